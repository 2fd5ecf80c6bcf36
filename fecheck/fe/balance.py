"""How well an FE answer balances the scene's load on the tibia's free DOFs."""

from __future__ import annotations

import numpy as np

from fecheck.fe.crosscheck import CrossCheck
from fecheck.model.assembly import applied_load, free_indices
from fecheck.model.run import ligament_springs
from fecheck.scene import Scene
from fecheck.statics.newton import pose, twist_basis


def free_dof_balance(scene: Scene, check: CrossCheck, flexion: tuple = (0.0,)) -> float:
    """The largest generalised force on the free DOFs at the FE pose of `check` (load,
    gravity, ligaments and the FE contact forces on the tibia) over the load: forces /
    load.force_N, moments / (100 mm · load.force_N); zero at equilibrium. `flexion`: the
    tibia's (θx rad, base rotation or None) as `fecheck.statics.newton.pose` takes them."""
    q = np.asarray(check.pose["fe"].q, dtype=float)
    rot, t = pose(q, *flexion)
    total = sum(part(rot, t)[0] for part in [applied_load(scene), *ligament_springs(scene)])
    for chk in check.compartments.values():
        x = chk.layer.surface.points @ rot.T + t
        f = -chk.fe_force_N[:, None] * (chk.layer.solid.normals @ rot.T)
        total = total + np.concatenate([f.sum(axis=0), np.cross(x, f).sum(axis=0)])
    free = list(free_indices(scene))
    residual = (twist_basis(q, *flexion).T @ total)[free]
    scale = np.where(np.array(free) < 3, 1.0, 100.0) * scene["load.force_N"]
    return float(np.abs(residual / scale).max())
