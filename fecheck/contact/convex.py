"""Convex-convex contact reduced to one point: the maximum depth only (enough for Hertz).

A closed form serves convex pairs whose law needs the maximum penetration
only. `SpherePlanePair` is the sphere-plane model's condyle (an analytic sphere, centre c,
radius R, fixed in the master, the femur) against its plateau (an analytic plane, point
p and unit normal n up towards the femur, fixed in the slave, the tibia):

    d = R − n·(c − p)        (mm, > 0 in contact)

a smooth function of the pose, unlike the deepest vertex of a meshed slave, which
switches from vertex to vertex as the tibia tilts (Newton stalls on that). With the
`fecheck.contact.surface` twist ξ = (v, ω) of the slave relative to the master (slave
points δx = v + ω × x, slave vectors δn = ω × n, world frame),

    δd = n·v + ω·(c × n)

and the Hertz resultant on the plateau acts along u = −n (δu = ω × u) through the sphere
centre c, which does not move with the slave.

>>> import numpy as np
>>> pair = SpherePlanePair([0.0, 0.0, 25.0], 25.5, [0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
>>> c = pair.evaluate((np.eye(3), np.zeros(3)), (np.eye(3), np.zeros(3)))
>>> round(c.depth_mm, 12), c.direction.tolist()
(0.5, [-0.0, -0.0, -1.0])
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from fecheck.contact.pair import validate_pose
from fecheck.errors import FecheckError
from geometry.mesh import TriMesh


@dataclass(frozen=True, eq=False)
class PointContact:
    """One convex-convex contact at one relative pose (world frame, mm).

    depth_mm : maximum penetration (≤ 0: separated)
    direction : (3,) unit direction of the force on the slave
    point : (3,) a point on the force's line of action, fixed in the master
    depth_twist : (6,) ∂depth/∂ξ, (1, mm) for ξ = (v, ω) (see `fecheck.contact.surface`)
    direction_twist : (3, 6) ∂direction/∂ξ (ω × u for a direction turning with the slave)
    face_centroids : () → (n, 3) world centroids of the faces of a mesh of the slave at
        this pose, for drawing the pressure (called only when a face pressure is asked)
    """

    depth_mm: float
    direction: np.ndarray
    point: np.ndarray
    depth_twist: np.ndarray
    direction_twist: np.ndarray
    face_centroids: Callable[[], np.ndarray] | None = None


def _unit(value, name: str) -> np.ndarray:
    v = np.asarray(value, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)) or np.linalg.norm(v) < 1e-12:
        raise FecheckError(f"{name} must be 3 finite numbers, not all zero; got {value!r}")
    return v / np.linalg.norm(v)


def _point(value, name: str) -> np.ndarray:
    v = np.asarray(value, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise FecheckError(f"{name} must be 3 finite numbers (mm), got {value!r}")
    return v


class SpherePlanePair:
    """An analytic sphere (master body) against an analytic plane (slave body).

    Parameters
    ----------
    center_mm, radius_mm : the sphere in the master body frame (mm)
    plane_point_mm, plane_normal : the plane in the slave body frame; the normal points
        out of the slave, towards the sphere (normalised here)
    mesh : a triangle mesh of the slave (body frame, mm) or a function building it, used
        only to draw the pressure (`slave`, `PointContact.face_centroids`); never queried
        by `evaluate`, and built on first use
    """

    def __init__(self, center_mm, radius_mm: float, plane_point_mm, plane_normal,
                 mesh: TriMesh | Callable[[], TriMesh] | None = None) -> None:
        self.center = _point(center_mm, "sphere centre")
        self.radius_mm = float(radius_mm)
        if not (np.isfinite(self.radius_mm) and self.radius_mm > 0):
            raise FecheckError(f"sphere radius must be a positive number of mm, got {radius_mm}")
        self.plane_point = _point(plane_point_mm, "plane point")
        self.plane_normal = _unit(plane_normal, "plane normal")
        self._mesh = mesh

    def describe(self) -> str:
        """One line on how this pair is evaluated (for ``--explain``)."""
        return ("closed form sphere-plane (Hertz: maximum depth only), no mesh (the slave "
                "mesh only draws the pressure)")

    @cached_property
    def slave(self) -> TriMesh:
        """The slave's mesh for pressure plots (built on first access)."""
        if self._mesh is None:
            raise FecheckError("this sphere-plane pair has no slave mesh to draw pressures on; "
                               "pass mesh= to SpherePlanePair")
        return self._mesh() if callable(self._mesh) else self._mesh

    def evaluate(self, slave_pose, master_pose) -> PointContact:
        """The contact at the given body poses ((R (3, 3), t (3,) mm), body to world)."""
        Rs, ts = validate_pose(slave_pose, "slave")
        Rm, tm = validate_pose(master_pose, "master")
        c = Rm @ self.center + tm
        n = Rs @ self.plane_normal
        depth = self.radius_mm - float(n @ (c - (Rs @ self.plane_point + ts)))
        twist = np.concatenate([n, np.cross(c, n)])
        u = -n
        turn = np.zeros((3, 6))
        turn[:, 3:] = [[0.0, u[2], -u[1]], [-u[2], 0.0, u[0]], [u[1], -u[0], 0.0]]
        centroids = None
        if self._mesh is not None:
            def centroids() -> np.ndarray:
                return self.slave.face_centroids @ Rs.T + ts
        return PointContact(depth, u, c, twist, turn, centroids)
