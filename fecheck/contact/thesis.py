"""The thesis's own detection algorithms, behind the `ContactPair` interface (for comparison).

* ``ray-parity`` — thesis Algorithm 3: slave vertices inside the master's bounding box
  are tested by ray-casting parity (trimesh ``contains``; embree through embreex when
  installed, or trimesh's pure ray engine with ``engine="triangle"``, which is what made
  the thesis's Fig. 3.25 quadratic); the depth of a vertex is its distance to the
  nearest master VERTEX (scipy cKDTree), as in the thesis. Its flaws are kept: parity is
  meaningless on open meshes (rays escape through the hole), and the nearest-vertex
  distance is not a surface distance. Outside vertices of touched faces get minus that
  distance so the face can be clipped (or counted whole, ``area="whole-face"``). The gradient is the
  exact gradient of that distance, ±(y - v)/|y - v|.
* ``fcl`` — thesis §3.2: python-fcl through trimesh's converters, the slave as a
  triangle BVH (``trimesh.collision.mesh_to_BVH``), the master as a convex polytope
  (``mesh_to_convex``: GJK/EPA per slave triangle) when it is convex, else as a BVH (the
  thesis's concave-concave case, whose depths are meaningless). Each slave face in
  contact counts whole at its largest penetration depth along the contact normal
  (which becomes the foundation normal, fixed in the master). fcl stops at 100,000
  contacts, silently: more raises a FecheckError here.

Optional dependencies (trimesh, embreex, python-fcl) are imported when a pair is built.
"""

from __future__ import annotations

import numpy as np

from fecheck.contact.broadphase import Candidates
from fecheck.contact.clip import whole_face_quadrature
from fecheck.contact.surface import ContactSurface, build_surface
from fecheck.errors import FecheckError
from geometry.mesh import TriMesh

FCL_MAX_CONTACTS = 100_000


def _all_faces(slave: TriMesh) -> Candidates:
    return Candidates(faces=np.arange(slave.n_faces), local_faces=slave.faces,
                      vertices=np.arange(slave.n_points), points=slave.points,
                      normals=slave.face_normals, areas=slave.face_areas)


def _trimesh(mesh: TriMesh):
    try:
        import trimesh
    except ImportError as err:
        raise FecheckError("the thesis methods need trimesh: pip install trimesh") from err
    return trimesh.Trimesh(mesh.points, mesh.faces, process=False)


class RayParity:
    """Thesis Algorithm 3 (ray-casting parity + nearest-vertex distance)."""

    uses_slave_normal = False
    normal_body = "slave"

    def __init__(self, slave: TriMesh, master: TriMesh, area_mode: str,
                 engine: str = "auto") -> None:
        from scipy.spatial import cKDTree

        self.slave, self.master, self.area_mode = slave, master, area_mode
        self._mesh = _trimesh(master)
        if engine == "triangle":                    # trimesh's pure-NumPy/rtree ray engine
            from trimesh.ray.ray_triangle import RayMeshIntersector

            self._mesh.ray = RayMeshIntersector(self._mesh)
        elif engine != "auto":
            raise FecheckError(f"unknown ray engine {engine!r}; choose 'auto' or 'triangle'")
        self._engine = type(self._mesh.ray).__module__.rsplit(".", 1)[-1]
        self._tree = cKDTree(master.points)
        self._box = (master.points.min(axis=0), master.points.max(axis=0))
        self._all = _all_faces(slave)

    def describe(self) -> str:
        return (f"thesis Algorithm 3: ray-casting parity ({self._engine}) + cKDTree "
                f"nearest-vertex depth; {self.area_mode} area")

    def evaluate(self, Rs, ts, Rm, tm) -> ContactSurface:
        R = Rm.T @ Rs
        t = Rm.T @ (ts - tm)
        y = self.slave.points @ R.T + t
        lo, hi = self._box
        in_box = np.flatnonzero(np.all((y >= lo) & (y <= hi), axis=1))
        inside = np.zeros(len(y), dtype=bool)
        if in_box.size:
            inside[in_box] = self._mesh.contains(y[in_box])
        faces = self.slave.faces
        hit = np.flatnonzero(inside[faces].any(axis=1))
        if hit.size == 0:
            return ContactSurface.empty(self.slave.n_faces, self.normal_body)
        verts = np.unique(faces[hit])
        dist, nearest = self._tree.query(y[verts])
        sign = np.where(inside[verts], 1.0, -1.0)
        depth = np.zeros(len(y))
        grad = np.zeros((len(y), 3))
        depth[verts] = sign * dist
        offset = y[verts] - self.master.points[nearest]
        grad[verts] = sign[:, None] * offset / np.maximum(dist, 1e-300)[:, None]
        tri = faces[hit]
        return build_surface(self, self.area_mode, self.slave.n_faces, self._all, hit,
                             depth[tri], y[tri], R, Rm, tm, Rs, grad[tri])


