"""How well an FE answer balances the scene's load on each rigid body's free DOFs."""

from __future__ import annotations

import numpy as np

from fecheck.fe.bodies.pose import FramePose
from fecheck.fe.knee.crosscheck import CompartmentCheck, CrossCheck
from fecheck.model.assembly import applied_load, free_indices
from fecheck.model.run import ligament_springs
from fecheck.scene import Scene
from fecheck.statics.newton import pose, twist_basis


def free_dof_balance(scene: Scene, check: CrossCheck, flexion: tuple = (0.0,)) -> float:
    """The largest of `body_balance`: zero at equilibrium."""
    return max(body_balance(scene, check, flexion).values())


def _contact_wrench(checks: list[CompartmentCheck], X_WB: FramePose) -> np.ndarray:
    """The FE contact forces of `checks` on the body B at X_WB they are carried by: force
    and moment about the world origin (6,), N and N·mm."""
    total = np.zeros(6)
    for chk in checks:
        x = X_WB.points(chk.layer.surface.points)
        f = -chk.fe_force_N[:, None] * X_WB.vectors(chk.layer.solid.normals)
        total += np.concatenate([f.sum(axis=0), np.cross(x, f).sum(axis=0)])
    return total


def body_balance(scene: Scene, check: CrossCheck, flexion: tuple = (0.0,)) -> dict[str, float]:
    """{body: the largest generalised force on its free DOFs at the FE pose of `check`
    over its load}: the tibia's (load, gravity, ligaments, what a body beyond the tibia
    puts on it, e.g. the patellar tendon, and the FE contact forces on the tibia) over
    load.force_N, moments over 100 mm · load.force_N; with a body beyond the tibia, its own
    (`fecheck.fe.knee.knee_body.BodyAtEF.balance`: for the patella the quadriceps,
    patellofemoral bundles, tendon and its FE contact over the quadriceps' total, moments
    over 100 mm times it). `flexion`: the tibia's (θx rad, base rotation or None) as
    `fecheck.statics.newton.pose` takes them."""
    q = np.asarray(check.pose["fe"].q, dtype=float)
    X_WT = FramePose(*pose(q, *flexion), "W", "T")
    total = sum(part(*X_WT.pair())[0] for part in [applied_load(scene), *ligament_springs(scene)])
    carried = {}
    for chk in check.compartments.values():
        carried.setdefault(chk.layer.body.carrier, []).append(chk)
    total = total + _contact_wrench(carried.get("T", []), X_WT)
    out = {}
    extra = check.extra
    if extra is not None:
        on_tibia, out[extra.kind.name] = extra.balance(
            X_WT, _contact_wrench(carried.get(extra.kind.frame, []), extra.fe_pose()))
        total = total + on_tibia
    free = list(free_indices(scene))
    residual = (twist_basis(q, *flexion).T @ total)[free]
    scale = np.where(np.array(free) < 3, 1.0, 100.0) * scene["load.force_N"]
    return {"tibia": float(np.abs(residual / scale).max())} | out
