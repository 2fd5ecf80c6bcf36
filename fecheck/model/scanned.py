"""Runners for the models on knee surfaces read from files (thesis §5.2.2-5.2.3), on the
shared statics.

* ``sphere-tibia``: the femoral condyle spheres of the scene's knee on the tibial
  articular surface; `scanned.condyle` = "hemisphere" cuts each sphere by a sagittal
  plane `scanned.hemisphere_cut_mm` from its centre towards the notch (thesis Fig. 5.13:
  no contact with the intercondylar eminence).
* ``femur-tibia``: the femoral articular surface on the tibial one (natural cartilage or
  an implant's component and insert); no landmark is read.
* ``sphere-plane`` scenes (H3's inclined/polynomial plateaus) come here only for
  `scanned.ligaments` = "bundles"; their contact pairs are H3's.

The surfaces are the scene's ``[geometry]`` files (`fecheck.scene.surfaces`). Slave: each
tibial compartment (an open sheet with n_z > 0), optionally decimated to
`scanned.decimate_faces` in total; master (femur, fixed): the sphere (closed form), the
hemisphere mesh or the femoral surface (libigl AABB closest point, inside by the side of
the closest face normal — no hole filling, where ray parity fails on an open sheet).
Contact law: the scene's, with a uniform thickness `contact.thickness_mm`; or, for
`scanned.thickness` = "bone-distance", the linear EF with a stiffness per slave face
from the tibial and femoral cartilage thicknesses in series (`fecheck.laws.layer`).

Ligaments: `scanned.ligaments` = "bundles" adds the bundles of ``geometry.ligaments``
(Blankevoort 1991 springs, straight paths, own slack lengths and stiffness).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

import numpy as np

from fecheck.contact.analytic import Sphere
from fecheck.contact.pair import ContactPair
from fecheck.errors import FecheckError
from fecheck.laws import layer
from fecheck.laws.registry import laws_with, spec_of
from fecheck.model import sphere_plane
from fecheck.model.assembly import (
    Compartment,
    applied_load,
    law_factory,
    law_inputs,
)
from fecheck.model.condyles import fit_note, scene_knee
from fecheck.model.equilibrium import compartment_results, not_converged_note, solve_equilibrium
from fecheck.model.knee_surfaces import femoral_master, tibial_slaves
from fecheck.model.notes import layer_depth_notes, mesh_resolution_notes, smoothing_notes
from fecheck.model.plausibility import before_solve, check_meshes
from fecheck.model.results import LigamentResult, Pose, RunResult, SolveRecord
from fecheck.model.reuse import reusable
from fecheck.scene import Scene, surfaces
from fecheck.scene.bundles import Bundle, read_bundles
from fecheck.scene.constants import COMPARTMENTS
from fecheck.statics.ligaments import SpringLigament, SpringSet, transition_strain_check
from fecheck.statics.wrapping import WrapObject
from geometry.cache import cached_arrays
from geometry.cap import spherical_cap


def _hemisphere(scene: Scene, compartment: str):
    """The condyle sphere cut by a sagittal plane towards the notch, closed by a flat face
    on the cut: slave points beyond the cut are then closest to that face and outside
    (an open cap would count the points past its rim as inside)."""
    knee = scene_knee(scene)
    centre, radius = knee.condyle_center[compartment], knee.radius_mm(compartment)
    notch = np.array([1.0 if centre[0] < 0 else -1.0, 0.0, 0.0])
    cut = centre + scene["scanned.hemisphere_cut_mm"] * notch
    return spherical_cap(radius, scene["mesh.sphere_subdivisions"], centre,
                         cut_point=cut, cut_normal=notch, closed=True,
                         method=scene["mesh.method"])


@reusable
def femoral_masters(scene: Scene) -> dict:
    kind = scene["model.kind"]
    if kind == "femur-tibia":
        femur = femoral_master(scene)
        return {c: femur for c in COMPARTMENTS}
    knee = scene_knee(scene)
    if scene["scanned.condyle"] == "hemisphere":
        return {c: _hemisphere(scene, c) for c in COMPARTMENTS}
    return {c: Sphere(knee.condyle_center[c], knee.radius_mm(c)) for c in COMPARTMENTS}


def slave_thickness(scene: Scene, slave) -> np.ndarray:
    """Per-face foundation thickness (mm) of a tibial slave: tibial plus femoral cartilage
    in series, each from the distance to its bone (`fecheck.laws.layer`); cached on disk
    by the meshes' content."""
    femur = femoral_master(scene)
    femur_bone, tibia_bone = surfaces.bone(scene, "femur"), surfaces.bone(scene, "tibia")

    def build() -> tuple[np.ndarray]:
        fem_h = layer.bone_distance_thickness(femur, femur_bone, name="geometry.femur_bone")
        tib_h = layer.bone_distance_thickness(slave, tibia_bone, name="geometry.tibia_bone")
        return (layer.series_thickness(slave, tib_h, femur, fem_h),)

    return cached_arrays("series-thickness", [slave, femur, femur_bone, tibia_bone], build)[0]


