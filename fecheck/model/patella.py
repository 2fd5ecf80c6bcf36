"""The patellofemoral joint in the EF: the patella a free rigid body (6 DOF) on the femoral
trochlea, held by its 20 ligament bundles and pulled by the quadriceps, solved together
with the tibia (`solve_knee`).

Data: the folder ``patella.dir`` names (``fecheck:knee/lenhart2015_patella``, the lenhart2015
patella packaged with fecheck): the patellar cartilage sheet (the contact slave; its normals
face the femur), the patella bone (the bone-distance thickness) and ``patellofemoral.json``
(bundles and quadriceps), all in the knee frame (mm) at the source model's default pose.

* Contact: the patellar cartilage sheet against the scene's femoral articular surface
  (`fecheck.model.knee_surfaces.femoral_master`), the scene's law, detection and area
  mode, fading to nothing within `RIM_MM` of the femoral sheet's rim (BVH detection);
  with ``scanned.thickness = 'bone-distance'`` the foundation thickness per face is
  the patellar cartilage (distance to the patella bone) and the femoral cartilage in series,
  as for the tibia (`fecheck.laws.layer`).
* Bundles (Blankevoort 1991 springs, straight lines, own slack lengths and stiffnesses):
  the patellar tendon PT1-6 between the patella and the tibia (`TwoBodySprings`, so the
  tendon couples the two bodies); lPFL1-8 and mPFL1-6 between the femur (fixed) and the
  patella. The tendon's wrap ellipsoid of the source model is not modelled.
* Quadriceps (`Quadriceps`): a constant tension per muscle along its line of action at the
  patella: the vasti from their patellar insertion toward their last femoral via point
  (fixed in the femur); the rectus femoris from its first patellar point along the femoral
  shaft (the vastus intermedius's femoral segment: its pelvic origin is not in this frame).
  ``patella.quadriceps_N`` is the total, split by the muscles' maximum isometric forces.

The patella's body coordinates are those of `fecheck.statics.newton.Body` with the data's
default pose at q = 0; its six coordinates are reported as the source model's CustomJoint
``pf_r`` reads them (`pf_coordinates`).
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fecheck.contact.pair import ContactPair
from fecheck.errors import FecheckError
from fecheck.laws import layer
from fecheck.laws.registry import spec_of
from fecheck.model.assembly import (
    Compartment,
    ContactModel,
    applied_load,
    force_scale,
    free_indices,
    law_factory,
    law_inputs,
    start_pose,
    wrench_parts,
)
from fecheck.model.equilibrium import Equilibrium, compartment_result
from fecheck.model.knee_surfaces import femoral_master
from fecheck.model.plausibility import before_solve
from fecheck.model.results import CompartmentResult
from fecheck.scene import Scene, surfaces
from fecheck.scene.packaged import PACKAGE_PREFIX, data_dir
from fecheck.statics.frames import rot_x, rot_y, rot_z, skew
from fecheck.statics.ligaments import (
    SpringSet,
    Wrapped,
    blankevoort_tension,
    free_and_object,
    point_forces,
)
from fecheck.statics.newton import (
    TIBIA_COORDINATES,
    Body,
    BodyPose,
    Part,
    Problem,
    body_pose,
    solve,
    tibia_body,
)
from fecheck.statics.wrapping import WrapObject
from geometry.cache import cached_arrays
from geometry.mesh import TriMesh

TIBIA, PATELLA = 0, 1
"""Body indices of the coupled solve (the femur is fixed, the world frame)."""
CARTILAGE = "lenhart2015_R_patella_cartilage.stl"
BONE = "lenhart2015_R_patella_bone.stl"
BUNDLES = "patellofemoral.json"
COMPARTMENT = "patellofemoral"
"""The name of the patellofemoral contact in the results."""

OSIM_AXES = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
"""A (3, 3): knee-frame vector = A · OpenSim vector (x anterior, y superior, z right →
x right, y anterior, z superior; the lenhart2015 README, "Pose and transform")."""
OSIM_ORIGIN_MM = np.array([-1.756628, -0.149547, 22.271913])
"""The origin of femur_distal_r in the knee frame, mm (the same matrix M)."""
DEFAULT_PF_MM = np.array([53.0, 5.0, 4.0])
"""pf_tx, pf_ty, pf_tz of the data's pose (the model's defaults, rotations 0), mm."""
PF_COORDINATES = ("pf_flex_deg", "pf_rot_deg", "pf_tilt_deg", "pf_tx_mm", "pf_ty_mm",
                  "pf_tz_mm")
PF_SIGNS = {
    "pf_flex_deg": "patellar flexion: -pf_flex about the femur's medio-lateral axis, first "
                   "(+ flexion, with the knee's: the patella's anterior face turns inferiorly)",
    "pf_rot_deg": "then about the antero-posterior axis (pf_rot_r, right-handed)",
    "pf_tilt_deg": "then about the superior axis (pf_tilt_r, right-handed)",
    "pf_tx_mm, pf_ty_mm, pf_tz_mm": "the patella frame's origin in femur_distal_r: anterior, "
                                    "superior, right (mm)",
}
"""The sense of the patellofemoral coordinates (OpenSim-JAM's joint pf_r, parent
femur_distal_r, child patella_r, no offset frames)."""
PASSIVE_ACTIVATION = 0.02
"""The source model's muscle activation in its passive flexion (the passive-flexion data
README: muscles at 2 % activation); the default quadriceps total is this share of their
summed maximum isometric forces (force-length and passive fibre force not modelled)."""
RIM_MM = 2.0
"""The patellofemoral contact fades to nothing over this width (mm) at the rim of the
femoral cartilage sheet (`fecheck.contact.pair.ContactPair`'s rim_mm; about 2.6 of its
0.76 mm edges): over the open apex of the intercondylar notch the patella's ridge meets no
femoral face, as the source model's rays find none. Measured with the source set-up every
1° to 120°: without the fade the run stops at 89° (the side-of-normal test makes the
rim a wall); a 1 mm fade stops at 94° (no stiffness at an iterate); 2 mm solves every
angle, and at 0-75° the six coordinates of the unfaded run (to 0.1° and 0.1 mm)."""
SHAFT_MM = 400.0
"""The rectus femoris pulls toward a point this far up the femoral shaft from its first
patellar point, mm (a thigh's length: its line of action is the shaft's)."""


def patella_dir(scene: Scene) -> Path:
    """The folder ``patella.dir`` names (``fecheck:NAME``, or a path relative to the scene
    file's folder), checked to hold the patella's three files."""
    given = scene["patella.dir"]
    if given.startswith(PACKAGE_PREFIX):
        folder = data_dir(given, "patella.dir")
    else:
        folder = Path(os.path.expandvars(given)).expanduser()
        if not folder.is_absolute():
            folder = (Path(scene.source).expanduser().resolve().parent / folder).resolve()
    missing = [n for n in (CARTILAGE, BONE, BUNDLES) if not (folder / n).is_file()]
    if missing:
        raise FecheckError(f"patella.dir = {given!r}: {folder} holds no {', '.join(missing)}; "
                           "give the lenhart2015_patella folder or "
                           "'fecheck:knee/lenhart2015_patella'")
    return folder


def rot_osim(angles: Sequence[float]) -> np.ndarray:
    """pf_r's rotation in OpenSim axes for (pf_flex, pf_rot, pf_tilt) rad:
    Rz(-pf_flex)·Rx(pf_rot)·Ry(pf_tilt) (body-fixed, in that order)."""
    return rot_z(-angles[0]) @ rot_x(angles[1]) @ rot_y(angles[2])


def pf_coordinates(rot: np.ndarray, t: np.ndarray) -> dict[str, float]:
    """The patella's six coordinates (`PF_COORDINATES`: deg, mm) at its body pose (R, t)
    (knee frame; R = I, t = 0 is the data's pose), as OpenSim's pf_r reads them.

    The patella_r frame is at the data's pose p_knee = A·(p + T0) + o (A `OSIM_AXES`, o
    `OSIM_ORIGIN_MM`, T0 `DEFAULT_PF_MM`); moved by (R, t), its rotation in femur_distal_r
    is Rpf = Aᵀ·R·A and its origin T = Rpf·T0 + Aᵀ·(R·o + t - o).
    """
    a, o = OSIM_AXES, OSIM_ORIGIN_MM
    r = a.T @ rot @ a
    origin = r @ DEFAULT_PF_MM + a.T @ (rot @ o + t - o)
    rot_ = math.asin(max(-1.0, min(1.0, r[2, 1])))
    tilt = math.atan2(-r[2, 0], r[2, 2])
    flex = -math.atan2(-r[0, 1], r[1, 1])
    return dict(zip(PF_COORDINATES, (math.degrees(flex), math.degrees(rot_),
                                     math.degrees(tilt), *map(float, origin)), strict=True))


@dataclass(frozen=True, eq=False)
class TwoBodySprings:
    """Blankevoort springs between points of two bodies (`a`, `b`: body indices, points
    in their body frames (n, 3) mm), evaluated at once: the `Part` of their pulls; those
    in `wrapped` along their paths over their wrap objects (`Wrapped`, b the patella)."""

    a: int
    points_a: np.ndarray
    b: int
    points_b: np.ndarray
    slack_mm: np.ndarray
    stiffness_N: np.ndarray
    transition_strain: np.ndarray
    wrapped: Wrapped | None = None

    def ends(self, poses: Sequence[BodyPose]) -> tuple[np.ndarray, np.ndarray]:
        """World attachments (n, 3) on body a and on body b, mm."""
        (ra, ta), (rb, tb) = poses[self.a], poses[self.b]
        return self.points_a @ ra.T + ta, self.points_b @ rb.T + tb

    def _wrapped(self, poses: Sequence[BodyPose]):
        i = self.wrapped.index
        return self.wrapped.forces(self.points_a[i], poses[self.a], self.points_b[i],
                                   poses[self.b], self.slack_mm[i], self.stiffness_N[i],
                                   self.transition_strain[i])

    def lengths(self, poses: Sequence[BodyPose]) -> np.ndarray:
        """(n,) path lengths, mm."""
        xa, xb = self.ends(poses)
        out = np.linalg.norm(xa - xb, axis=1)
        if self.wrapped is not None:
            out[self.wrapped.index] = self._wrapped(poses)[0]
        return out

    def tensions(self, poses: Sequence[BodyPose]) -> np.ndarray:
        """(n,) spring forces, N (+ tension)."""
        strain = self.lengths(poses) / self.slack_mm - 1.0
        return blankevoort_tension(strain, self.stiffness_N, self.transition_strain)[0]

    def __call__(self, poses: Sequence[BodyPose]) -> Part:
        straight = np.ones(len(self.slack_mm), dtype=bool)
        if self.wrapped is not None:
            straight[self.wrapped.index] = False
        xa, xb = self.ends(poses)
        xa, xb = xa[straight], xb[straight]
        d = xa - xb
        length = np.linalg.norm(d, axis=1)
        u = d / length[:, None]
        l0 = self.slack_mm[straight]
        f, df = blankevoort_tension(length / l0 - 1.0, self.stiffness_N[straight],
                                    self.transition_strain[straight])
        force = f[:, None] * u                      # on b, toward a
        uu = u[:, :, None] * u[:, None, :]
        jac = -(df / l0)[:, None, None] * uu - (f / length)[:, None, None] * (np.eye(3) - uu)
        eye = np.broadcast_to(np.eye(3), jac.shape)
        da = np.concatenate([eye, -skew(xa)], axis=2)   # δx_a = da·ξ_a (n, 3, 6)
        db = np.concatenate([eye, -skew(xb)], axis=2)
        dfa, dfb = -jac @ da, jac @ db
        sf, sxa, sxb = skew(force), skew(xa), skew(xb)
        dw = np.zeros((12, 12))
        dw[0:3, 0:6], dw[0:3, 6:12] = -dfa.sum(0), -dfb.sum(0)
        dw[3:6, 0:6] = (sf @ da - sxa @ dfa).sum(0)
        dw[3:6, 6:12] = (-sxa @ dfb).sum(0)
        dw[6:9, 0:6], dw[6:9, 6:12] = dfa.sum(0), dfb.sum(0)
        dw[9:12, 0:6] = (sxb @ dfa).sum(0)
        dw[9:12, 6:12] = (-sf @ db + sxb @ dfb).sum(0)
        total = force.sum(0)
        w = np.concatenate([-total, -np.cross(xa, force).sum(0), total,
                            np.cross(xb, force).sum(0)])
        if self.wrapped is not None:
            _, free, pull, pull_jac = self._wrapped(poses)
            for on_b, (fr, ob) in ((self.wrapped.on_b, (slice(0, 6), slice(6, 12))),
                                   (~self.wrapped.on_b, (slice(6, 12), slice(0, 6)))):
                if on_b.any():
                    wf, d_free, d_object = free_and_object(free[on_b], pull[on_b],
                                                           pull_jac[on_b])
                    w[fr] += wf
                    w[ob] -= wf
                    dw[fr, fr] += d_free
                    dw[fr, ob] += d_object
                    dw[ob, fr] -= d_free
                    dw[ob, ob] -= d_object
        return (self.a, self.b), w, dw


@dataclass(frozen=True, eq=False)
class Quadriceps:
    """Constant muscle tensions (n,) N at patellar points (n, 3) (patella frame, mm), each
    along the line toward its femoral point (n, 3) (fixed, world, mm)."""

    names: tuple[str, ...]
    patella_points: np.ndarray
    femur_points: np.ndarray
    tension_N: np.ndarray

    def lines(self, rot: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World points of application (n, 3) and unit lines of action (n, 3)."""
        x = self.patella_points @ rot.T + t
        d = self.femur_points - x
        return x, d / np.linalg.norm(d, axis=1)[:, None]

    def __call__(self, rot: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x, u = self.lines(rot, t)
        length = np.linalg.norm(self.femur_points - x, axis=1)
        uu = u[:, :, None] * u[:, None, :]
        jac = -(self.tension_N / length)[:, None, None] * (np.eye(3) - uu)
        return point_forces(x, self.tension_N[:, None] * u, jac)


@dataclass(frozen=True, eq=False)
class PatellaModel:
    """The patella of a scene: its contact (`Compartment`, slave the patellar cartilage),
    the femur-patella bundles (`SpringSet`, femur points and patella points), the tendon
    (`TwoBodySprings`, tibia a, patella b), the quadriceps, and the bundle names of each."""

    compartment: Compartment
    femoral: SpringSet
    femoral_names: tuple[str, ...]
    tendon: TwoBodySprings
    tendon_names: tuple[str, ...]
    quadriceps: Quadriceps
    bone: TriMesh

    def ligament_tensions(self, tibia: BodyPose, patella: BodyPose) -> dict[str, float]:
        """{bundle: tension N} of the 20 bundles at the two poses."""
        out = dict(zip(self.tendon_names, self.tendon.tensions((tibia, patella)).tolist(),
                       strict=True))
        out.update(zip(self.femoral_names, self.femoral.tensions(*patella).tolist(),
                       strict=True))
        return out


def series_thickness(scene: Scene, slave: TriMesh, bone: TriMesh) -> np.ndarray:
    """Per-face foundation thickness (mm) of the patellar sheet in the scene's cartilage
    material: patellar and femoral cartilage, each from the distance to its bone
    (`fecheck.laws.layer`), in series, or with a femoral material of its own the equivalent
    thickness; cached on disk by the meshes' content."""
    femur, femur_bone = femoral_master(scene), surfaces.bone(scene, "femur")

    def build() -> tuple[np.ndarray, np.ndarray]:
        fem_h = layer.bone_distance_thickness(femur, femur_bone, name="geometry.femur_bone")
        return (layer.bone_distance_thickness(slave, bone, name="patella bone"),
                layer.opposite_thickness(slave, femur, fem_h))

    own, opposite = cached_arrays("patella-thickness", [slave, femur, femur_bone, bone], build)
    sides, scale = layer.sides(scene), scene["scanned.thickness_scale"]
    if not sides.own_material:
        return scale * (own + opposite)
    return sides.equivalent_thickness(scale * own, scale * opposite)


def _law(scene: Scene, slave: TriMesh, bone: TriMesh):
    """The scene's law over the patellar sheet (`fecheck.model.scanned`'s rule)."""
    if scene["scanned.thickness"] == "uniform":
        return law_factory(scene)(math.nan, COMPARTMENT)
    spec = spec_of(scene)
    if spec.per_face is None:
        raise FecheckError("scanned.thickness = 'bone-distance' with the patella sets a linear "
                           "EF stiffness per face: use contact.law = 'ef' (or "
                           "scanned.thickness = 'uniform')")
    return spec.per_face(law_inputs(scene), lambda: series_thickness(scene, slave, bone),
                         math.nan, COMPARTMENT)


def _quadriceps(scene: Scene, muscles: list[dict]) -> Quadriceps:
    """The four quadriceps of ``patellofemoral.json`` with ``patella.quadriceps_N`` split
    by their maximum isometric forces (module docstring)."""
    fmax = np.array([m["max_isometric_force_N"] for m in muscles], dtype=float)
    by_name = {m["name"]: m for m in muscles}
    shaft = np.subtract(*(p["point_mm"] for p in by_name["vasint_r"]["path"][:2]))
    shaft = shaft / np.linalg.norm(shaft)
    at, toward = [], []
    for m in muscles:
        path = m["path"]
        if path[-2]["body"] == "patella_r":          # rectus femoris: from the pelvis
            first = np.asarray(path[-2]["point_mm"], dtype=float)
            at.append(first)
            toward.append(first + SHAFT_MM * shaft)
        else:
            at.append(np.asarray(path[-1]["point_mm"], dtype=float))
            toward.append(np.asarray(path[-2]["point_mm"], dtype=float))
    total = scene["patella.quadriceps_N"]
    return Quadriceps(tuple(m["name"] for m in muscles), np.array(at), np.array(toward),
                      total * fmax / fmax.sum())


def build_patella(scene: Scene) -> PatellaModel:
    """The scene's patella (module docstring) from ``patella.dir``: a right knee's."""
    if scene["knee.side"] != "right":
        raise FecheckError(f"patella.dir with knee.side = {scene['knee.side']!r}: the "
                           "patella data and its pf_r coordinates are a right knee's; set "
                           "knee.side = 'right' or patella.dir = ''")
    folder = patella_dir(scene)
    slave = surfaces.read_surface(folder / CARTILAGE)
    bone = surfaces.read_surface(folder / BONE, manifold=False)
    doc = json.loads((folder / BUNDLES).read_text(encoding="utf-8"))
    rim = RIM_MM if scene["contact.detection"] in ("auto", "bvh") else 0.0
    pair = ContactPair(slave, femoral_master(scene), method=scene["contact.detection"],
                       area=scene["contact.area"], margin_mm=scene["contact.margin_mm"],
                       rim_mm=rim)
    comp = Compartment(COMPARTMENT, pair, _law(scene, slave, bone), True, math.nan)
    tendon, femoral = [], []
    for b in doc["ligaments"]:
        points = dict(zip(b["points_bone"], np.asarray(b["points_mm"], dtype=float),
                          strict=True))
        strain = b["parameters"]["transition_strain"]["value"]
        wrap = (WrapObject.of(b["wrap"][0]) if scene["ligaments.wrap"] and b["wrap"]
                else None)
        row = (b["name"], points.get("tibia", points.get("femur")), points["patella"],
               scene["scanned.ligament_slack_scale"] * b["derived"]["slack_length_mm"],
               scene["scanned.ligament_stiffness_scale"] * b["parameters"]["linear_stiffness"][
                   "value"], strain, wrap)
        (tendon if "tibia" in points else femoral).append(row)

    def col(rows, i):
        return np.array([r[i] for r in rows], dtype=float)

    return PatellaModel(
        comp,
        SpringSet(col(femoral, 1), col(femoral, 2), col(femoral, 3), col(femoral, 4),
                  col(femoral, 5), Wrapped.of([r[6] for r in femoral], "patella")),
        tuple(r[0] for r in femoral),
        TwoBodySprings(TIBIA, col(tendon, 1), PATELLA, col(tendon, 2), col(tendon, 3),
                       col(tendon, 4), col(tendon, 5),
                       Wrapped.of([r[6] for r in tendon], "patella")),
        tuple(r[0] for r in tendon), _quadriceps(scene, doc["quadriceps"]), bone)


@dataclass(frozen=True, eq=False)
class PatellaState:
    """The patella at an equilibrium: body coordinates q (6,), pose (R, t), its contact
    (`CompartmentResult`, slave points in the world), the bundles' tensions (N) and
    the quadriceps' (N, by muscle)."""

    q: np.ndarray
    rot: np.ndarray
    t: np.ndarray
    contact: CompartmentResult
    ligaments: dict[str, float]
    quadriceps: dict[str, float]

    def coordinates(self) -> dict[str, float]:
        """`pf_coordinates` of the pose."""
        return pf_coordinates(self.rot, self.t)

    def centre_of_pressure(self) -> np.ndarray:
        """The contact's centre of pressure (3,) in the femur (knee) frame, mm (NaN:
        none)."""
        c = self.contact
        w = np.asarray(c.face_pressure_MPa) * np.asarray(c.face_area_mm2)
        if not w.sum() > 0.0:
            return np.full(3, math.nan)
        centroids = c.slave_points[c.slave_faces].mean(axis=1)
        return w @ centroids / w.sum()


def solve_knee(scene: Scene, comps: Sequence[Compartment], springs: Sequence[Callable],
               patella: PatellaModel, warm_start: np.ndarray | None,
               patella_start: np.ndarray | None, flexion: tuple[float, np.ndarray],
               check: bool = True) -> tuple[Equilibrium, PatellaState]:
    """The tibia (as `fecheck.model.equilibrium.solve_equilibrium`: its compartments, the
    scene's load and gravity, its bundle `springs`) and the patella (six free DOFs, from
    `patella_start` or the data's pose) solved together: 5 + 6 unknowns, the patellar
    tendon coupling them."""
    if check:
        before_solve(scene, comps)
    contact = ContactModel(comps)
    pf = ContactModel([patella.compartment])
    tibia_parts = wrench_parts(contact, applied_load(scene), *springs)
    patella_parts = wrench_parts(pf, patella.femoral, patella.quadriceps)

    def wrench(poses: Sequence[BodyPose]) -> list[Part]:
        out = [((TIBIA,), w, dw) for w, dw in tibia_parts(*poses[TIBIA])]
        out += [((PATELLA,), w, dw) for w, dw in patella_parts(*poses[PATELLA])]
        out.append(patella.tendon(poses))
        return out

    q0 = start_pose(scene) if warm_start is None else np.asarray(warm_start, dtype=float)
    theta, base = flexion
    bodies = (tibia_body(q0, free_indices(scene), theta, base),
              Body("patella", np.zeros(6) if patella_start is None
                   else np.asarray(patella_start, dtype=float), tuple(range(6)),
                   free_key="", start_keys="the patella data's pose"))
    problem = Problem(bodies, wrench, (), force_scale(scene),
                      tolerance=scene["solver.tolerance"],
                      max_iterations=scene["solver.max_iterations"],
                      touching=lambda: contact.touching or pf.touching)
    t0 = time.perf_counter()
    sol = solve(problem)
    seconds = time.perf_counter() - t0
    rot, t = body_pose(sol.q[TIBIA], base)
    evaluated = contact.evaluate(rot, t)
    eq = Equilibrium(sol, sol.q[TIBIA][list(TIBIA_COORDINATES)], rot, t,
                     [res for res, _, _ in evaluated], [w for _, w, _ in evaluated], contact,
                     seconds)
    prot, pt = body_pose(sol.q[PATELLA])
    (res, w, _), = pf.evaluate(prot, pt)
    result = compartment_result(patella.compartment, res, w, prot, pt)
    quads = patella.quadriceps
    state = PatellaState(np.asarray(sol.q[PATELLA], dtype=float), prot, pt, result,
                         patella.ligament_tensions((rot, t), (prot, pt)),
                         dict(zip(quads.names, quads.tension_N.tolist(), strict=True)))
    return eq, state
