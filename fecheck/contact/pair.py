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

import warnings
from functools import lru_cache
from typing import NamedTuple

import numpy as np

from fecheck.contact.analytic import Plane, PolynomialSurface, Sphere
from fecheck.contact.broadphase import (
    CandidateCache,
    Candidates,
    checked_relative_pose,
    pose_status,
)
from fecheck.contact.kernels import NO_RIM, plane_surface, sphere_surface
from fecheck.contact.surface import ContactSurface, build_surface
from fecheck.errors import FecheckError
from geometry.mesh import TriMesh

METHODS = ("auto", "closed-form", "bvh", "ray-parity", "fcl")
CLOSED_MASTER_METHODS = {"ray-parity": "counting ray crossings",
                         "fcl": "FCL's penetration query of two solids"}
"""Detection methods that need a closed (watertight) master mesh, and why."""
AREAS = ("clipped", "whole-face")


class Prepared(NamedTuple):
    """An evaluation's candidate set (None for the thesis's detectors) and poses: the
    relative pose y = R p + t (slave → master frame) and both bodies' poses."""

    cand: Candidates | None
    R: np.ndarray
    t: np.ndarray
    Rs: np.ndarray
    ts: np.ndarray
    Rm: np.ndarray
    tm: np.ndarray


def _pose_arrays(pose, name: str) -> tuple[np.ndarray, np.ndarray]:
    """(R, t) as contiguous float arrays of shapes (3, 3) and (3,); FecheckError else."""
    try:
        R, t = pose
        R = np.ascontiguousarray(R, dtype=float)
        t = np.ascontiguousarray(t, dtype=float)
    except (TypeError, ValueError) as err:
        raise FecheckError(f"{name} pose must be a pair (R (3, 3), t (3,) mm)") from err
    if R.shape != (3, 3) or t.shape != (3,):
        raise FecheckError(f"{name} pose must be (R (3, 3), t (3,) mm), "
                           f"got shapes {R.shape} and {t.shape}")
    return R, t


def raise_bad_pose(status: int, name: str) -> None:
    """FecheckError for a `fecheck.contact.broadphase.pose_status` other than 0."""
    if status == 1:
        raise FecheckError(f"{name} pose translation contains NaN or infinite values")
    if status == 2:
        raise FecheckError(f"{name} rotation is not orthonormal with det +1 (or contains "
                           "NaN); build it with fecheck.statics.frames.rotation")


def checked_poses(slave_pose, master_pose) -> tuple[np.ndarray, ...]:
    """(Rs, ts, Rm, tm) as contiguous float arrays; FecheckError unless each pose is a pair
    of shapes (3, 3) and (3,) (the values are checked in compiled code)."""
    return _pose_arrays(slave_pose, "slave") + _pose_arrays(master_pose, "master")


def validate_pose(pose, name: str) -> tuple[np.ndarray, np.ndarray]:
    """(R, t) as float arrays; FecheckError unless R is a proper rotation (orthonormal
    within 1e-6, det +1) and t is finite (`fecheck.contact.broadphase.pose_status`)."""
    R, t = _pose_arrays(pose, name)
    raise_bad_pose(pose_status(R, t), name)
    return R, t


def drop_duplicate_faces(mesh: TriMesh) -> TriMesh:
    """`mesh` without repeated faces (same three vertices, any order or winding).

    A repeated face would count its area and pressure twice; the copies are dropped with a
    warning (the first occurrence is kept, so the result equals the clean mesh) rather than
    refused, since exporters commonly emit such copies and the intent is unambiguous.
    Face regions are renumbered. Returns `mesh` itself when it has no duplicates.
    """
    _, first = np.unique(np.sort(mesh.faces, axis=1), axis=0, return_index=True)
    n_dup = mesh.n_faces - len(first)
    if n_dup == 0:
        return mesh
    keep = np.sort(first)
    warnings.warn(f"the slave mesh has {n_dup} duplicate face(s) (same three vertices); "
                  "dropped the copies so that each face counts once", stacklevel=3)
    new_index = np.full(mesh.n_faces, -1)
    new_index[keep] = np.arange(len(keep))
    regions = {name: new_index[f][new_index[f] >= 0] for name, f in mesh.regions.items()}
    return TriMesh(mesh.points, mesh.faces[keep], regions)