def slave_sides(scene: Scene, slave) -> tuple[np.ndarray, np.ndarray]:
    """Per-face (tibial, femoral) cartilage thickness (mm) under each face of a tibial
    slave, each from the distance to its bone, the femoral one at the femoral face closest
    to the slave face (`fecheck.laws.layer`); cached on disk by the meshes' content."""
    femur = femoral_master(scene)
    femur_bone, tibia_bone = surfaces.bone(scene, "femur"), surfaces.bone(scene, "tibia")

    def build() -> tuple[np.ndarray, np.ndarray]:
        fem_h = layer.bone_distance_thickness(femur, femur_bone, name="geometry.femur_bone")
        return (layer.bone_distance_thickness(slave, tibia_bone, name="geometry.tibia_bone"),
                layer.opposite_thickness(slave, femur, fem_h))

    return cached_arrays("side-thickness", [slave, femur, femur_bone, tibia_bone], build)


@reusable
def series_thicknesses(scene: Scene) -> dict[str, np.ndarray]:
    """{compartment: `slave_thickness` of its tibial slave (`tibial_slaves`)}, per face, mm;
    kept while the geometry is."""
    return {c: slave_thickness(scene, slave) for c, slave in tibial_slaves(scene).items()}


@reusable
def _side_thicknesses(scene: Scene) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """{compartment: `slave_sides` of its slave}, kept while the geometry is."""
    return {c: slave_sides(scene, pair.slave) for c, (pair, _) in contact_pairs(scene).items()}


def _face_thickness(scene: Scene, compartment: str) -> np.ndarray:
    """The per-face foundation thickness (mm) of a compartment's slave in the tibial
    material: the series total, or with a femoral material of its own the equivalent
    thickness (`fecheck.laws.layer.Sides.equivalent_thickness`)."""
    sides, scale = layer.sides(scene), scene["scanned.thickness_scale"]
    if not sides.own_material:
        return scale * series_thicknesses(scene)[compartment]
    tibial, femoral = _side_thicknesses(scene)[compartment]
    return sides.equivalent_thickness(scale * tibial, scale * femoral)


def _law(scene: Scene, radius_mm: float, compartment: str):
    """The compartment's law (`fecheck.laws.registry`): over the bone-distance thickness
    map where the scene asks for it and the law takes one (`LawSpec.per_face`)."""
    spec = spec_of(scene)
    if scene["scanned.thickness"] == "uniform":
        return law_factory(scene)(radius_mm, compartment)
    if spec.per_face is None:
        names = " or ".join(f"'{n}'" for n in laws_with(lambda s: s.per_face is not None))
        raise FecheckError("scanned.thickness = 'bone-distance' sets a linear EF stiffness "
                           f"per face: use contact.law = {names} (or "
                           "scanned.thickness = 'uniform')")
    return spec.per_face(law_inputs(scene), lambda: _face_thickness(scene, compartment),
                         radius_mm, compartment)


@reusable
def contact_pairs(scene: Scene) -> dict[str, tuple[ContactPair, float]]:
    """{compartment: (contact pair, condyle radius mm or NaN)} of a sphere-tibia or
    femur-tibia scene: the geometry alone, so that a change of material or law (a
    population's sample) keeps the pairs and their broad-phase sets."""
    kind = scene["model.kind"]
    slaves, masters = tibial_slaves(scene), femoral_masters(scene)
    opts = {"method": scene["contact.detection"], "area": scene["contact.area"],
            "margin_mm": scene["contact.margin_mm"]}
    knee = scene_knee(scene) if kind == "sphere-tibia" else None
    return {c: (ContactPair(slaves[c], masters[c], **opts),
                knee.radius_mm(c) if knee is not None else math.nan) for c in COMPARTMENTS}


@reusable
def build_compartments(scene: Scene) -> list[Compartment]:
    """Contact pairs and laws of a sphere-tibia or femur-tibia scene (tibia slaves)."""
    kind = scene["model.kind"]
    if kind == "sphere-plane":
        return sphere_plane.build_compartments(scene)
    if kind not in ("sphere-tibia", "femur-tibia"):
        raise FecheckError(f"model.kind {kind!r} is not a scanned-knee model")
    out = []
    for c, (pair, radius) in contact_pairs(scene).items():
        out.append(Compartment(c, pair, _law(scene, radius, c), True, radius))
    return out


@reusable
def _bundles(scene: Scene) -> tuple[Bundle, ...]:
    """The bundles of ``geometry.ligaments``, checked; kept while the file is."""
    out = read_bundles(surfaces.required_path(scene, "ligaments",
                                              "scanned.ligaments = 'bundles'"))
    for b in out:
        transition_strain_check(b.transition_strain)
    return out


def bundle_springs(scene: Scene) -> tuple[tuple[str, ...], list[SpringLigament]]:
    """Names and springs of the scanned knee's ligament bundles (none if not asked)."""
    if scene["scanned.ligaments"] == "none":
        return (), []
    if scene["ligaments.model"] != "none":
        raise FecheckError("scanned.ligaments = 'bundles' replaces the three-ligament model: "
                           "set ligaments.model = 'none'")
    out = _bundles(scene)
    stiffness, slack = (scene["scanned.ligament_stiffness_scale"],
                        scene["scanned.ligament_slack_scale"])
    wrap = scene["ligaments.wrap"]
    springs = [SpringLigament(b.femur_point, b.tibia_point, slack * b.slack_length_mm,
                              stiffness * b.stiffness_N, b.transition_strain,
                              WrapObject.of(b.wrap) if wrap and b.wrap else None)
               for b in out]
    return tuple(b.name for b in out), springs


