"""The rigid model (thesis §5.1): point contacts, linear statics.

Each femoral condyle is a ball constrained to stay on its tibial plateau plane
(frictionless: the reaction is along the plane normal, through the contact point);
ligaments, if any, are rods whose reaction is along the rod. At the given pose the
equilibrium of the tibia's free DOFs is linear in the reactions λ:

    Bᵀ (W_applied + Σ λ_j w_j) = 0,

with w_j the wrench of a unit reaction. It is solved in the least-squares sense and
checked: a load the constraints cannot carry (a mechanism) or reactions the equilibrium
cannot determine (statically indeterminate) raise `FecheckError`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fecheck.errors import FecheckError
from fecheck.scene.constants import DOF_NAMES
from fecheck.scene.knee import COMPARTMENTS, Knee
from fecheck.statics.newton import pose, twist_basis


@dataclass(frozen=True)
class RigidSolution:
    """Reactions of the rigid model.

    contact_force_N : {compartment: normal force, N (+ compression)}
    contact_point : {compartment: (3,) world contact point, mm}
    contact_normal : {compartment: (3,) plateau normal (world), pointing to the femur}
    ligament_force_N : {ligament: rod force, N (+ tension)}
    ligament_length_mm : {ligament: length, mm}
    residual_N : norm of the unbalanced generalised force (N and N·mm / 50 mm)
    """

    contact_force_N: dict[str, float]
    contact_point: dict[str, np.ndarray]
    contact_normal: dict[str, np.ndarray]
    ligament_force_N: dict[str, float]
    ligament_length_mm: dict[str, float]
    residual_N: float


def unit_wrench(point: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """(6,) wrench of a unit force along `direction` at `point` (mm), about the origin."""
    return np.concatenate([direction, np.cross(point, direction)])


def solve_rigid(knee: Knee, normals: dict[str, np.ndarray], applied: np.ndarray,
                q: np.ndarray, free: tuple[int, ...], ligaments: tuple[str, ...] = (),
                theta_x: float = 0.0, equal_forces: bool = False) -> RigidSolution:
    """Reactions of the rigid model at pose `q` (x, y, z mm, θy, θz rad).

    Parameters
    ----------
    knee : landmarks; each condyle touches its plateau at centre − radius·normal
    normals : {compartment: (3,) unit plateau normal, tibia frame}
    applied : (6,) applied wrench on the tibia (N, N·mm about the world origin)
    free : indices of the free DOFs in (x, y, z, θy, θz)
    ligaments : names of the ligaments modelled as rods
    equal_forces : impose equal compartment forces (thesis Fig. 5.12): one unknown for
        both condyles, so the ligaments must carry the rest
    """
    rot, t = pose(q, theta_x)
    b = twist_basis(q, theta_x)[:, list(free)]
    columns, points, world_normals = [], {}, {}
    for c in COMPARTMENTS:
        n = rot @ normals[c]
        x = knee.condyle_center[c] - knee.radius_mm(c) * n
        points[c], world_normals[c] = x, n
        columns.append(-unit_wrench(x, n))          # the femur pushes the tibia along -n
    lengths = {}
    for name in ligaments:
        x = rot @ knee.tibia_attachment[name] + t
        d = knee.femur_attachment[name] - x
        lengths[name] = float(np.linalg.norm(d))
        columns.append(unit_wrench(x, d / lengths[name]))   # tension pulls toward the femur
    if equal_forces:
        columns = [columns[0] + columns[1]] + columns[2:]
    scale = np.ones(len(free))
    scale[np.asarray(free) >= 3] = 1.0 / 50.0                # moments N·mm → N
    a = (b.T @ np.column_stack(columns)) * scale[:, None]
    rhs = -(b.T @ applied) * scale
    lam, _, rank, _ = np.linalg.lstsq(a, rhs, rcond=None)
    if rank < a.shape[1]:
        raise FecheckError(f"the rigid model is statically indeterminate: {a.shape[1]} "
                           f"reactions but only {rank} independent equilibrium equations on "
                           f"the free DOFs {[DOF_NAMES[i] for i in free]}; free more DOFs "
                           f"(dofs.free) or remove ligament rods")
    residual = float(np.linalg.norm(a @ lam - rhs))
    if residual > 1e-9 * max(1.0, float(np.linalg.norm(rhs))):
        unbalanced = [DOF_NAMES[free[i]] for i in np.flatnonzero(np.abs(a @ lam - rhs) > 1e-9
                                                                   * np.linalg.norm(rhs))]
        raise FecheckError(f"the rigid model cannot carry the load in DOFs {unbalanced}: "
                           f"nothing resists them; drive them (remove from dofs.free) or add "
                           f"ligament rods")
    if equal_forces:
        lam = np.concatenate([[lam[0]], lam])
    forces = {c: float(lam[i]) for i, c in enumerate(COMPARTMENTS)}
    ligs = {name: float(lam[2 + i]) for i, name in enumerate(ligaments)}
    return RigidSolution(forces, points, world_normals, ligs, lengths, residual)
