"""Assemble a scene into bodies, contact pairs and forces, solve it, report the result.

`run_scene(scene)` is the one entry point. Model kinds are registered in `MODEL_RUNNERS`
(kind → function of the scene returning a `RunResult`); to add one (e.g. the scanned
``sphere-tibia`` / ``femur-tibia`` models), write its runner, register it here and add
the kind to `fecheck.scene.MODEL_KINDS`. The contact models share `ContactModel`:
per compartment a contact pair and a law; femur fixed, tibia pose (R, t). The Hertz law on
plane plateaus with analytic detection uses the closed-form sphere-plane point contact
(`fecheck.contact.convex`, smooth in the pose); on polynomial plateaus, with mesh
detection or the thesis's whole-face counting it takes the deepest slave vertex, which is
not smooth (Newton may stall).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from fecheck import laws
from fecheck.contact.surface import ContactSurface
from fecheck.errors import FecheckError
from fecheck.frames import skew
from fecheck.knee import COMPARTMENTS, LIGAMENTS, Knee, plane_normal
from fecheck.ligaments import rod_constraint, spring_wrench, transition_strain_check
from fecheck.results import CompartmentResult, LigamentResult, RunResult
from fecheck.scene import DOF_NAMES, Scene
from fecheck.statics import Problem, cross3, point_force, pose, solve

GRAVITY_MPS2 = 9.81
WHOLE_FACE_NOTE = ("whole-face area counting (thesis Fig. 3.20) reproduces the thesis's bias: "
                   "contact area overestimated and depth underestimated (Table 5.3); use "
                   "contact.area = 'clipped' for the exact values")


def start_pose(scene: Scene) -> np.ndarray:
    """q = (x, y, z, θy, θz) (mm, rad) from the dofs.* values, z lowered by the start gap."""
    return np.array([scene["dofs.x_mm"], scene["dofs.y_mm"],
                     scene["dofs.z_mm"] - scene["solver.start_gap_mm"],
                     math.radians(scene["dofs.abduction_deg"]),
                     math.radians(scene["dofs.internal_deg"])])


def pose_dict(q: np.ndarray) -> dict[str, float]:
    """Pose for reports: x_mm, y_mm, z_mm, abduction_deg, internal_deg."""
    return {"x_mm": float(q[0]), "y_mm": float(q[1]), "z_mm": float(q[2]),
            "abduction_deg": math.degrees(q[3]), "internal_deg": math.degrees(q[4])}


def free_indices(scene: Scene) -> tuple[int, ...]:
    return tuple(DOF_NAMES.index(d) for d in scene.free_dofs)


def plateau_normals(scene: Scene) -> dict[str, np.ndarray]:
    """{compartment: unit plateau normal, tibia frame} for plane plateaus."""
    if scene["plateau.kind"] == "transverse":
        return {c: np.array([0.0, 0.0, 1.0]) for c in COMPARTMENTS}
    if scene["plateau.kind"] == "inclined":
        return {c: plane_normal(scene[f"plateau.{c}_angles_deg"]) for c in COMPARTMENTS}
    raise FecheckError("this model needs plane plateaus: set plateau.kind to 'transverse' or "
                       "'inclined'")


def applied_load(scene: Scene) -> Callable[[np.ndarray, np.ndarray],
                                            tuple[np.ndarray, np.ndarray]]:
    """Wrench (and tangent) of the external load and the tibia's weight at pose (R, t)."""
    direction = np.asarray(scene["load.direction"], dtype=float)
    norm = np.linalg.norm(direction)
    force = scene["load.force_N"] * (direction / norm if norm > 0 else direction)
    point = np.asarray(scene["load.point_mm"], dtype=float)
    weight = np.array([0.0, 0.0, -scene["tibia.mass_kg"] * GRAVITY_MPS2 * scene["gravity"]])
    com = np.asarray(scene["tibia.com_mm"], dtype=float)
    follows = scene["load.frame"] == "tibia"
    w_fixed = np.concatenate([force, np.cross(point, force)])

    def wrench(rot: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        w2, d2 = point_force(rot @ com + t, weight)
        if follows:
            w1, d1 = point_force(rot @ point + t, force)
            return w1 + w2, d1 + d2
        return w_fixed + w2, d2

    return wrench


class WrenchSum:
    """The summed (wrench (6,) N, N·mm; tangent (6, 6)) on the tibia of several parts
    (contact, load, ligament springs), each a function of the tibia's pose (rot, t).

    last : each part's (wrench, tangent) at the latest call (`statics.Problem.parts`)
    """

    def __init__(self, *parts: Callable):
        self.parts = parts
        self.last: list[tuple[np.ndarray, np.ndarray]] = []

    def __call__(self, rot: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        self.last = [part(rot, t) for part in self.parts]
        w, dw = self.last[0]
        for wp, dp in self.last[1:]:
            w, dw = w + wp, dw + dp
        return w, dw


def total_wrench(*parts: Callable) -> WrenchSum:
    """The summed wrench and tangent of `parts` (`WrenchSum`)."""
    return WrenchSum(*parts)


def force_scale(scene: Scene) -> float:
    """Load magnitude the residual tolerance is relative to, N (≥ 1)."""
    weight = scene["tibia.mass_kg"] * GRAVITY_MPS2 * scene["gravity"]
    return max(1.0, scene["load.force_N"], weight)


def _ligament_names(scene: Scene) -> tuple[str, ...]:
    return LIGAMENTS if scene["ligaments.model"] != "none" else ()


# ----------------------------------------------------------------------------- rigid
def run_rigid(scene: Scene, warm_start: np.ndarray | None = None) -> RunResult:
    """Thesis §5.1: balls on frictionless plateau planes, linear statics (at the pose of
    the dofs.* values; `warm_start` is ignored: there is nothing to iterate)."""
    from fecheck.rigid import solve_rigid

    t0 = time.perf_counter()
    if scene["ligaments.model"] == "spring":
        raise FecheckError("the rigid model takes ligaments as rods (ligaments.model = 'rod') "
                           "or none")
    knee = scene.knee
    q = start_pose(scene) + np.array([0.0, 0.0, scene["solver.start_gap_mm"], 0.0, 0.0])
    theta_x = math.radians(scene["dofs.flexion_deg"])
    rot, t = pose(q, theta_x)
    applied, _ = applied_load(scene)(rot, t)
    sol = solve_rigid(knee, plateau_normals(scene), applied, q, free_indices(scene),
                      _ligament_names(scene), theta_x, scene["constraints.equal_forces"])
    nan = math.nan
    comps = {}
    for c in COMPARTMENTS:
        f_tibia = -sol.contact_force_N[c] * sol.contact_normal[c]
        torque = np.cross(sol.contact_point[c] - t, f_tibia)
        comps[c] = CompartmentResult(sol.contact_force_N[c], nan, nan, nan, nan,
                                     float(np.linalg.norm(torque)), torque)
    ligs = {k: LigamentResult(v, sol.ligament_length_mm[k])
            for k, v in sol.ligament_force_N.items()}
    elapsed = time.perf_counter() - t0
    return RunResult(scene["name"] or scene.source, "rigid", "none", True, 1, sol.residual_N,
                     pose_dict(q), comps, ligs, {"total": elapsed, "solve": elapsed})


# ----------------------------------------------------------------------- contact models
@dataclass
class Compartment:
    """One compartment's contact: pair, law and which body the slave belongs to.

    note : a caveat of this pair with this law, appended to `describe()`
    """

    name: str
    pair: object
    law: Callable[[object], laws.LawResult]
    slave_is_tibia: bool
    radius_mm: float
    last: laws.LawResult | None = None
    note: str = ""

    def describe(self) -> str:
        """How the pair is evaluated, with the law's caveat (for ``--explain``)."""
        return self.pair.describe() + self.note


def law_factory(scene: Scene) -> Callable[[float], Callable[[object], laws.LawResult]]:
    """Validated contact law of a scene, as a function of the condyle radius (mm)."""
    e, nu, h = scene["contact.youngs_MPa"], scene["contact.poisson"], scene["contact.thickness_mm"]
    name = scene["contact.law"]
    if name == "ef":
        k = laws.ef_stiffness(e, nu, h)
        return lambda r: lambda s: laws.elastic_foundation(s, k)
    if name == "volumetric":
        laws.validate_material(e, nu, h)
        kv = scene["contact.volumetric_stiffness_N_per_mm3"]
        return lambda r: lambda s: laws.volumetric(s, kv)
    if name == "blankevoort":
        pressure = laws.blankevoort_pressure(e, nu, h)
        return lambda r: lambda s: laws.foundation(s, pressure)
    e_star = laws.hertz_modulus(e, nu, scene["contact.indenter_youngs_MPa"],
                                scene["contact.indenter_poisson"])
    return lambda r: lambda s: laws.hertz(s, r, e_star)


DEEPEST_VERTEX_NOTE = ("; Hertz from the deepest slave vertex: not smooth in the pose "
                       "(Newton may stall)")


def hertz_point_contact(scene: Scene) -> bool:
    """Whether the scene's Hertz compartments use the closed-form sphere-plane contact:
    Hertz law, plane plateaus, analytic detection, clipped areas (``whole-face`` asks for
    the thesis's counting of mesh faces, so it keeps the meshed, deepest-vertex path)."""
    return (scene["contact.law"] == "hertz"
            and scene["plateau.kind"] in ("transverse", "inclined")
            and scene["contact.detection"] not in MESH_DETECTION
            and scene["contact.area"] == "clipped")


def _hertz_point_compartments(scene: Scene) -> list[Compartment]:
    """Closed-form sphere (femur) on plane (tibia) pairs: smooth maximum depth. The
    plateau mesh only draws the pressure and is built on first use, never in the solve."""
    from fecheck.contact.convex import SpherePlanePair

    knee = scene.knee
    e_star = laws.hertz_modulus(scene["contact.youngs_MPa"], scene["contact.poisson"],
                                scene["contact.indenter_youngs_MPa"],
                                scene["contact.indenter_poisson"])
    out = []
    for c, n in plateau_normals(scene).items():
        centre, r = knee.condyle_center[c], knee.radius_mm(c)
        pair = SpherePlanePair(centre, r, centre - r * n, n,
                               mesh=lambda c=c: _plateau_mesh(scene, knee, c))
        out.append(Compartment(c, pair, lambda s, r=r: laws.hertz_point(s, r, e_star),
                               True, r))
    return out


def build_compartments(scene: Scene) -> list[Compartment]:
    """Contact pairs of the sphere-plane model (meshes built or read from the cache)."""
    from fecheck.contact.analytic import Sphere
    from fecheck.contact.pair import ContactPair

    if hertz_point_contact(scene):
        return _hertz_point_compartments(scene)
    if scene["contact.detection"] == "ray-parity" and scene["contact.master"] == "plateau":
        raise FecheckError(
            "contact.detection = 'ray-parity' (thesis Algorithm 3) takes the depth as the "
            "distance to the nearest master VERTEX; the plateau master is a box whose "
            "vertices lie ~20 mm from the contact, so that depth is meaningless here. Use "
            "contact.master = 'condyle' (the meshed condyle is then the master), or "
            "contact.detection = 'auto', 'bvh' or 'fcl'")
    knee = scene.knee
    law = law_factory(scene)
    note = DEEPEST_VERTEX_NOTE if scene["contact.law"] == "hertz" else ""
    out = []
    opts = {"method": scene["contact.detection"], "area": scene["contact.area"],
            "margin_mm": scene["contact.margin_mm"]}
    meshed = scene["contact.detection"] in MESH_DETECTION
    for c in COMPARTMENTS:
        centre, r = knee.condyle_center[c], knee.radius_mm(c)
        if scene["contact.master"] == "plateau":
            slave = _condyle_mesh(scene, knee, c)
            master = _plateau_box(scene, knee, c) if meshed else _plateau_master(scene, knee, c)
            pair = ContactPair(slave, master, **opts)
            out.append(Compartment(c, pair, law(r), False, r, note=note))
        else:
            slave = _plateau_mesh(scene, knee, c)
            master = _condyle_mesh(scene, knee, c) if meshed else Sphere(centre, r)
            pair = ContactPair(slave, master, **opts)
            out.append(Compartment(c, pair, law(r), True, r, note=note))
    return out


MESH_DETECTION = ("bvh", "ray-parity", "fcl")
"""Detection methods that need a mesh master: the analytic surface is meshed instead."""


def _condyle_mesh(scene: Scene, knee: Knee, c: str):
    from geometry.icosphere import icosphere

    return icosphere(knee.radius_mm(c), scene["mesh.sphere_subdivisions"],
                     knee.condyle_center[c], method=scene["mesh.method"])


def _plateau_box(scene: Scene, knee: Knee, c: str):
    """The plateau plane as the top of a closed 40 x 40 x 10 mm box (mesh detection)."""
    from geometry.plateau import plateau_box

    if scene["plateau.kind"] == "polynomial":
        raise FecheckError("mesh detection (contact.detection = 'bvh', 'ray-parity' or "
                           "'fcl') needs plane plateaus here; use contact.detection = 'auto' "
                           "for polynomial plateaus")
    n = plateau_normals(scene)[c]
    lam, gam = ((0.0, 0.0) if scene["plateau.kind"] == "transverse"
                else scene[f"plateau.{c}_angles_deg"])
    return plateau_box(knee.condyle_center[c] - knee.radius_mm(c) * n, 40.0, 40.0, 10.0,
                       sagittal_deg=lam, frontal_deg=gam)


def _plateau_master(scene: Scene, knee: Knee, c: str):
    from fecheck.contact.analytic import Plane, PolynomialSurface
    from geometry.polynomial import Polynomial2D

    if scene["plateau.kind"] == "polynomial":
        return PolynomialSurface(Polynomial2D(np.asarray(scene[f"plateau.{c}_coefficients"])))
    n = plateau_normals(scene)[c]
    return Plane(knee.condyle_center[c] - knee.radius_mm(c) * n, n)


def _plateau_mesh(scene: Scene, knee: Knee, c: str):
    """The meshed plateau disc under condyle `c`, sized to resolve and contain the
    expected contact (`fecheck.contact_size.plateau_mesh_sizes`)."""
    from fecheck.contact_size import plateau_mesh_sizes
    from geometry.plateau import plane_patch, polynomial_patch
    from geometry.polynomial import Polynomial2D

    foot = knee.condyle_center[c] - knee.radius_mm(c) * np.array([0.0, 0.0, 1.0])
    size = plateau_mesh_sizes(scene, knee.radius_mm(c))
    radius = size.pop("radius")
    if scene["plateau.kind"] == "polynomial":
        poly = Polynomial2D(np.asarray(scene[f"plateau.{c}_coefficients"]))
        return polynomial_patch(poly, footprint="ellipse", center_xy=foot[:2], half_x=radius,
                                half_y=radius, refine_point=foot[:2], **size)
    n = plateau_normals(scene)[c]
    point = knee.condyle_center[c] - knee.radius_mm(c) * n
    return plane_patch(point, n, radius=radius, refine_point=point, **size)


class ContactModel:
    """Wrench of all contacts on the tibia at a pose, with the exact tangent."""

    def __init__(self, compartments: list[Compartment]):
        self.compartments = compartments
        self.evaluations = 0
        self.contact_seconds = 0.0
        self.touching = False
        self._eye = np.eye(3)
        self._zero = np.zeros(3)

    def __call__(self, rot: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        w = np.zeros(6)
        dw = np.zeros((6, 6))
        t0 = time.perf_counter()
        touching = False
        fixed, tibia = (self._eye, self._zero), (rot, t)
        for comp in self.compartments:
            if comp.slave_is_tibia:
                res = comp.law(comp.pair.evaluate(tibia, fixed))
                w[:3] += res.force
                w[3:] += res.moment
                dw += res.tangent
            else:                   # minus the wrench on the femur, for the tibia's twist
                res = comp.law(comp.pair.evaluate(fixed, tibia))
                w[:3] -= res.force
                w[3:] -= res.moment
                fs = skew(res.force)
                dw += res.tangent
                dw[:3, 3:] += fs
                dw[3:, :3] += fs
                dw[3:, 3:] += skew(res.moment)
            comp.last = res
            touching = touching or res.max_depth > 0
        self.contact_seconds += time.perf_counter() - t0
        self.evaluations += 1
        self.touching = touching
        return w, dw

    def compartment_wrench(self, name: str) -> np.ndarray:
        """(6,) last contact wrench of one compartment on the tibia (N, N·mm)."""
        comp = next(c for c in self.compartments if c.name == name)
        sign = 1.0 if comp.slave_is_tibia else -1.0
        return sign * np.concatenate([comp.last.force, comp.last.moment])


def _equal_force_constraint(model: ContactModel, wrench_fn):
    """g = |F_medial| − |F_lateral| (N); gradient from the contact tangent (the second
    derivative is not available: the Newton step is inexact in this one row)."""
    def con(rot, t):
        _, _ = wrench_fn(rot, t)
        grads, mags = [], []
        for comp in model.compartments:
            res = comp.last
            f = res.force
            mag = float(np.linalg.norm(f))
            tan = res.tangent[:3]
            if not comp.slave_is_tibia:
                tan = -tan  # the tibia's twist is minus the slave's relative twist
            grads.append(f @ tan / mag if mag > 0 else np.zeros(6))
            mags.append(mag)
        g = mags[0] - mags[1]
        return g, -(grads[0] - grads[1]), np.zeros((6, 6))
    return con


def run_contact_model(scene: Scene, warm_start: np.ndarray | None = None) -> RunResult:
    """Sphere-plane (and later meshed) models: Newton statics with contact laws."""
    from fecheck.law_kernel import warm_up

    t_start = time.perf_counter()
    knee = scene.knee
    comps = build_compartments(scene)
    warm_up()                        # the compiled law kernel loads in the build, not the solve
    t_built = time.perf_counter()
    contact = ContactModel(comps)
    load = applied_load(scene)
    lig_names = _ligament_names(scene)
    springs = []
    constraints = []
    if scene["ligaments.model"] == "spring":
        transition_strain_check(scene["ligaments.transition_strain"])
        springs = [spring_wrench(knee.femur_attachment[n], knee.tibia_attachment[n],
                                 knee.ligament_length_mm(n),
                                 scene[f"ligaments.{n}.stiffness_N"],
                                 scene[f"ligaments.{n}.reference_strain"],
                                 scene["ligaments.transition_strain"]) for n in lig_names]
    elif scene["ligaments.model"] == "rod":
        constraints = [rod_constraint(knee.femur_attachment[n], knee.tibia_attachment[n],
                                      knee.ligament_length_mm(n)) for n in lig_names]

    wrench = total_wrench(contact, load, *springs)
    if scene["constraints.equal_forces"]:
        constraints.append(_equal_force_constraint(contact, wrench))
    q0 = start_pose(scene) if warm_start is None else np.asarray(warm_start, dtype=float)
    problem = Problem(q0, free_indices(scene), wrench, tuple(constraints),
                      math.radians(scene["dofs.flexion_deg"]), force_scale(scene),
                      tolerance=scene["solver.tolerance"],
                      max_iterations=scene["solver.max_iterations"],
                      touching=lambda: contact.touching,
                      parts=lambda: wrench.last)
    t_solve = time.perf_counter()
    sol = solve(problem)
    t_solved = time.perf_counter()
    rot, t = pose(sol.q, problem.theta_x)
    wrench(rot, t)                                # state at the solution, for the report
    compartments = {c.name: _compartment_result(contact, c, rot, t) for c in comps}
    ligaments = {}
    for i, n in enumerate(lig_names):
        x = rot @ knee.tibia_attachment[n] + t
        length = float(np.linalg.norm(knee.femur_attachment[n] - x))
        if springs:
            force = springs[i].tension(length)
        else:
            force = float(sol.multipliers[i])
        ligaments[n] = LigamentResult(force, length)
    notes = []
    if scene["contact.area"] == "whole-face":
        notes.append(WHOLE_FACE_NOTE)
    if not sol.converged:
        notes.append(f"did not converge in {sol.iterations} iterations "
                     f"(residual {sol.residual_norm:.3g} N); raise solver.max_iterations")
    notes += layer_depth_notes(scene, compartments) + mesh_resolution_notes(scene, comps)
    if scene["contact.law"] == "blankevoort":
        deep = [c for c, r in compartments.items()
                if r.max_depth_mm > laws.BLANKEVOORT_LINEAR_FROM * scene["contact.thickness_mm"]]
        if deep:
            notes.append(f"depth beyond 0.9 h in {deep}: the log law was continued linearly")
    extra = {"evaluations": contact.evaluations,
             "contact_faces": {c.name: c.pair.slave.n_faces for c in comps},
             "detection": {c.name: c.describe() for c in comps},
             "residual_history": list(sol.history)}
    if scene["constraints.equal_forces"]:
        extra["equal_forces_multiplier"] = float(sol.multipliers[-1])
    timing = {"total": time.perf_counter() - t_start, "build": t_built - t_start,
              "solve": t_solved - t_solve, "contact": contact.contact_seconds,
              "per_evaluation": contact.contact_seconds / max(contact.evaluations, 1)}
    return RunResult(scene["name"] or scene.source, scene["model.kind"], scene["contact.law"],
                     sol.converged, sol.iterations, sol.residual_norm, pose_dict(sol.q),
                     compartments, ligaments, timing, exact_reference(scene, compartments),
                     tuple(notes), extra | {"q": sol.q.tolist()})


MIN_CONTACT_FACES = 60
"""Fewer faces in contact than this get a note: area and pressure are then coarse. Icosphere
on a plane at the baseline load (fecheck stress): 1,280 faces put 36-46 faces in contact and
are 8-9 % off the exact EF answer; 5,120 faces put 88-96 in contact, 2 % off (faceting)."""


def mesh_resolution_notes(scene: Scene, comps: list[Compartment]) -> list[str]:
    """After the solve: `FecheckError` if a contact reaches the rim of a meshed plateau
    disc, plane or polynomial (it is cut there: area, pressures and the force balance are
    wrong; the disc is centred under the condyle at the reference pose, and a contact
    that slides off it, e.g. with ligaments turning the tibia, needs a wider
    ``mesh.plateau_radius_mm``); notes for contacts spanning fewer than
    `MIN_CONTACT_FACES`."""
    from fecheck.contact_size import plateau_mesh_sizes

    notes = []
    for comp in comps:
        surface = getattr(comp.last, "surface", None)
        if not isinstance(surface, ContactSurface) or surface.n_faces == 0:
            continue
        rim = getattr(comp.pair, "boundary_vertex", None)
        if comp.slave_is_tibia and rim is not None:
            touching = comp.pair.slave.faces[surface.face][surface.vertex_depth > 0.0]
            if rim[touching].any():
                disc = plateau_mesh_sizes(scene, comp.radius_mm)["radius"]
                fix = "raise mesh.plateau_radius_mm"
                if scene["plateau.kind"] == "polynomial":
                    fix += (" (on a polynomial plateau, a rim contact away from the condyle "
                            "can be the fit rising beyond the cartilage it was fitted to: "
                            "then lower it)")
                raise FecheckError(f"{comp.name}: the contact reaches the rim of the meshed "
                                   f"plateau disc (radius {disc:g} mm) and is cut there; {fix}")
        if surface.n_faces < MIN_CONTACT_FACES:
            key = ("mesh.plateau_refine_mm" if comp.slave_is_tibia
                   else "mesh.sphere_subdivisions")
            notes.append(f"{comp.name}: the contact spans only {surface.n_faces} faces, so "
                         f"its area and pressures are coarse; refine the mesh ({key})")
    return notes


def layer_depth_notes(scene: Scene, compartments: Mapping[str, CompartmentResult]
                      ) -> list[str]:
    """Check solved depths (mm) against the cartilage thickness h = contact.thickness_mm.

    The EF and Blankevoort foundations model a layer of thickness h (Blankevoort's log law
    is continued linearly beyond 0.9 h, never beyond h): a depth ≥ h means the layer is
    crushed through and the answer is meaningless, so it raises `FecheckError` naming what
    to change. The volumetric law has no thickness: a note. Hertz: nothing.
    """
    law, h = scene["contact.law"], scene["contact.thickness_mm"]
    deep = {c: r.max_depth_mm for c, r in compartments.items() if r.max_depth_mm >= h}
    if not deep or law == "hertz":
        return []
    where = ", ".join(f"{c} {d:.3g} mm" for c, d in deep.items())
    if law == "volumetric":
        return [(f"depth {where} ≥ the cartilage thickness {h:g} mm: the volumetric law has "
                 "no thickness, but the bodies overlap deeper than the cartilage")]
    raise FecheckError(f"the cartilage layer is crushed through: solved depth {where} ≥ "
                       f"contact.thickness_mm = {h:g} mm, where the {law} foundation law does "
                       "not hold; use a stiffer material (contact.youngs_MPa), a thicker "
                       "layer (contact.thickness_mm) or a smaller load (load.force_N)")


def _compartment_result(model: ContactModel, comp: Compartment, rot: np.ndarray,
                        t: np.ndarray) -> CompartmentResult:
    res = comp.last
    w = model.compartment_wrench(comp.name)
    torque = w[3:] - cross3(t, w[:3])
    force = float(np.linalg.norm(w[:3]))
    mesh = comp.pair.slave
    points = mesh.points @ rot.T + t if comp.slave_is_tibia else mesh.points
    area, mean = res.area, res.mean_pressure
    face_pressure = res.face_pressure()
    if isinstance(res.surface, ContactSurface):
        faces = res.surface.n_faces
    else:                                           # point contact: faces under the pressure
        faces = int(np.count_nonzero(face_pressure))
    if getattr(comp.pair, "area_mode", "") == "whole-face" and faces:
        # the thesis's area: the full (unprojected) area of every face touching the master
        area = float(mesh.face_areas[res.surface.face].sum())
        mean = force / area
    return CompartmentResult(force, res.max_pressure, mean, area, res.max_depth,
                             float(np.linalg.norm(torque)), torque, faces,
                             face_pressure, points, mesh.faces)


def ef_sphere_plane(force_N: float, radius_mm: float, k_N_per_mm3: float) -> dict[str, float]:
    """Closed-form EF sphere on plane at a given force (DESIGN §5): depth d from
    F = k·πd²(R − d/3), area π(2Rd − d²), p_max = k·d, p_mean = F/A."""
    r, k = radius_mm, k_N_per_mm3
    d = (force_N / (k * math.pi * r)) ** 0.5
    for _ in range(50):
        f = k * math.pi * d * d * (r - d / 3) - force_N
        d -= f / (k * math.pi * (2 * r * d - d * d))
    area = math.pi * (2 * r * d - d * d)
    return {"max_depth_mm": d, "area_mm2": area, "max_pressure_MPa": k * d,
            "mean_pressure_MPa": force_N / area if area > 0 else 0.0}


def exact_reference(scene: Scene, compartments: Mapping[str, CompartmentResult]) -> dict:
    """Closed-form EF values at the solved compartment forces, with deviations (%)."""
    if (scene["model.kind"] != "sphere-plane" or scene["plateau.kind"] == "polynomial"
            or scene["contact.law"] not in ("ef", "volumetric")):
        return {}
    if scene["contact.law"] == "ef":
        k = laws.ef_stiffness(scene["contact.youngs_MPa"], scene["contact.poisson"],
                              scene["contact.thickness_mm"])
    else:
        k = scene["contact.volumetric_stiffness_N_per_mm3"]
    out = {}
    knee = scene.knee
    for c, res in compartments.items():
        if res.force_N <= 0:
            continue
        ref = ef_sphere_plane(res.force_N, knee.radius_mm(c), k)
        got = {"max_depth_mm": res.max_depth_mm, "area_mm2": res.area_mm2,
               "max_pressure_MPa": res.max_pressure_MPa,
               "mean_pressure_MPa": res.mean_pressure_MPa}
        ref["deviation_percent"] = {key: 100.0 * (got[key] - v) / v for key, v in ref.items()}
        out[c] = ref
    return out


def _run_scanned(scene: Scene, warm_start: np.ndarray | None = None) -> RunResult:
    from fecheck.scanned_models import run_scanned

    return run_scanned(scene, warm_start)


MODEL_RUNNERS: dict[str, Callable[..., RunResult]] = {
    "rigid": run_rigid,
    "sphere-plane": run_contact_model,
    "sphere-tibia": _run_scanned,
    "femur-tibia": _run_scanned,
}


def run_scene(scene: Scene, warm_start: np.ndarray | None = None) -> RunResult:
    """Solve a scene and return its `RunResult`.

    `warm_start` (5,) = (x, y, z mm, θy, θz rad) starts the Newton solve there (sweeps).
    """
    kind = scene["model.kind"]
    if scene["scanned.ligaments"] != "none":
        return _run_scanned(scene, warm_start)
    if kind not in MODEL_RUNNERS:
        raise FecheckError(f"model.kind {kind!r} has no runner; known: "
                           f"{', '.join(MODEL_RUNNERS)}")
    return MODEL_RUNNERS[kind](scene, warm_start)