def boundary_vertices(mesh: TriMesh) -> np.ndarray:
    """(n_points,) True for vertices on a boundary edge (an edge of one face only)."""
    e = np.sort(mesh.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    edges, counts = np.unique(e, axis=0, return_counts=True)
    out = np.zeros(mesh.n_points, dtype=bool)
    out[edges[counts == 1].ravel()] = True
    return out


@lru_cache(maxsize=8)
def _mesh_master(mesh: TriMesh, sign: str):
    """One `MeshMaster` per master mesh object (the tree, rings and kernels built once:
    both compartments of a femur-tibia scene share the femoral surface)."""
    from fecheck.contact.mesh_master import MeshMaster

    return MeshMaster(mesh, sign=sign)


def _resolved_method(slave: TriMesh, master, method: str, area: str, margin_mm: float
                     ) -> str:
    """Check a pair's inputs; the detection method, with 'auto' resolved."""
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
    if method in CLOSED_MASTER_METHODS and boundary_vertices(master).any():
        raise FecheckError(f"contact.detection = {method!r} tells inside from outside by "
                           f"{CLOSED_MASTER_METHODS[method]}, which needs a closed master "
                           f"mesh; this master is open ({int(boundary_vertices(master).sum())} "
                           "boundary vertices, e.g. a cartilage sheet): use 'bvh' (or "
                           "'auto'), which measures depth along the face normals of open "
                           "sheets")
    return method


def _analytic_kernel(master) -> tuple[object, tuple, tuple | None]:
    """The compiled surface kernel of a plane or sphere master, its arguments, and the
    master as `fecheck.laws.fused.closed_form_wrench` takes it ((is a sphere, (point,
    normal) or (centre, radius) in one array)), loaded now (compiled, or read from
    numba's cache); (None, (), None) for other masters."""
    if isinstance(master, Plane):
        kernel, args = plane_surface, (master.point, master.normal)
        packed = (False, np.concatenate([master.point, master.normal]))
    elif isinstance(master, Sphere):
        kernel, args = sphere_surface, (master.center, master.radius)
        packed = (True, np.append(master.center, master.radius))
    else:
        return None, (), None
    eye, zero = np.eye(3), np.zeros(3)
    kernel(True, True, np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), np.zeros((0, 3)),
           np.zeros(0), eye, zero, eye, zero, eye, *args)
    return kernel, args, packed