@reusable
def _checked_meshes(scene: Scene) -> bool:
    """Run the mesh checks of the scene's contact pairs (`check_meshes`); kept, so not
    run again, while the pairs and the start pose are (a change of material or load keeps
    them)."""
    if scene["model.kind"] == "sphere-plane":
        comps = sphere_plane.build_compartments(scene)
    else:
        comps = [Compartment(c, pair, None, True, radius)
                 for c, (pair, radius) in contact_pairs(scene).items()]
    check_meshes(scene, comps)
    return True


def bundle_parts(springs: list[SpringLigament]) -> list[SpringSet]:
    """The wrench parts of the bundle `springs`: one vectorised `SpringSet` (none: [])."""
    return [SpringSet.of(springs)] if springs else []


def run_scanned(scene: Scene, warm_start: np.ndarray | None = None,
                flexion: tuple[float, np.ndarray] | None = None,
                built: tuple | None = None) -> RunResult:
    """Solve a scanned-knee scene (module docstring); same outputs as the other models.
    `flexion` = (θx rad, Q (3, 3)) as in `solve_equilibrium`; `built` = (compartments,
    bundle names, bundle springs) already built for this scene (a flexion angle)."""
    if scene["constraints.equal_forces"]:
        raise FecheckError("constraints.equal_forces is not available for the scanned models")
    if scene["model.kind"] != "sphere-plane" and scene["ligaments.model"] != "none":
        raise FecheckError("the scanned models take the scanned knee's own ligament bundles "
                           "(scanned.ligaments = 'bundles'); set ligaments.model = 'none'")
    t_start = time.perf_counter()
    comps, names, springs = built or (build_compartments(scene), *bundle_springs(scene))
    if built is None:
        before_solve(scene)
        _checked_meshes(scene)
    t_built = time.perf_counter()
    bundles = bundle_parts(springs)
    eq = solve_equilibrium(scene, comps, bundles, (), warm_start, flexion, check=False)
    return scanned_result(scene, eq, comps, names, bundles, flexion,
                          (t_built - t_start, time.perf_counter() - t_start))


def scanned_result(scene: Scene, eq, comps, names: Sequence[str], bundles: Sequence,
                   flexion: tuple[float, np.ndarray] | None, seconds: tuple[float, float]
                   ) -> RunResult:
    """The `RunResult` of a scanned knee's tibial equilibrium `eq`
    (`fecheck.model.equilibrium.Equilibrium`) of compartments `comps`, bundles `names` and
    their wrench parts `bundles` (`bundle_parts`), at `flexion` as in `run_scanned`;
    `seconds`: (build, total) wall time, s."""
    sol, rot, t = eq.solution, eq.rot, eq.t
    compartments = compartment_results(comps, eq)
    ligaments = {}
    lig_wrench = np.zeros(6)
    if bundles:
        lengths, tensions = bundles[0].lengths(rot, t), bundles[0].tensions(rot, t)
        ligaments = {name: LigamentResult(float(f), float(length))
                     for name, f, length in zip(names, tensions, lengths, strict=True)}
        lig_wrench = bundles[0](rot, t)[0]
    # bone-distance thickness varies per face; the uniform layer is checked as a whole
    notes = (layer_depth_notes(scene, compartments)
             if scene["scanned.thickness"] == "uniform" else [])
    if scene["model.kind"] == "sphere-plane":       # meshed plateau discs: rim and faces
        notes += mesh_resolution_notes(scene, comps, eq.results)
    notes += not_converged_note(sol) + smoothing_notes(scene)
    if scene["model.kind"] == "sphere-tibia":
        notes += fit_note(scene, scene_knee(scene))
    contact = eq.contact
    contact_wrench = sum(eq.wrenches)
    record = SolveRecord(contact.evaluations, {c.name: c.pair.slave.n_faces for c in comps},
                         {c.name: c.pair.describe() for c in comps}, tuple(sol.history),
                         wrench_N={"contact": contact_wrench, "ligaments": lig_wrench,
                                   "load_and_gravity": applied_load(scene)(rot, t)[0]})
    timing = {"total": seconds[1], "build": seconds[0],
              "solve": eq.seconds, "contact": contact.contact_seconds,
              "per_evaluation_us": 1e6 * contact.contact_seconds / max(contact.evaluations, 1),
              "per_evaluation_s": contact.contact_seconds / max(contact.evaluations, 1)}
    return RunResult(scene.label, scene["model.kind"], scene["contact.law"],
                     sol.converged, sol.iterations, sol.residual_norm,
                     Pose.of(eq.q, math.radians(scene["dofs.flexion_deg"]) if flexion is None
                             else flexion[0], side=scene.side), compartments,
                     ligaments, timing, {}, tuple(notes), record)
