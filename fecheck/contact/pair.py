"""A slave mesh against a master: the contact query the statics solver calls every iteration.

>>> import numpy as np
>>> from geometry.mesh import TriMesh
>>> from fecheck.contact.analytic import Plane
>>> tri = TriMesh(np.array([[0., 0, -1], [2, 0, -1], [0, 2, -1]]), np.array([[0, 1, 2]]))
>>> pair = ContactPair(tri, Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]))
>>> I, o = np.eye(3), np.zeros(3)
>>> s = pair.evaluate((I, o), (I, o))
>>> round(s.area, 6), round(float((s.qp_weight * s.qp_depth).sum()), 6)
(2.0, 2.0)
"""

from __future__ import annotations

import numpy as np

from fecheck.contact.analytic import Plane, PolynomialSurface, Sphere
from fecheck.contact.broadphase import CandidateCache
from fecheck.contact.clip import clip_faces, quadrature, whole_faces
from fecheck.contact.surface import ContactSurface
from geometry.errors import FecheckError
from geometry.mesh import TriMesh

METHODS = ("auto", "closed-form", "bvh", "ray-parity", "fcl")
AREAS = ("clipped", "whole-face")
_EYE = np.eye(3)
_ROLL1, _ROLL2 = [1, 2, 0], [2, 0, 1]