class ContactPair:
    """Penetration of `slave` (a triangle mesh) into `master`, pose after pose.

    Parameters
    ----------
    slave : slave surface in its body frame, mm, faces counter-clockwise from outside;
        repeated faces are dropped with a warning (`drop_duplicate_faces`) and
        ``pair.slave`` is the mesh actually used; ``pair.boundary_vertex`` marks its
        vertices on boundary edges (a contact reaching them is cut by the mesh's rim)
    master : `Plane`, `Sphere`, `PolynomialSurface` (master body frame) or a `TriMesh`
    method : "auto" (closed form for analytic masters, BVH for meshes), "closed-form",
        "bvh", or the thesis's algorithms "ray-parity" (Algorithm 3) and "fcl"
    area : "clipped" (exact in-contact part of each face) or "whole-face" (the thesis's
        counting, its Fig. 3.20: every face with a vertex in contact counts whole, at
        the face's largest vertex depth — what fcl reports per face. At the thesis's
        loads and 5,120 faces this gives d 0.81/0.84 mm and p_max 3.62/3.77 MPa against
        its Table 5.3 d 0.80/0.85 mm, p_max 3.59/3.81 MPa; exact: 0.955/1.015 mm)
        The "fcl" method always counts whole faces.
    margin_mm : broad-phase reach; candidate faces are reused while no slave vertex can
        have moved more than 90 % of it relative to a mesh master, half of it relative to
        an analytic one (`fecheck.contact.broadphase`)
    mesh_sign : inside/outside test of a mesh master, "normal" (side of the closest
        face normal; open sheets) or "winding" (generalised winding number; closed
        meshes), see `fecheck.contact.mesh_master`
    rim_mm : 0 (default) or the width (mm) of a fade at the rim of an open mesh master
        (BVH, "normal" sign): a slave point's depth is scaled by a smoothstep of the
        distance from its closest master point to the master's boundary edges, from 0
        on the rim to 1 at `rim_mm` inside it. A point whose closest master point is on
        the rim (behind or beyond an open sheet's edge, where the side-of-normal test
        would see a wall) carries no contact, as a ray along its normal missing the sheet
        would; the fade keeps the force and its tangent continuous there

    `Plane` and `Sphere` masters are evaluated by compiled kernels
    (`fecheck.contact.kernels`); a pair loads its kernel when it is built (from numba's
    on-disk cache, ~1 s in a fresh process; compiled once, ~10-20 s, on first use).
    """

    def __init__(self, slave: TriMesh, master, *, method: str = "auto",
                 area: str = "clipped", margin_mm: float = 2.0,
                 mesh_sign: str = "normal", rim_mm: float = 0.0) -> None:
        method = _resolved_method(slave, master, method, area, margin_mm)
        if not (np.isfinite(rim_mm) and rim_mm >= 0.0):
            raise FecheckError(f"rim_mm must be 0 or a positive number of mm, got {rim_mm}")
        if rim_mm > 0.0 and (method != "bvh" or mesh_sign != "normal"):
            raise FecheckError("rim_mm (a fade at an open master sheet's rim) needs a mesh "
                               "master with the 'bvh' method and mesh_sign='normal'")
        slave = drop_duplicate_faces(slave)
        self.slave, self.method, self.area_mode = slave, method, area
        self.boundary_vertex = boundary_vertices(slave)
        self.margin_mm = float(margin_mm)
        self.resolved_method = method
        self._thesis = None
        self._rim = (NO_RIM, 0.0)
        if method == "closed-form":
            self.master = master
        elif method == "bvh":
            self.master = _mesh_master(master, mesh_sign)
            if rim_mm > 0.0:
                self._rim = (self.master.rim_distance, float(rim_mm))
        else:
            from fecheck.contact.thesis import thesis_detector
            self.master = master
            self._thesis = thesis_detector(method, slave, master, area)
        self._kernel, self._kernel_args, self._closed_form = _analytic_kernel(self.master)
        # the candidate set of the last call and its points' WalkState (closest master
        # faces, depth bounds), the start of the next call while the set is reused
        self._warm: tuple[object, object] = (None, None)
        if self._thesis is None:
            region = getattr(self.master, "region", None)
            reach = (self.master.margin_reach(self.margin_mm) if method == "bvh"
                     else self.master.reach)
            self._cache = CandidateCache(slave, reach, self.margin_mm,
                                         region=region(self.margin_mm) if region else None,
                                         lipschitz_reach=method == "bvh")

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
                f"reused while the pose moves < {self._cache.reuse_limit_mm:g} mm")

    @property
    def analytic_kernel(self) -> tuple[object, tuple]:
        """The compiled kernel of a plane or sphere master (`fecheck.contact.kernels`) and
        its master arguments; (None, ()) for other masters."""
        return self._kernel, self._kernel_args

    @property
    def closed_form_master(self) -> tuple[bool, np.ndarray] | None:
        """A plane or sphere master as `fecheck.laws.fused.closed_form_wrench` takes it:
        (is a sphere, (point, normal) or (centre, radius) in one array, mm); else None."""
        return self._closed_form

    @property
    def rim(self) -> tuple[np.ndarray, float]:
        """The rim fade: (the mesh master's `rim_distance`, width mm), or (`NO_RIM`, 0)
        without one."""
        return self._rim

    @property
    def walk_tables(self) -> tuple:
        """A mesh master's `walk_tables` and the pair's `rim`, as
        `fecheck.contact.kernels.walked_mesh_surface` takes them."""
        return (*self.master.walk_tables, *self._rim)

    @property
    def cache(self) -> CandidateCache:
        """The broad-phase candidate cache (its counters show rebuilds and reuses)."""
        return self._cache

    def prepare(self, slave_pose, master_pose) -> Prepared:
        """The checked poses and the candidate set of an evaluation (for compiled callers
        that integrate a law themselves, `fecheck.laws.fused`).

        Parameters
        ----------
        slave_pose, master_pose : (R (3, 3), t (3,) mm), body frame to world: x = R p + t
        """
        Rs, ts, Rm, tm = checked_poses(slave_pose, master_pose)
        R, t, slave_status, master_status = checked_relative_pose(Rs, ts, Rm, tm)
        raise_bad_pose(slave_status, "slave")
        raise_bad_pose(master_status, "master")
        cand = self._cache.get(R, t) if self._thesis is None else None
        return Prepared(cand, R, t, Rs, ts, Rm, tm)

    def forget(self) -> None:
        """Drop the candidate set and the walk state kept from earlier calls, so that the
        next evaluation starts as a fresh pair's does (its numbers then do not depend on
        the poses evaluated before, even at round-off)."""
        if self._thesis is None:
            self._cache.reset()
        self._warm = (None, None)

    def warm_state(self, cand: Candidates):
        """The mesh master's walk state of the candidate points if it belongs to `cand`
        (the last call's set), else None."""
        return self._warm[1] if self._warm[0] is cand else None

    def evaluate(self, slave_pose, master_pose) -> ContactSurface:
        """Contact surface in world coordinates for the given body poses.

        Parameters
        ----------
        slave_pose, master_pose : (R (3, 3), t (3,) mm), body frame to world: x = R p + t
        """
        cand, R, t, Rs, ts, Rm, tm = self.prepare(slave_pose, master_pose)
        if self._thesis is not None:
            return self._thesis.evaluate(Rs, ts, Rm, tm)
        master = self.master
        if cand.faces.size == 0:
            return ContactSurface.empty(self.slave.n_faces, master.normal_body)
        if self._kernel is not None:
            hit, normal, depth, *qp = self._kernel(
                self.area_mode == "clipped", True, cand.points, cand.local_faces, cand.normals,
                cand.areas, R, t, Rm, tm, Rs, *self._kernel_args)
            if hit.size == 0:
                return ContactSurface.empty(self.slave.n_faces, master.normal_body)
            return ContactSurface(cand.faces[hit], normal, depth, *qp, master.normal_body,
                                  self.slave.n_faces)
        if self.resolved_method == "bvh":
            state, (hit, normal, depth, *qp) = master.surface(
                self.area_mode == "clipped", cand, R, t, Rm, tm, Rs, self.warm_state(cand),
                self._rim)
            self._warm = (cand, state)
            if hit.size == 0:
                return ContactSurface.empty(self.slave.n_faces, master.normal_body)
            return ContactSurface(cand.faces[hit], normal, depth, *qp, master.normal_body,
                                  self.slave.n_faces)
        y = cand.points @ R.T + t
        d = master.depth_values(y)[cand.local_faces]
        hit = np.nonzero(d.max(axis=1) > 0.0)[0]
        if hit.size == 0:
            return ContactSurface.empty(self.slave.n_faces, master.normal_body)
        faces = cand.local_faces[hit]
        return build_surface(master, self.area_mode, self.slave.n_faces, cand, hit, d[hit],
                             y[faces], R, Rm, tm, Rs)
