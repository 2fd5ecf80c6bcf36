"""One equilibrium of the tibia under contact, load, gravity, springs and constraints,
and the per-compartment results read from it. Shared by every contact model kind."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from fecheck.contact.surface import ContactSurface
from fecheck.laws import LawResult
from fecheck.model.assembly import (
    Compartment,
    ContactModel,
    applied_load,
    force_scale,
    free_indices,
    start_pose,
    wrench_parts,
)
from fecheck.model.plausibility import before_solve
from fecheck.model.results import CompartmentResult
from fecheck.scene import Scene
from fecheck.scene.unit_hints import no_equilibrium_hint
from fecheck.statics.newton import (
    TIBIA_COORDINATES,
    NoEquilibrium,
    Problem,
    Solution,
    body_pose,
    constraint_on_body,
    cross3,
    on_body,
    solve,
    tibia_body,
)


@dataclass(frozen=True, eq=False)
class Equilibrium:
    """A solved equilibrium: the Newton solution, the tibia's q = (x, y, z mm, θy, θz rad)
    and pose (R, t), and each compartment's law result and contact wrench on the tibia (6,)
    at that pose.

    seconds : wall time of the Newton solve, s
    """

    solution: Solution
    q: np.ndarray
    rot: np.ndarray
    t: np.ndarray
    results: list[LawResult]
    wrenches: list[np.ndarray]
    contact: ContactModel
    seconds: float


def solve_equilibrium(scene: Scene, comps: Sequence[Compartment],
                      springs: Sequence[Callable] = (),
                      constraints: Sequence[Callable] = (),
                      warm_start: np.ndarray | None = None,
                      flexion: tuple[float, np.ndarray] | None = None,
                      check: bool = True) -> Equilibrium:
    """Newton statics of the scene's tibia with contact in `comps`, the scene's load and
    gravity, ligament `springs` (wrench parts) and `constraints` (rods, equal forces).

    The tibia is the one body of the solve (the femur is fixed); `springs` are its wrench
    parts at its pose (R, t) and `constraints` functions (R, t, parts) → (g, w, ∂w/∂ξ)
    (`fecheck.statics.newton.constraint_on_body`).
    `warm_start` (5,) = (x, y, z mm, θy, θz rad) starts the solve there (sweeps).
    `flexion` = (θx rad, Q (3, 3)) drives θx about Q's first column instead of
    dofs.flexion_deg about world x (`fecheck.statics.newton.Body`'s base). The
    scene and meshes are checked first (`fecheck.model.plausibility.before_solve`; not
    with `check` False: a later angle of checked parts); a
    failure to find any equilibrium names a load below the tibia's weight.
    """
    if check:
        before_solve(scene, comps)
    contact = ContactModel(comps)
    parts = wrench_parts(contact, applied_load(scene), *springs)
    q0 = start_pose(scene) if warm_start is None else np.asarray(warm_start, dtype=float)
    theta, base = flexion or (math.radians(scene["dofs.flexion_deg"]), None)
    tibia = tibia_body(q0, free_indices(scene), theta, base)
    problem = Problem((tibia,), on_body(parts),
                      tuple(constraint_on_body(c) for c in constraints), force_scale(scene),
                      tolerance=scene["solver.tolerance"],
                      max_iterations=scene["solver.max_iterations"],
                      touching=lambda: contact.touching)
    t0 = time.perf_counter()
    sol = _solve(scene, problem)
    seconds = time.perf_counter() - t0
    rot, t = body_pose(sol.q[0], base)
    evaluated = contact.evaluate(rot, t)              # at the solution, for the report
    return Equilibrium(sol, sol.q[0][list(TIBIA_COORDINATES)], rot, t,
                       [res for res, _, _ in evaluated], [w for _, w, _ in evaluated], contact,
                       seconds)


def _solve(scene: Scene, problem: Problem) -> Solution:
    """`solve`, with the load's cause added to a failure to find any equilibrium."""
    try:
        return solve(problem)
    except NoEquilibrium as err:
        hint = no_equilibrium_hint(scene)
        if not hint:
            raise
        raise NoEquilibrium(f"{err}; {hint}") from None


def compartment_result(comp: Compartment, res: LawResult, w: np.ndarray, rot: np.ndarray,
                       t: np.ndarray) -> CompartmentResult:
    """The reported metrics of one compartment from its law result `res` and contact
    wrench `w` (6,) on the tibia at pose (R, t); torque about the tibial origin."""
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
    face_area, face_depth = _face_fields(res.surface)
    return CompartmentResult(force, res.max_pressure, mean, area, res.max_depth,
                             float(np.linalg.norm(torque)), torque, faces,
                             face_pressure, points, mesh.faces, face_area, face_depth,
                             w[:3].copy(), axial_force(w[:3], rot))


def axial_force(force: np.ndarray, rot: np.ndarray) -> float:
    """Component of a contact force on the tibia (3,) N along the tibia's long axis (its z
    axis, world R e_z), + compressive."""
    return float(-force @ rot[:, 2])


def _face_fields(surface) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(n_slave_faces,) in-contact area (mm²) and mean depth over it (mm) of every slave
    face of a `ContactSurface`; (None, None) for a point contact."""
    if not isinstance(surface, ContactSurface):
        return None, None
    area, depth = np.zeros(surface.n_slave_faces), np.zeros(surface.n_slave_faces)
    fa = surface.face_area
    ok = fa > 0
    area[surface.face] = fa
    depth[surface.face[ok]] = surface.face_depth_integral[ok] / fa[ok]
    return area, depth


def compartment_results(comps: Sequence[Compartment], eq: Equilibrium
                        ) -> dict[str, CompartmentResult]:
    """{compartment: `CompartmentResult`} at the equilibrium."""
    return {c.name: compartment_result(c, res, w, eq.rot, eq.t)
            for c, res, w in zip(comps, eq.results, eq.wrenches, strict=True)}


def not_converged_note(sol: Solution) -> list[str]:
    """The note a run that stopped before convergence carries (none if it converged)."""
    if sol.converged:
        return []
    return [f"did not converge in {sol.iterations} iterations "
            f"(residual {sol.residual_norm:.3g} N); raise solver.max_iterations"]