def validate_pose(pose, name: str) -> tuple[np.ndarray, np.ndarray]:
    """(R, t) as float arrays; FecheckError unless R is a finite proper rotation."""
    try:
        R, t = pose
        R = np.asarray(R, dtype=float)
        t = np.asarray(t, dtype=float)
    except (TypeError, ValueError) as err:
        raise FecheckError(f"{name} pose must be a pair (R (3, 3), t (3,) mm)") from err
    if R.shape != (3, 3) or t.shape != (3,):
        raise FecheckError(f"{name} pose must be (R (3, 3), t (3,) mm), "
                           f"got shapes {R.shape} and {t.shape}")
    if not np.isfinite(R.sum() + t.sum()):
        raise FecheckError(f"{name} pose contains NaN or infinite values")
    if np.abs(R.T @ R - _EYE).max() > 1e-6 or R[0] @ _cross(R[1], R[2]) < 0:
        raise FecheckError(f"{name} rotation is not orthonormal with det +1; "
                           "build it with fecheck.frames.rotation")
    return R, t


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b over the last axis (cheaper than np.cross on small arrays)."""
    return a[..., _ROLL1] * b[..., _ROLL2] - a[..., _ROLL2] * b[..., _ROLL1]


def _apply(a: np.ndarray, R: np.ndarray, t: np.ndarray | None = None) -> np.ndarray:
    """R a (+ t) for an array of 3-vectors of any leading shape."""
    out = a.reshape(-1, 3) @ R.T
    if t is not None:
        out += t
    return out.reshape(a.shape)


def _skew(v: np.ndarray) -> np.ndarray:
    out = np.zeros(v.shape + (3,))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


class ContactPair:
    """Penetration of `slave` (a triangle mesh) into `master`, pose after pose.

    Parameters
    ----------
    slave : slave surface in its body frame, mm, faces counter-clockwise from outside
    master : `Plane`, `Sphere`, `PolynomialSurface` (master body frame) or a `TriMesh`
    method : "auto" (closed form for analytic masters, BVH for meshes), "closed-form",
        "bvh", or the thesis's algorithms "ray-parity" (Algorithm 3) and "fcl"
    area : "clipped" (exact in-contact part of each face) or "whole-face" (the thesis's
        counting: every face with a vertex in contact counts whole, at the face's
        largest vertex depth)
    margin_mm : broad-phase reach; candidate faces are reused while no slave vertex can
        have moved more than half of it relative to the master
    mesh_sign : inside/outside test of a mesh master, "normal" (side of the closest
        face normal; open sheets) or "winding" (generalised winding number; closed
        meshes), see `fecheck.contact.mesh_master`
    """

    def __init__(self, slave: TriMesh, master, *, method: str = "auto",
                 area: str = "clipped", margin_mm: float = 2.0,
                 mesh_sign: str = "normal") -> None:
        if not isinstance(slave, TriMesh):
            raise FecheckError("the slave must be a geometry.mesh.TriMesh")
        if slave.n_faces == 0:
            raise FecheckError("the slave mesh has no faces; check the mesh file or builder")
        if method not in METHODS:
            raise FecheckError(f"unknown contact method {method!r}; choose one of "
                               + ", ".join(METHODS))
        if area not in AREAS:
            raise FecheckError(f"unknown area mode {area!r}; choose 'clipped' or 'whole-face'")
        if not (np.isfinite(margin_mm) and margin_mm > 0):
            raise FecheckError(f"margin_mm must be a positive number of mm, got {margin_mm}")
        self.slave, self.method, self.area_mode = slave, method, area
        self.margin_mm = float(margin_mm)
        analytic = isinstance(master, (Plane, Sphere, PolynomialSurface))
        if not analytic and not isinstance(master, TriMesh):
            raise FecheckError("the master must be a Plane, Sphere, PolynomialSurface "
                               "or a TriMesh")
        if method == "auto":
            method = "closed-form" if analytic else "bvh"
        if method == "closed-form" and not analytic:
            raise FecheckError("method 'closed-form' needs an analytic master; "
                               "use 'bvh' for a mesh master")
        if method in ("bvh", "ray-parity", "fcl") and analytic:
            raise FecheckError(f"method {method!r} needs a mesh master; analytic masters "
                               "use 'closed-form'")
        self.resolved_method = method
        self._thesis = None
        if method == "closed-form":
            self.master = master
        elif method == "bvh":
            from fecheck.contact.mesh_master import MeshMaster
            self.master = MeshMaster(master, sign=mesh_sign, margin_mm=self.margin_mm)
        else:
            from fecheck.contact.thesis import thesis_detector
            self.master = master
            self._thesis = thesis_detector(method, slave, master, area)
        if self._thesis is None:
            self._cache = CandidateCache(slave, self.master.reach, self.margin_mm,
                                         prefilter=getattr(self.master, "prefilter", None))

    def describe(self) -> str:
        """One line on how this pair is evaluated (for ``--explain``)."""
        if self._thesis is not None:
            return self._thesis.describe()
        area = ("exact clipping at zero depth" if self.area_mode == "clipped"
                else "whole faces (thesis counting)")
        if self.resolved_method == "closed-form":
            how = f"closed form ({self.master.describe()}), no BVH"
        else:
            how = self.master.describe()
        return (f"{how}; {area}; broad phase keeps slave faces within {self.margin_mm:g} mm, "
                f"reused while the pose moves < {0.5 * self.margin_mm:g} mm")

    @property
    def cache(self) -> CandidateCache:
        """The broad-phase candidate cache (its counters show rebuilds and reuses)."""
        return self._cache

    def evaluate(self, slave_pose, master_pose) -> ContactSurface:
        """Contact surface in world coordinates for the given body poses.

        Parameters
        ----------
        slave_pose, master_pose : (R (3, 3), t (3,) mm), body frame to world: x = R p + t
        """
        Rs, ts = validate_pose(slave_pose, "slave")
        Rm, tm = validate_pose(master_pose, "master")
        if self._thesis is not None:
            return self._thesis.evaluate(Rs, ts, Rm, tm)
        R = Rm.T @ Rs
        t = Rm.T @ (ts - tm)
        master = self.master
        body = master.normal_body
        cand = self._cache.get(R, t)
        if cand.faces.size == 0:
            return ContactSurface.empty(self.slave.n_faces, body)
        y = cand.points @ R.T + t
        grad = None
        if master.uses_slave_normal:
            u = _apply(cand.normals, -R)
            d = master.depth_values(y[cand.local_faces], u[:, None, :])
        elif hasattr(master, "depth_and_gradients"):        # one BVH query for both
            dv, grad = master.depth_and_gradients(y)
            d = dv[cand.local_faces]
        else:
            d = master.depth_values(y)[cand.local_faces]
        hit = np.flatnonzero(d.max(axis=1) > 0.0)
        if hit.size == 0:
            return ContactSurface.empty(self.slave.n_faces, body)
        faces = cand.local_faces[hit]
        return build_surface(master, self.area_mode, self.slave.n_faces, cand, hit, d[hit],
                             y[faces], R, Rm, tm, Rs, None if grad is None else grad[faces])


def build_surface(master, area_mode: str, n_slave_faces: int, cand, hit: np.ndarray,
                  D: np.ndarray, Y: np.ndarray, R: np.ndarray, Rm: np.ndarray,
                  tm: np.ndarray, Rs: np.ndarray, g: np.ndarray | None = None
                  ) -> ContactSurface:
    """Quadrature, twist derivatives and normals of the contact faces `hit` of `cand`.

    D (m, 3) vertex depths and Y (m, 3, 3) vertex positions in the master frame (mm);
    R the slave-to-master rotation; (Rm, tm) the master pose; Rs the slave rotation;
    g (m, 3, 3) the depth gradients if already known (master frame).
    """
    m = len(hit)
    nf_w = _apply(cand.normals[hit], Rs)                  # slave face normals, world
    X = _apply(Y, Rm, tm)                                 # (m, 3, 3) world vertices
    if master.uses_slave_normal:
        U = np.broadcast_to(_apply(cand.normals[hit], -R)[:, None, :], Y.shape)
        g, h = master.depth_gradients(Y, U)
        gw = _apply(g, Rm)
        rot = _cross(X, gw) - _cross(nf_w[:, None, :], _apply(h, Rm))
    else:
        gw = _apply(master.depth_gradients(Y)[0] if g is None else g, Rm)
        rot = _cross(X, gw)
    # Per vertex: depth, world position, ∂d/∂v, ∂d/∂ω — interpolated in one pass.
    vertex = np.concatenate([D[:, :, None], X, gw, rot], axis=-1)      # (m, 3, 10)

    normal_twist = np.zeros((m, 3, 6))
    if master.normal_body == "slave":
        N = -nf_w
        normal_twist[:, :, 3:] = -_skew(N)
    else:
        Nm, dN = master.foundation_normals(Y)
        N = _apply(Nm, Rm)
        cos = np.einsum("ij,ij->i", nf_w, N)
        dcos = np.zeros((m, 6))
        dcos[:, 3:] = _cross(nf_w, N)
        if dN is not None:
            A = Rm @ dN @ Rm.T
            normal_twist[:, :, :3] = A
            normal_twist[:, :, 3:] = -A @ _skew(X.sum(axis=1) / 3.0)
            dcos += np.einsum("ij,ijk->ik", nf_w, normal_twist)
        dproj = np.sign(cos)[:, None] * dcos

    if area_mode == "clipped":
        parent, corners, frac = clip_faces(D)
    else:
        parent, corners, frac = whole_faces(m)
    qp_face, bary, qfrac = quadrature(parent, corners, frac)
    qp = np.einsum("qi,qij->qj", bary, vertex[qp_face])
    qp_depth, qp_depth_twist = qp[:, 0], qp[:, 4:]
    if area_mode == "whole-face":
        deepest = vertex[np.arange(m), np.argmax(D, axis=1)][qp_face]
        qp_depth, qp_depth_twist = deepest[:, 0], deepest[:, 4:]
    area = qfrac * cand.areas[hit][qp_face]
    if master.normal_body == "slave":
        weight, weight_twist = area, np.zeros((len(qp_face), 6))
    else:
        weight = area * np.abs(cos)[qp_face]
        weight_twist = area[:, None] * dproj[qp_face]
    return ContactSurface(
        face=cand.faces[hit], normal=N, vertex_depth=D, qp_face=qp_face, qp_bary=bary,
        qp_point=qp[:, 1:4], qp_depth=qp_depth, qp_weight=weight,
        qp_depth_twist=qp_depth_twist, qp_weight_twist=weight_twist,
        normal_body=master.normal_body, n_slave_faces=n_slave_faces,
        normal_twist=normal_twist)
