"""The rigid model (thesis §5.1): balls on frictionless plateau planes, linear statics."""

from __future__ import annotations

import math
import time

import numpy as np

from fecheck.errors import FecheckError
from fecheck.model.assembly import (
    applied_load,
    free_indices,
    ligament_names,
    plateau_normals,
    start_pose,
)
from fecheck.model.equilibrium import axial_force
from fecheck.model.plausibility import before_solve
from fecheck.model.results import CompartmentResult, LigamentResult, Pose, RunResult
from fecheck.scene import Scene
from fecheck.scene.constants import COMPARTMENTS
from fecheck.statics.newton import pose
from fecheck.statics.rigid import solve_rigid


# ----------------------------------------------------------------------------- rigid
def run_rigid(scene: Scene, warm_start: np.ndarray | None = None) -> RunResult:
    """Thesis §5.1: balls on frictionless plateau planes, linear statics (at the pose of
    the dofs.* values; `warm_start` is ignored: there is nothing to iterate)."""
    t0 = time.perf_counter()
    if scene["ligaments.model"] == "spring":
        raise FecheckError("the rigid model takes ligaments as rods (ligaments.model = 'rod') "
                           "or none")
    before_solve(scene)
    knee = scene.knee
    q = start_pose(scene) + np.array([0.0, 0.0, scene["solver.start_gap_mm"], 0.0, 0.0])
    theta_x = math.radians(scene["dofs.flexion_deg"])
    rot, t = pose(q, theta_x)
    applied, _ = applied_load(scene)(rot, t)
    sol = solve_rigid(knee, plateau_normals(scene), applied, q, free_indices(scene),
                      ligament_names(scene), theta_x, scene["constraints.equal_forces"])
    nan = math.nan
    comps = {}
    for c in COMPARTMENTS:
        f_tibia = -sol.contact_force_N[c] * sol.contact_normal[c]
        torque = np.cross(sol.contact_point[c] - t, f_tibia)
        comps[c] = CompartmentResult(sol.contact_force_N[c], nan, nan, nan, nan,
                                     float(np.linalg.norm(torque)), torque,
                                     force_vector_N=f_tibia,
                                     axial_force_N=axial_force(f_tibia, rot))
    ligs = {k: LigamentResult(v, sol.ligament_length_mm[k])
            for k, v in sol.ligament_force_N.items()}
    elapsed = time.perf_counter() - t0
    return RunResult(scene.label, "rigid", "none", True, 1, sol.residual_N,
                     Pose.of(q, theta_x, side=scene.side), comps, ligs,
                     {"total": elapsed, "solve": elapsed})