class FclPerFace:
    """Thesis §3.2: python-fcl per-face contacts, whole faces at their deepest point."""

    def __init__(self, slave: TriMesh, master: TriMesh) -> None:
        try:
            import fcl
            from trimesh.collision import mesh_to_BVH, mesh_to_convex
        except ImportError as err:
            raise FecheckError("method 'fcl' needs python-fcl and trimesh: "
                               "pip install 'fecheck[thesis]'") from err
        self._fcl = fcl
        self.slave = slave
        master_tm = _trimesh(master)
        self.convex = bool(master_tm.is_convex)
        geometry = mesh_to_convex(master_tm) if self.convex else mesh_to_BVH(master_tm)
        self._slave_obj = fcl.CollisionObject(mesh_to_BVH(_trimesh(slave)), fcl.Transform())
        self._master_obj = fcl.CollisionObject(geometry, fcl.Transform())

    def describe(self) -> str:
        kind = "convex master (GJK/EPA per triangle)" if self.convex else "BVH master"
        return f"thesis fcl: slave triangle BVH vs {kind}; whole faces at their deepest point"

    def evaluate(self, Rs, ts, Rm, tm) -> ContactSurface:
        fcl = self._fcl
        self._slave_obj.setTransform(fcl.Transform(Rs, ts))
        self._master_obj.setTransform(fcl.Transform(Rm, tm))
        request = fcl.CollisionRequest(num_max_contacts=FCL_MAX_CONTACTS, enable_contact=True)
        result = fcl.CollisionResult()
        fcl.collide(self._slave_obj, self._master_obj, request, result)
        contacts = result.contacts
        if len(contacts) >= FCL_MAX_CONTACTS:
            raise FecheckError(f"fcl reached its cap of {FCL_MAX_CONTACTS} contacts and "
                               "truncated the result; use a coarser slave or method='bvh'")
        if not contacts:
            return ContactSurface.empty(self.slave.n_faces, "master")
        face = np.fromiter((c.b1 for c in contacts), dtype=np.int64, count=len(contacts))
        depth = np.fromiter((c.penetration_depth for c in contacts), dtype=float,
                            count=len(contacts))
        normal = np.array([c.normal for c in contacts], dtype=float)
        order = np.lexsort((-depth, face))                 # deepest contact of each face
        first = order[np.r_[True, face[order][1:] != face[order][:-1]]]
        face, depth, grad = face[first], depth[first], normal[first]
        # fcl's normal points from the slave into the master: the depth grows along it,
        # and the pressure on the slave acts against it.
        X = self.slave.triangles[face] @ Rs.T + ts
        qp_face, bary, qfrac = whole_face_quadrature(len(face))
        qp_point = np.einsum("qi,qij->qj", bary, X[qp_face])
        g = grad[qp_face]
        return ContactSurface(
            face=face, normal=-grad, vertex_depth=np.repeat(depth[:, None], 3, axis=1),
            qp_face=qp_face, qp_bary=bary, qp_point=qp_point, qp_depth=depth[qp_face],
            qp_weight=qfrac * self.slave.face_areas[face][qp_face],
            qp_depth_twist=np.concatenate([g, np.cross(qp_point, g)], axis=1),
            qp_weight_twist=np.zeros((len(qp_face), 6)), qp_clip=np.zeros(0, dtype=int),
            clip_share=np.zeros((0, 2)), clip_face=np.zeros(0, dtype=int),
            clip_edge=np.zeros((0, 2, 3)), clip_rate=np.zeros((0, 2, 6)), normal_body="master",
            n_slave_faces=self.slave.n_faces)


def thesis_detector(method: str, slave: TriMesh, master: TriMesh, area_mode: str):
    """The detector object for `method` ("ray-parity" or "fcl")."""
    if method == "ray-parity":
        return RayParity(slave, master, area_mode)
    return FclPerFace(slave, master)
