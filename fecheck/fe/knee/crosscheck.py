"""FE cross-check of a scene: the EF equilibrium, then the FE of the same geometry,
materials and load, compared on the same tibial faces.

1. The scene's EF equilibrium (`fecheck.model.run.run_scene`).
2. Per compartment the tibial surface the EF run used, extruded into a bonded cartilage
   layer by its thickness (`fecheck.fe.bodies.scene_bodies`, `fecheck.fe.bodies.solid`), pressed by
   the rigid femoral surface (sphere or mesh) with exact frictionless contact along the
   surface normals (`fecheck.fe.solve.joint`).
3. ``fe.mode = "joint"`` (default): the tibia's free DOFs are unknowns of the FE
   problem, under the scene's load, gravity and ligament springs, so the FE finds its
   own medial/lateral split and pose. ``"compartment"``: each compartment is pushed
   along the EF compartment force's line with that force's magnitude, from the EF pose.
4. Per compartment: force (vector, axial component, magnitude), p_max, p_mean, area,
   depth and centre of pressure of FE and EF; the FE pressure averaged onto the EF's
   faces beside the EF's own face pressure. For a transverse plateau with a uniform
   layer the axisymmetric FE, the EF closed form and Hertz at the FE's compartment force
   are added (the axisymmetric answer is then the 3D discretisation reference).

With a body beyond the tibia (`fecheck.fe.knee.registry`: the patella, ``patella.dir``):
its cartilage is a layer of its own on it, a second rigid body whose coordinates join the
tibia's under the loads the EF puts on it (the patella's quadriceps, patellar tendon and
patellofemoral bundles), the EF the tibia and the body solved together
(`fecheck.fe.knee.knee_body`); its contact is compared as a compartment (centre of
pressure in its frame) and left out of the split.

``fe.cartilage = "series"`` (default): the FE models one deformable layer (the tibial
side) under a rigid femoral surface; with ``scanned.thickness = "bone-distance"`` that
layer has the EF's series thickness (tibial + femoral cartilage). ``"two-layer"``: each
cartilage its own layer on its own bone, in frictionless contact (`fecheck.fe.knee.femoral`).
Units: mm, N, MPa; tibia frame for centres of pressure.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from fecheck.errors import FecheckError
from fecheck.fe.bodies.pose import FramePose
from fecheck.fe.bodies.scene_bodies import FEBody, refuse_unmodelled, scene_bodies
from fecheck.fe.bodies.settings import FESettings
from fecheck.fe.knee.knee_body import BodyAtEF, KneeBody
from fecheck.fe.knee.registry import scene_body
from fecheck.fe.pressure.recovery import pressure_peaks, smoothing_length, zero_contour_area
from fecheck.fe.pressure.results import ContactMetrics, FEContactResult, PressurePeaks, SideMetrics
from fecheck.fe.solve.joint import rigid_bodies
from fecheck.fe.solve.press import (
    FELayer,
    build_layers,
    carried_by,
    guard_bodies,
    joint_drive,
    push_drive,
    rigid_gaps,
    solve_pressed,
)
from fecheck.model.condyles import scene_knee
from fecheck.model.equilibrium import axial_force
from fecheck.model.notes import smoothing_notes
from fecheck.model.results import CompartmentResult, Pose, RunResult
from fecheck.model.reuse import building_once
from fecheck.reference.closed_forms import (
    DONAHUE_2002,
    column_stiffness,
    ef_sphere_on_plane,
    hertz_sphere_on_plane,
)
from fecheck.scene import Scene
from fecheck.statics.newton import pose
from geometry.roughness import Roughness, default_radius, roughness

ROUGH_FEATURE_SHARE = 0.1
"""The FE peak sits on a rough feature when the tibial sheet departs from its smoothed copy
near the peak by more than this share of the FE contact depth. Measured: 0.3 mm terraces
every 3 mm under a sphere (tests/fe/test_fe_roughness.py) depart by 23 % of the depth at the
peak and raise the vertex p_max 62 % above the flat sheet's; the shipped scanned knee's
sheets depart by 3 % (medial) and 5 % (lateral) at their peaks."""
SOLID_NOTE = ("the tibial body is the closed solid geometry.tibia_solid (Gmsh tetrahedra): "
              "its base fixed (fe.solid_base_deg), its walls free, frictionless contact on "
              "its articular face under a rigid femoral surface")
LAYER_NOTE = ("when a layer is good enough for an implant (validation/fe_implant.py, a "
              "generated insert 7-12 mm thick, contact radius / thickness 0.75-1.05, slopes "
              "up to 18 deg, contact away from the walls): a layer with the solid's own "
              "thickness map (fe.body = 'layer') came within 2.1 % of the solid on p_max and "
              "area and 0.1 mm on the centre of pressure; a uniform layer of the dwells' "
              "thickness was 12 % off on p_max and area. Near walls, posts or undercuts, or "
              "where the base is not parallel to the surface, mesh the solid")
SERIES_VS_TWO_LAYER = ("on the scanned knee (validation/fe_two_layer.py, full resolution, "
                       "800 N) the one-layer series model came within 3.4 % of the two-layer "
                       "FE on the face-averaged p_max (4.5 % on the vertex p_max), 0.03 "
                       "points on the medial/lateral split and 0.1 mm on the centres of "
                       "pressure, but its contact areas were 9-10 % smaller: good enough for "
                       "forces, split and where the load sits, not for the contact area")
DONAHUE_NOTE = ("* Donahue 2002 is another knee under another load (800 N, whole joint with "
                "menisci): a scale for the numbers, not a reference for this scene")


def stderr_log(message: str) -> None:
    """Progress of `fecheck fe` on standard error, one line per step."""
    print(f"fecheck fe: {message}", file=sys.stderr, flush=True)


@dataclass(frozen=True, eq=False)
class CompartmentCheck:
    """One compartment: FE and EF side by side, the FE maps and the flat-layer references.

    fe_pressure_MPa : (n_fe_points,) FE pressure at the FE surface vertices
    fe_face_pressure_MPa : (n_ef_faces,) FE pressure averaged onto the EF run's faces
    ef_face_pressure_MPa : (n_ef_faces,) EF face pressure on the same faces (None when the
        EF run's pressure lives on another mesh, e.g. contact.master = 'plateau')
    axisym, ef_closed_form, hertz : at the FE compartment force, flat uniform layers only
    peaks : the FE peak as a vertex value, averaged onto the EF faces and smoothed, with
        the lone-spike and rough-feature flags (None: not assessed)
    roughness : the tibial sheet against its smoothed copy (`geometry.roughness`)
    femoral_roughness : the same of the femoral sheet pressing it (None: an analytic one)
    """

    name: str
    fe: SideMetrics
    ef_model: SideMetrics
    layer: FELayer
    fe_pressure_MPa: np.ndarray
    fe_force_N: np.ndarray
    active: np.ndarray
    fe_face_pressure_MPa: np.ndarray
    ef_face_pressure_MPa: np.ndarray | None
    max_penetration_mm: float
    axisym: FEContactResult | None = None
    ef_closed_form: ContactMetrics | None = None
    hertz: ContactMetrics | None = None
    peaks: PressurePeaks | None = None
    roughness: Roughness | None = None
    femoral_roughness: Roughness | None = None

    @property
    def cop_distance_mm(self) -> float:
        """Distance between the FE and EF centres of pressure, mm (NaN if either is
        undefined)."""
        a, b = self.fe.center_of_pressure_mm, self.ef_model.center_of_pressure_mm
        if a is None or b is None:
            return math.nan
        return float(np.linalg.norm(np.asarray(a) - np.asarray(b)))

    def deviation(self) -> dict[str, float]:
        """FE vs the axisymmetric FE at the same load (the 3D discretisation error of a
        flat layer): relative p_max and area differences; {} when there is no reference."""
        if self.axisym is None:
            return {}
        a = self.axisym.metrics
        return {"max_pressure": self.fe.max_pressure_MPa / a.max_pressure_MPa - 1,
                "area": self.fe.area_mm2 / a.area_mm2 - 1}

    def as_dict(self) -> dict[str, Any]:
        def metrics(m):
            return None if m is None else m.as_dict()

        return {"fe": self.fe.as_dict(), "ef_model": self.ef_model.as_dict(),
                "cop_distance_mm": _num(self.cop_distance_mm),
                "max_penetration_mm": self.max_penetration_mm,
                "min_contact_force_N": float(self.fe_force_N.min()),
                "vertices_in_contact": int(self.active.sum()),
                "fe_geometry": {"tibial_surface": self.layer.body.tibial_surface,
                                "femoral_surface": self.layer.body.femoral_surface,
                                "smoothing_rounds": self.layer.smoothing_rounds,
                                "prepared_sheet": self.layer.to_ef is not None},
                "axisym": None if self.axisym is None else self.axisym.as_dict(),
                "fe_vs_axisym": self.deviation(),
                "ef_closed_form": metrics(self.ef_closed_form), "hertz": metrics(self.hertz),
                "fe_peaks": metrics(self.peaks), "tibial_roughness": metrics(self.roughness),
                "femoral_roughness": metrics(self.femoral_roughness),
                "donahue_2002": {f"{s:g}mm": m.as_dict()
                                 for s, m in DONAHUE_2002.get(self.name, {}).items()}}


@dataclass(frozen=True, eq=False)
class CrossCheck:
    """The FE cross-check of a scene."""

    compartments: dict[str, CompartmentCheck]
    settings: FESettings
    material: dict[str, float]
    pose: dict[str, Pose]
    """The tibia's pose of the FE ("fe") and of the EF run ("ef")."""
    geometry: dict[str, Any]
    timing_s: dict[str, float]
    notes: tuple[str, ...] = field(default=())
    ef_run: RunResult | None = None
    """The EF run compared (the error estimate's FE levels start from its pose)."""
    extra: BodyAtEF | None = None
    """The body beyond the tibia at the EF, with the FE's coordinates (None: the tibia
    alone)."""

    def split(self, side: str) -> dict[str, float]:
        """{tibial compartment: share of the summed tibial compartment force magnitudes}
        of `side` ("fe" or "ef_model")."""
        forces = {c: getattr(chk, side).force_N for c, chk in self.compartments.items()
                  if chk.layer.body.carrier == "T"}
        total = sum(forces.values())
        return {c: f / total if total > 0 else math.nan for c, f in forces.items()}

    def as_dict(self) -> dict[str, Any]:
        out = {"mode": self.settings.mode,
               "compartments": {c: chk.as_dict() for c, chk in self.compartments.items()},
               "split": {"fe": self.split("fe"), "ef_model": self.split("ef_model")},
               "fe_geometry": self.geometry,
               "pose": {k: dict(v) for k, v in self.pose.items()},
               "settings": dict(self.settings.__dict__), "material": self.material,
               "timing_s": self.timing_s, "notes": list(self.notes)}
        if self.extra is not None:
            out |= self.extra.as_dict()
        return out


def _num(value: float) -> float | None:
    return float(value) if value is not None and math.isfinite(value) else None


# ---------------------------------------------------------------------- the metrics
def _fe_metrics(layer: FELayer, force_N: np.ndarray, active: np.ndarray, gaps0: np.ndarray,
                X_WB: FramePose) -> tuple[SideMetrics, np.ndarray]:
    """FE metrics of one compartment (forces at the surface vertices, rigid gaps at the
    solution pose X_WB of the body that carries it) and the vertex pressures."""
    surface, solid = layer.surface, layer.solid
    pressure = force_N / solid.tributary_mm2
    vector = X_WB.vectors(-(force_N @ solid.normals))            # on the body, world
    total = float(force_N.sum())
    area = zero_contour_area(surface.points, surface.faces, pressure, active)
    cop = (force_N @ surface.points) / total if total > 0 else None
    depth = float(max(0.0, -gaps0.min()))
    return SideMetrics(vector, axial_force(vector, X_WB.rotation), float(pressure.max()),
                       total / area if area > 0 else math.nan, area, depth, cop), pressure


def ef_metrics(res: CompartmentResult, X_WB: FramePose) -> SideMetrics:
    """The EF run's metrics of one compartment, its centre of pressure in the frame of the
    body B at X_WB that carries it (from its face pressures and in-contact face areas;
    None for a point contact)."""
    cop = None
    if res.face_area_mm2 is not None and res.face_pressure_MPa is not None:
        load = res.face_pressure_MPa * res.face_area_mm2
        if load.sum() > 0:
            centroid = res.slave_points[res.slave_faces].mean(axis=1)
            cop = X_WB.rotation.T @ ((load @ centroid) / load.sum() - X_WB.translation)
    vector = (np.full(3, math.nan) if res.force_vector_N is None
              else np.asarray(res.force_vector_N, dtype=float))
    return SideMetrics(vector, res.axial_force_N, res.max_pressure_MPa,
                       res.mean_pressure_MPa, res.area_mm2, res.max_depth_mm, cop)


def _on_ef_faces(layer: FELayer, pressure: np.ndarray) -> np.ndarray:
    """FE vertex pressure averaged onto the EF faces (over each face's FE children; an EF
    face with none, as where a closed solid's articular face stops short of the sheet's
    rim or is coarser than the sheet, takes the FE face nearest its centroid), or
    interpolated at their centroids from a prepared sheet."""
    if layer.to_ef is not None:
        return layer.to_ef @ pressure
    face = pressure[layer.surface.faces].mean(axis=1)
    n = layer.body.surface.n_faces
    total = np.bincount(layer.parent, weights=face * layer.surface.face_areas, minlength=n)
    area = np.bincount(layer.parent, weights=layer.surface.face_areas, minlength=n)
    childless = area <= 0
    if childless.any():
        ef = layer.body.surface.face_centroids[childless]
        nearest = cKDTree(layer.surface.face_centroids).query(ef)[1]
        total[childless], area[childless] = face[nearest], 1.0
    return total / area


def _ef_face_pressure(layer: FELayer, res: CompartmentResult, X_WB: FramePose
                      ) -> np.ndarray | None:
    """The EF face pressure when it lives on this layer's EF faces (its body at X_WB),
    else None."""
    ef = layer.body.surface
    if (res.face_pressure_MPa is None or res.slave_faces is None
            or res.slave_faces.shape != ef.faces.shape
            or not np.array_equal(res.slave_faces, ef.faces)):
        return None
    back = (res.slave_points - X_WB.translation) @ X_WB.rotation   # world → body frame
    if not np.allclose(back, ef.points, atol=1e-6):
        return None
    return np.asarray(res.face_pressure_MPa, dtype=float)


def _flat_references(scene: Scene, layer: FELayer, load_N: float, settings: FESettings
                     ) -> dict[str, Any]:
    """Axisymmetric FE, EF closed form and Hertz at `load_N` for a transverse plateau with
    a uniform layer under a sphere ({} otherwise)."""
    from fecheck.fe.bodies.indenter import SphereIndenter
    from fecheck.fe.reference.axisym import axisym_sphere_on_layer

    body = layer.body
    if (scene["plateau.kind"] != "transverse" or scene["model.kind"] != "sphere-plane"
            or not isinstance(body.indenter, SphereIndenter) or load_N <= 0):
        return {}
    E, nu, h = (scene["contact.youngs_MPa"], scene["contact.poisson"],
                scene["contact.thickness_mm"])
    radius = body.indenter.radius_mm
    return {"axisym": axisym_sphere_on_layer(load_N, radius, E, nu, h,
                                             size_mm=settings.axisym_size_mm,
                                             solver=settings.solver),
            "ef_closed_form": ef_sphere_on_plane(load_N, radius, E, nu, h),
            "hertz": hertz_sphere_on_plane(load_N, radius, E, nu)}


def assess_peaks(name: str, layer: FELayer, pressure: np.ndarray, face_pressure: np.ndarray,
                 depth_mm: float, E_MPa: float) -> tuple[PressurePeaks, Roughness, list[str]]:
    """The FE peaks of one compartment (`pressure_peaks`, bound: the modulus `E_MPa`), the
    roughness of its tibial sheet, and the warnings: a lone-vertex spike, or a peak on a
    rough feature (more than `ROUGH_FEATURE_SHARE` of the contact depth `depth_mm` from the
    smoothed sheet within the smoothing length of the peak)."""
    s, sheet = layer.surface, layer.body.surface
    length = smoothing_length(s.points, s.faces, pressure > 0)
    peaks = pressure_peaks(s.points, s.faces, layer.solid.tributary_mm2, pressure,
                           float(np.nanmax(face_pressure)), E_MPa, length)
    rough = roughness(sheet, default_radius(sheet))
    feature = rough.local_mm(sheet.points, peaks.vertex_at_mm, length)
    on_rough = depth_mm > 0 and feature > ROUGH_FEATURE_SHARE * depth_mm
    peaks = dataclasses.replace(peaks, feature_mm=feature, rough=bool(on_rough))
    x, y, z = peaks.vertex_at_mm
    where = (f"{name}: the FE vertex p_max {peaks.vertex_MPa:.3g} MPa at ({x:.1f}, {y:.1f}, "
             f"{z:.1f}) mm")
    beside = (f"the FE p_max averaged on the EF faces is {peaks.face_MPa:.3g} MPa, smoothed "
              f"over {length:.2f} mm {peaks.smoothed_MPa:.3g} MPa")
    feature_text = (f"the tibial sheet is {feature:.3f} mm from its copy smoothed over "
                    f"{rough.radius_mm:.2f} mm there ({feature / depth_mm:.0%} of the "
                    f"{depth_mm:.3f} mm contact depth)" if depth_mm > 0 else "")
    out = []
    if peaks.spike:
        rough_text = f"; it sits on a rough feature: {feature_text}" if on_rough else ""
        out.append(f"{where} is a lone-vertex spike ({peaks.spike}), not a physical "
                   f"pressure; {beside}{rough_text}")
    elif on_rough:
        out.append(f"{where} sits on a rough feature: {feature_text}, so the FE peak follows "
                   f"the segmentation's roughness; {beside}; geometry.smooth_mm smooths the "
                   "sheets")
    return peaks, rough, out


# ---------------------------------------------------------------------- the scene
def _refuse_constraints(scene: Scene, settings: FESettings) -> None:
    if settings.mode != "joint":
        return
    if scene["constraints.equal_forces"]:
        raise FecheckError("fe.mode = 'joint' lets the FE find its own medial/lateral split, "
                           "which constraints.equal_forces would fix: use fe.mode = "
                           "'compartment' (each compartment under its EF force)")
    if scene["ligaments.model"] == "rod":
        raise FecheckError("fe.mode = 'joint' models ligament springs, not rigid rods "
                           "(ligaments.model = 'rod'): use ligaments.model = 'spring' or "
                           "fe.mode = 'compartment'")


def _added(scene: Scene, settings: FESettings, extra: BodyAtEF | None
           ) -> tuple[KneeBody | None, Any]:
    """The scene's body beyond the tibia (`fecheck.fe.knee.registry.scene_body`) and its
    model (that of `extra` when given), else (None, None); refuses what the FE does not
    model with it (`KneeBody.refuse`)."""
    kind = scene_body(scene)
    if kind is None:
        return None, None
    kind.refuse(scene, settings)
    return kind, kind.model(scene) if extra is None else extra.model


def _ef(scene: Scene, log: Callable[[str], None], ef: tuple[RunResult, float] | None,
        extra: BodyAtEF | None, kind: KneeBody | None, model: Any,
        flexion: tuple[float, np.ndarray] | None
        ) -> tuple[RunResult, float, BodyAtEF | None]:
    """The EF run compared, its time (s) and the body beyond the tibia at the EF: `ef` and
    `extra` as given, or solved here (`_ef_run`)."""
    if ef is None:
        return _ef_run(scene, log, kind, model, flexion)
    _loaded(ef[0], extra)
    return ef[0], ef[1], extra


def _ef_run(scene: Scene, log: Callable[[str], None], kind: KneeBody | None = None,
            model: Any = None, flexion: tuple[float, np.ndarray] | None = None
            ) -> tuple[RunResult, float, BodyAtEF | None]:
    """The scene's EF run, its time (s) and, with a body beyond the tibia (`kind`, its
    `model`), the tibia and that body solved together (`KneeBody.ef`)."""
    from fecheck.model.run import run_scene

    log("solving the EF equilibrium" + ("" if kind is None else f" with the {kind.name}"))
    t0 = time.perf_counter()
    extra = None
    if kind is None:
        run = run_scene(scene)
    else:
        run, extra = kind.ef(scene, flexion, model)
    seconds = time.perf_counter() - t0
    _loaded(run, extra)
    return run, seconds, extra


def _loaded(run: RunResult, extra: BodyAtEF | None) -> None:
    """`FecheckError` unless the EF `run` converged with every compartment (and the
    contact of the body beyond the tibia) loaded."""
    if extra is not None and not extra.contact.force_N > 0:
        raise FecheckError(f"the {extra.kind.name} carries no load at the EF equilibrium: the "
                           "FE cross-check compares loaded contacts; "
                           f"{extra.kind.unloaded_hint}")
    if not run.converged:
        raise FecheckError("the EF equilibrium of this scene did not converge; fix the scene "
                           "(see `fecheck run`) before the FE cross-check")
    for c, res in run.compartments.items():
        if not (math.isfinite(res.force_N) and res.force_N > 0):
            raise FecheckError(f"the {c} compartment carries no load at the EF equilibrium "
                               f"({res.force_N:g} N): the FE cross-check compares loaded "
                               "compartments; raise load.force_N or move load.point_mm")


def _expected_depth(scene: Scene, run: RunResult, extra: BodyAtEF | None = None) -> float:
    """The deepest FE indentation to expect, mm: per compartment the EF run's depth, but
    no more than the linear EF of the scene's own layer would give at that force (a law
    with another stiffness, e.g. 'volumetric', can sink the EF far deeper than the layer
    the FE models); a femur-tibia scene, with no sphere, the EF run's depth."""
    E, nu, h = (scene["contact.youngs_MPa"], scene["contact.poisson"],
                scene["contact.thickness_mm"])
    deepest = 0.0
    knee = None if scene["model.kind"] == "femur-tibia" else scene_knee(scene)
    for c, res in run.compartments.items():
        if knee is None:                               # no sphere: the EF run's own depth
            deepest = max(deepest, res.max_depth_mm)
            continue
        layer = ef_sphere_on_plane(res.force_N, knee.radius_mm(c), E, nu, h).depth_mm
        ef = res.max_depth_mm if math.isfinite(res.max_depth_mm) else layer
        deepest = max(deepest, min(ef, layer))
    if extra is not None:
        deepest = max(deepest, extra.contact.max_depth_mm)
    return deepest


def _femoral(scene: Scene, layers: Sequence[FELayer], settings: FESettings,
             log: Callable[[str], None]) -> Callable | None:
    """The femoral layers' builder of ``fe.cartilage = "two-layer"`` (None: series)."""
    from fecheck.fe.knee.femoral import FemoralBuilder, femoral_sheet

    if settings.cartilage != "two-layer":
        return None
    prepared = [lay.body.name for lay in layers if lay.to_ef is not None]
    if prepared:
        raise FecheckError(f"fe.cartilage = 'two-layer' meshes the sheets as read, but the "
                           f"{' and '.join(prepared)} tibial sheet needs preparing to extrude "
                           "(fe.prepare): use fe.cartilage = 'series'")
    return FemoralBuilder(femoral_sheet(scene, layers[0].body.indenter.mesh), settings, log)


def _solve(scene: Scene, layers: Sequence[FELayer], run: RunResult, settings: FESettings,
           log: Callable[[str], None], flexion: tuple[float, np.ndarray] | None = None,
           extra: BodyAtEF | None = None
           ) -> tuple[dict, np.ndarray, np.ndarray | None, float, float]:
    """FE solve(s) of the mode: {compartment: (layer, contact, worst penetration, X_WB
    the pose of the body that carries it at that compartment's solution)}, the tibia's FE
    q (5,) (the EF pose in compartment mode), with `extra` the body's FE coordinates (else
    None), the condensation time and the femoral layers' build time (s; 0 for the series
    model); `flexion` as in `cross_check`."""
    from fecheck.model.run import ligament_springs

    q_ef = np.asarray(run.pose.q, dtype=float)
    margin = settings.candidate_gap_mm + _expected_depth(scene, run, extra)
    femoral = _femoral(scene, layers, settings, log)
    if settings.mode == "joint":
        if extra is None:
            drive = joint_drive(scene, q_ef, ligament_springs(scene), flexion)
        else:
            drive = extra.kind.drive(scene, q_ef, ligament_springs(scene),
                                     flexion or (math.radians(scene["dofs.flexion_deg"]), None),
                                     extra)
        sol, condense, _, worst = solve_pressed(layers, drive, margin, settings, log, femoral)
        at = rigid_bodies(drive.pose, drive.basis, sol.q)
        out = {lay.body.name: (lay, lc, worst, carried_by(lay, at))
               for lay, lc in zip(layers, sol.layers, strict=True)}
        coordinates = None if extra is None else sol.q[len(sol.q) - len(extra.q):]
        return out, drive.full(sol.q), coordinates, condense, getattr(femoral, "seconds", 0.0)
    X_WT = _ef_pose(scene, q_ef, flexion)
    out, condense = {}, 0.0
    for lay in layers:
        force = run.compartments[lay.body.name].force_vector_N
        drive = push_drive(X_WT, np.asarray(force, dtype=float))
        sol, seconds, _, worst = solve_pressed([lay], drive, margin, settings, log, femoral)
        out[lay.body.name] = (lay, sol.layers[0], worst, drive.pose(sol.q))
        condense += seconds
    return out, q_ef, None, condense, getattr(femoral, "seconds", 0.0)


def _ef_side(name: str, run: RunResult, extra: BodyAtEF | None, X_WT: FramePose
             ) -> tuple[CompartmentResult, FramePose]:
    """The EF result of compartment `name` and the EF pose of the body that carries it:
    the body's beyond the tibia for its contact, else the tibia's X_WT."""
    if extra is not None and name == extra.kind.compartment:
        return extra.contact, extra.ef_pose
    return run.compartments[name], X_WT


def _ef_pose(scene: Scene, q: np.ndarray, flexion: tuple[float, np.ndarray] | None
             ) -> FramePose:
    """The tibia's pose X_WT at q (5,): flexion dofs.flexion_deg about x, or `flexion`."""
    theta, base = flexion or (math.radians(scene["dofs.flexion_deg"]), None)
    return FramePose(*pose(np.asarray(q, dtype=float), theta, base), "W", "T")


def cross_check(scene: Scene, *, mode: str | None = None, refine: int | None = None,
                log: Callable[[str], None] | None = stderr_log,
                ef: tuple[RunResult, float] | None = None,
                flexion: tuple[float, np.ndarray] | None = None,
                extra: BodyAtEF | None = None) -> CrossCheck:
    """The FE cross-check of `scene` (module docstring); `mode` and `refine` override
    ``fe.mode`` and ``fe.refine``; `log` gets progress lines (None: silent); `ef` the
    scene's EF run and its time (s) when the caller has them (None: solved here);
    `flexion` = (θx rad, Q (3, 3)): the EF run's flexion, held about Q's first column
    (`fecheck flex`; None: dofs.flexion_deg about x); `extra`: with a body beyond the
    tibia (`fecheck.fe.knee.registry.scene_body`, e.g. patella.dir), that body at the EF
    solved with `ef` (for the patella `fecheck.fe.knee.patella_layer.ef_knee`; None:
    solved here).

    Raises
    ------
    FecheckError
        A scene the FE cannot model faithfully (no cartilage, constraints in joint mode,
        an unloaded compartment), or an FE answer that is not physical.
    """
    with building_once():                  # the EF and the FE read one knee
        return _cross_check(scene, mode, refine, log, ef, flexion, extra)


def _cross_check(scene: Scene, mode: str | None, refine: int | None,
                 log: Callable[[str], None] | None, ef: tuple[RunResult, float] | None,
                 flexion: tuple[float, np.ndarray] | None, extra: BodyAtEF | None
                 ) -> CrossCheck:
    say = log or (lambda message: None)
    from fecheck.fe.knee.femoral import femoral_material, refuse_two_layer

    settings = FESettings.from_scene(scene, mode=mode, refine=refine)
    refuse_unmodelled(scene)
    _refuse_constraints(scene, settings)
    refuse_two_layer(scene, settings)
    E, nu = scene["contact.youngs_MPa"], scene["contact.poisson"]
    t0 = time.perf_counter()
    bodies = scene_bodies(scene)
    kind, model = _added(scene, settings, extra)
    if kind is not None:
        bodies.append(kind.fe_body(scene, model))
    meshed = guard_bodies(bodies, settings, nu)         # before the EF run, not after it
    run, ef_seconds, extra = _ef(scene, say, ef, extra, kind, model, flexion)
    t1 = time.perf_counter()
    layers = build_layers(bodies, E, nu, settings, say, meshed)
    t2 = time.perf_counter()
    solved, q_fe, coordinates, condense, femoral_s = _solve(scene, layers, run, settings, say,
                                                            flexion, extra)
    t3 = time.perf_counter()
    if extra is not None:
        extra = extra.with_fe(coordinates)
    tibia_ef = _ef_pose(scene, run.pose.q, flexion)
    checks, alerts, femoral = {}, [], {}
    for name, (lay, lc, worst, X_WB) in solved.items():
        fe, pressure = _fe_metrics(lay, lc.force_N, lc.active, rigid_gaps(lay, X_WB), X_WB)
        res, X_WB_ef = _ef_side(name, run, extra, tibia_ef)
        refs = _flat_references(scene, lay, float(lc.force_N.sum()), settings)
        on_faces = _on_ef_faces(lay, pressure)
        peaks, rough, said = assess_peaks(name, lay, pressure, on_faces, fe.depth_mm, E)
        alerts += said
        femur = getattr(lay.body.indenter, "mesh", None)
        if femur is not None and id(femur) not in femoral:
            femoral[id(femur)] = roughness(femur, default_radius(femur))
        checks[name] = CompartmentCheck(
            name, fe, ef_metrics(res, X_WB_ef), lay, pressure, lc.force_N, lc.active,
            on_faces, _ef_face_pressure(lay, res, X_WB_ef), worst, peaks=peaks,
            roughness=rough, femoral_roughness=femoral.get(id(femur)), **refs)
    for text in alerts:
        warnings.warn(text, stacklevel=2)
    t4 = time.perf_counter()
    femurs = _femurs(solved)
    dofs = sum(sol.n_dofs for sol in _solids(layers)) + sum(f.solid.n_dofs for f in femurs)
    geometry = _geometry(layers, dofs) | {"cartilage": settings.cartilage}
    if femurs:
        e_f, nu_f = femoral_material(scene)
        geometry |= {"deformable_layers": 2, "femoral_E_MPa": e_f, "femoral_nu": nu_f,
                     "elements": geometry["elements"] + int(sum(len(f.solid.mesh.tets)
                                                                for f in femurs)),
                     "nodes": geometry["nodes"] + int(sum(f.solid.n_nodes for f in femurs))}
    timing = {"ef_equilibrium": ef_seconds, "fe_build": t2 - t1 + femoral_s,
              "fe_condense": condense, "fe_contact": t3 - t2 - condense - femoral_s,
              "references": t4 - t3, "total": t4 - t0, "fe": t3 - t1}
    timing["ef_over_fe"] = ef_seconds / timing["fe"]
    notes = [DONAHUE_NOTE]
    prepared = [lay.body.name for lay in layers if lay.to_ef is not None]
    if prepared:
        notes.insert(0, f"the FE meshes prepared sheets ({', '.join(prepared)}: rims trimmed, "
                        f"remeshed at fe.size_mm {settings.size_mm:g} mm, smoothed over "
                        f"fe.smooth_mm {settings.smooth_mm:g} mm, with the femoral surface "
                        "above), its pressures interpolated onto the EF faces")
    notes[:0] = smoothing_notes(scene)
    if extra is not None:
        notes.insert(0, extra.kind.note)
    if geometry["thickness_source"] in ("solid", "solid-distance"):
        notes[:0] = [SOLID_NOTE, LAYER_NOTE] if geometry["thickness_source"] == "solid" \
            else [LAYER_NOTE]
    if femurs:
        notes.insert(0, "two deformable layers (fe.cartilage = 'two-layer'): the tibial and "
                        "the femoral cartilage each extruded toward its own bone by its own "
                        f"thickness ({geometry['thickness_source']}) and bonded there, "
                        f"tibial E {E:g} MPa ν {nu:g}, femoral E {geometry['femoral_E_MPa']:g} "
                        f"MPa ν {geometry['femoral_nu']:g}, frictionless node-to-surface "
                        "contact between them; "
                        + SERIES_VS_TWO_LAYER)
    elif geometry["thickness_source"] == "bone-distance":
        notes.insert(0, "one deformable layer on the tibia with the EF's series thickness "
                        "(tibial + femoral cartilage, from the bone distances) under a rigid "
                        "femoral surface: two deformable layers in contact are not modelled")
    return CrossCheck(checks, settings,
                      {"E_MPa": E, "nu": nu, "thickness_mm": scene["contact.thickness_mm"],
                       "ef_k_N_per_mm3": column_stiffness(E, nu, scene["contact.thickness_mm"])},
                      {"fe": Pose.of(q_fe, side=run.pose.side), "ef": run.pose}, geometry,
                      timing, tuple(notes), run, extra)


def fe_level(scene: Scene, bodies: Sequence[FEBody], run: RunResult, settings: FESettings,
             log: Callable[[str], None], extra: BodyAtEF | None = None
             ) -> tuple[dict[str, tuple], int, float]:
    """The FE of `bodies` at `settings` from the EF `run`'s pose (and the EF pose of the
    body beyond the tibia, `extra`) under the load control of ``settings.mode`` (another
    discretization level of a cross-check): {compartment: (layer, FE metrics, vertex
    pressures MPa)}, the FE dofs and time, s."""
    E, nu = scene["contact.youngs_MPa"], scene["contact.poisson"]
    t0 = time.perf_counter()
    layers = build_layers(bodies, E, nu, settings, log)
    solved = _solve(scene, layers, run, settings, log, extra=extra)[0]
    out = {}
    for name, (lay, lc, _, X_WB) in solved.items():
        out[name] = (lay, *_fe_metrics(lay, lc.force_N, lc.active, rigid_gaps(lay, X_WB),
                                       X_WB))
    dofs = sum(sol.n_dofs for sol in _solids(layers)) + sum(f.solid.n_dofs
                                                            for f in _femurs(solved))
    return out, dofs, time.perf_counter() - t0


def _femurs(solved: dict) -> list:
    """The distinct deformable femoral layers of the solved compartments (none: series)."""
    return list({id(lc.femur): lc.femur for _, lc, _, _ in solved.values()
                 if lc.femur is not None}.values())


def on_ef_faces(layer: FELayer, pressure: np.ndarray) -> np.ndarray:
    """FE vertex `pressure` (MPa) of `layer` averaged onto its EF faces."""
    return _on_ef_faces(layer, pressure)


def _geometry(layers: Sequence[FELayer], dofs: int) -> dict[str, Any]:
    """The top-level `fe_geometry` of the JSON."""
    def joined(values):
        unique = list(dict.fromkeys(values))
        return unique[0] if len(unique) == 1 else " + ".join(unique)

    edges = []
    for lay in layers:
        s = lay.surface
        e = s.points[s.faces[:, [1, 2, 0]]] - s.points[s.faces]
        edges.append(np.linalg.norm(e, axis=2).min())
    return {"tibial_surface": joined(lay.body.tibial_surface for lay in layers),
            "femoral_surface": joined(lay.body.femoral_surface for lay in layers),
            "thickness_source": joined(lay.body.thickness_source for lay in layers),
            "deformable_layers": 1,
            "elements": int(sum(len(sol.mesh.tets) for sol in _solids(layers))),
            "nodes": int(sum(sol.n_nodes for sol in _solids(layers))),
            "dofs": int(dofs),
            "smallest_size_mm": float(min(edges))} | _element(layers)


def _solids(layers: Sequence[FELayer]) -> list:
    """The distinct assembled solids of `layers` (the compartments of one closed tibial
    solid share one)."""
    return list({id(lay.solid.K): lay.solid for lay in layers}.values())


def _element(layers: Sequence[FELayer]) -> dict[str, Any]:
    """The element and, for extruded layers, the levels through the thickness."""
    if any(lay.body.solid is not None for lay in layers):
        return {"element": "quadratic tetrahedron (P2), Gmsh tetrahedralization of the "
                           "closed tibial solid"}
    return {"levels": int(len(layers[0].solid.mesh.tets) // (3 * layers[0].surface.n_faces)),
            "element": "quadratic tetrahedron (P2), prisms of the extruded surface split in 3"}
