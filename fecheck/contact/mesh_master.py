"""Mesh masters: signed closest-point depth through libigl's compiled AABB tree (mm).

The tree is built once per master (``igl.AABB.init``) and queried with
``squared_distance`` for the slave points of each evaluation. Depth is the distance to
the closest point, positive inside. Inside/outside:

* ``sign="normal"`` (default): the side of the closest face's normal. For a consistently
  oriented mesh (open sheet or closed) this is exact wherever the closest point lies on
  a face or an edge (at an edge, a point in the outward normal cone is outside both
  faces), which is where contact happens; it costs nothing beyond the closest-point
  query, and it defines inside for an OPEN sheet (a cropped cartilage surface) as the
  side its normals point away from — where a ray-parity test fails (rays escape through
  the hole).
* ``sign="winding"``: the generalised winding number (inside where it exceeds 1/2),
  robust for closed meshes with defects (self-intersections, small holes). A point's
  side comes from a grid of nodes with known side and distance built once per master
  (`fecheck.contact.winding.SideGrid`, 1 mm, wider over large boxes: every point over
  1.73 mm from the surface),
  else from an exact hierarchical winding number (`fecheck.contact.winding.WindingTree`,
  built once); a broad phase that asks only reach > -margin takes the answer from the
  grid's bounds of the signed distance where they tell, and no sign within the margin
  (`MeshMaster.margin_reach`). Measured on the femur_tibia_menisci solve (3,124
  and 3,198 faces, one run, shared machine): ``igl.winding_number`` on every point took
  24 µs a point over 90,000 points (2.1 s of the solve); the tree takes 9-10 µs of CPU
  a point within ~0.3 mm of the surface (igl 13 µs), and the grid and the margin leave
  16,000 points to it. libigl's
  point-cloud fast winding number (precomputed octree) was 24 µs per point and wrong by
  up to 0.93 within 2 mm of the surface, so it is not used.

A pair may fade the depths to zero near the rim of an open sheet (``rim_mm`` of
`fecheck.contact.pair.ContactPair`; `rim_distance`, `fecheck.contact.kernels.fade_at_rim`):
behind the rim the side-of-normal sign acts as a wall, where a ray along the slave's
normal would miss the sheet.

While a contact pair reuses its candidate set, the candidate points keep what they
learnt at the last call (`fecheck.contact.coherent.WalkState`). A point needs no
closest point when every face it belongs to has a negative depth bound (last depth +
distance moved) at all three vertices: the signed distance is 1-Lipschitz, as the broad
phase assumes too, except behind the rim of an open sheet where the side-of-normal sign
jumps. The others check their last closest face against the faces of its 1-ring,
visiting only those that the distances kept from earlier calls (less the point's travel
since) do not prove farther, and walk on if one is closer; the tree answers only points
whose walk does not settle. With the side-of-normal sign all of it, with the clipped
quadrature, is one compiled call (`MeshMaster.surface`,
`fecheck.contact.kernels.walked_mesh_surface`).
Measured (20,480 faces each, 1 mm overlap, 283 candidate points of which ~106 need a
closest point, one run, shared machine): a reused evaluation 75 µs with every point
walked in NumPy-glued calls, 66 µs fused into one call, 40-44 µs with the depth bounds
and a single ring-gap bound per point, 37-39 µs with a bound per ring face (~2 of 12
ring faces re-checked per point at 0.03 mm steps, ~8 after a 0.2 mm jump); the tree
path (a rebuilt set) ~1-2 ms. Of a reused evaluation, the quadrature of ~170 contact
faces (~600 points with their twists) takes ~10 µs and boxing its ~10 arrays ~3 µs.

A tree query keeps its points and answers until the next one (`MeshMaster.tree_closest`):
the full evaluation that follows a broad-phase rebuild asks again for most of the points the
rebuild's reach just asked, at the same pose, and takes those answers (bitwise the same
points, so the same answers) instead of a second query.

Measured alternatives for the closest point (one run, 20,480-face sphere, 500 points
within 2 mm of it): igl.AABB 1.3 ms; ``igl.signed_distance`` rebuilds its tree every
call (45 ms); trimesh's rtree-based proximity is slower still (see
``validation/bench_detection.py``).
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from fecheck.contact.bvh import BOX
from fecheck.contact.coherent import WalkState, edge_frames, face_rings, local_closest
from fecheck.contact.kernels import (
    NO_RIM,
    fade_at_rim,
    mesh_surface,
    signed_closest,
    walked_mesh_surface,
)
from fecheck.contact.winding import GRID_PAD_MM, SideGrid, WindingTree
from fecheck.errors import FecheckError
from geometry.cache import cached_arrays
from geometry.mesh import TriMesh, is_closed

MAX_STEPS = 4            # 1-ring moves of a warm-started closest-face walk
GRID_MM = 1.0            # spacing of the winding number's side grid (`SideGrid`)
RIM_SAMPLES = 8          # points per boundary edge in the distance to the rim


class MeshMaster:
    """A triangle-mesh master with a prebuilt AABB tree (master body frame, mm).

    Parameters
    ----------
    mesh : the master surface, faces counter-clockwise from outside (normals outward);
        a closed mesh with a negative signed volume (inside out) is refused
    sign : "normal" (side of the closest face normal) or "winding" (generalised
        winding number > 1/2; closed meshes)
    """

    uses_slave_normal = False
    normal_body = "slave"

    def __init__(self, mesh: TriMesh, sign: str = "normal") -> None:
        import igl

        if mesh.n_faces == 0:
            raise FecheckError("the master mesh has no faces; check the mesh file or builder")
        if sign not in ("normal", "winding"):
            raise FecheckError(f"unknown sign method {sign!r}; choose 'normal' or 'winding'")
        closed = is_closed(mesh)
        if closed and mesh.signed_volume < 0.0:
            # Refused, not flipped: an inside-out mesh means its normals (and so every
            # depth sign) point inwards; guessing the intent would hide a mesh error.
            raise FecheckError(f"the master mesh is inside out (closed, signed volume "
                               f"{mesh.signed_volume:.4g} mm³ < 0): flip its face winding "
                               "(faces[:, ::-1]) so the normals point outwards")
        if sign == "winding" and not closed:
            raise FecheckError("sign='winding' needs a closed master mesh; "
                               "use sign='normal' for open sheets")
        self.mesh, self.sign = mesh, sign
        self._V = np.ascontiguousarray(mesh.points)
        self._F = np.ascontiguousarray(mesh.faces)
        self._normals = mesh.face_normals
        self._tree = igl.AABB()
        self._tree.init(self._V, self._F)
        self._ring = cached_arrays("face-rings", [self._F],
                                   lambda: face_rings(self._F, mesh.n_points))
        self._ring_width = int(np.diff(self._ring[0]).max())
        self._edges = edge_frames(self._V, self._F)
        self._winding = self._grid = None
        self._last_tree: tuple | None = None
        if sign == "winding":
            self._winding = WindingTree(mesh)
            self._grid = cached_arrays(
                "side-grid", [self._V, self._F, np.array([GRID_MM, GRID_PAD_MM])],
                lambda: SideGrid.tables(self._V, GRID_MM, self.distance_mm, self._winding),
                version=2)
        self._load_kernels()

    def _load_kernels(self) -> None:
        """Compile the walk kernels, or load them from numba's cache, now rather than in
        the first evaluations that use them (a first compile takes seconds)."""
        eye, zero, no_points = np.eye(3), np.zeros(3), np.zeros((0, 3))
        no_faces, none = np.zeros((0, 3), dtype=np.int64), np.zeros(0, dtype=np.int64)
        local_closest(self._edges, *self._ring, no_points, none, MAX_STEPS)
        signed_closest(no_points, no_points, np.zeros(0), no_points, np.zeros(0, dtype=bool),
                       True)
        mesh_surface(True, True, no_faces, no_points, np.zeros(0), no_points, no_points,
                     np.zeros(0), eye, zero, eye)
        fade_at_rim(no_points, none, np.zeros(0), no_points, self._edges, NO_RIM, 0.0)
        state = self.empty_state()
        walked_mesh_surface(True, True, no_points, no_faces, no_points, np.zeros(0), eye, zero,
                            eye, zero, eye, self._edges, *self._ring, self._normals, NO_RIM,
                            0.0, state.face, state.position, state.upper, state.travel,
                            state.ring, MAX_STEPS)

    def empty_state(self) -> WalkState:
        """The walk state of no points (for loading the kernels)."""
        return WalkState.start(np.zeros(0, dtype=np.int64), np.zeros((0, 3)), np.zeros(0),
                               self._ring_width)

    @property
    def walk_tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The closest-face walk's master tables (edge frames, face-ring pointers and
        indices, unit face normals), as `walked_mesh_surface` takes them."""
        return (self._edges, *self._ring, self._normals)

    @cached_property
    def rim_distance(self) -> np.ndarray:
        """(n_faces, 3) distance (mm) of each face's corners to the mesh's rim (its
        boundary edges, each sampled at `RIM_SAMPLES` points: within 1/16 of an edge's
        length); all inf for a closed mesh."""
        from scipy.spatial import cKDTree

        e = np.sort(self._F[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
        edges, counts = np.unique(e, axis=0, return_counts=True)
        rim = edges[counts == 1]
        if rim.size == 0:
            return np.full(self._F.shape, np.inf)
        s = (np.arange(RIM_SAMPLES) / RIM_SAMPLES)[None, :, None]
        a, b = self._V[rim[:, 0]][:, None], self._V[rim[:, 1]][:, None]
        dist, _ = cKDTree((a + s * (b - a)).reshape(-1, 3)).query(self._V)
        return np.ascontiguousarray(dist[self._F])

    def describe(self) -> str:
        sign = ("side of the closest face normal" if self.sign == "normal"
                else "generalised winding number")
        return (f"mesh master ({self.mesh.n_faces} faces): libigl AABB closest point, "
                f"inside by {sign}")

    def region(self, margin_mm: float) -> tuple[int, np.ndarray]:
        """A region holding every point with reach > -margin: the master's bounding box
        grown by the margin (`fecheck.contact.bvh`)."""
        lo, hi = self.mesh.points.min(axis=0), self.mesh.points.max(axis=0)
        return BOX, np.concatenate([lo - margin_mm, hi + margin_mm])

    def distance_mm(self, points: np.ndarray) -> np.ndarray:
        """(n,) unsigned distance from each point (master frame, mm) to the surface."""
        sq, _, _ = self._tree.squared_distance(self._V, self._F,
                                               np.ascontiguousarray(points.reshape(-1, 3)))
        return np.sqrt(sq)

    def _query(self, y: np.ndarray, start: np.ndarray | None = None, unsigned_mm: float = 0.0):
        """(depth, gradient, closest face) of points `y`. With the winding sign, a point's
        side is its winding number where the side grid (`SideGrid`) does not prove it, and
        points closer than `unsigned_mm` to the surface are taken inside (neither)."""
        pts = np.ascontiguousarray(y.reshape(-1, 3))
        if start is None:
            sq, face, closest = self.tree_closest(pts)
        else:
            sq, face, closest, settled = local_closest(self._edges, *self._ring, pts, start,
                                                       MAX_STEPS)
            lost = np.flatnonzero(~settled)
            if lost.size:
                sq[lost], face[lost], closest[lost] = self._tree.squared_distance(
                    self._V, self._F, pts[lost])
        by_normal = self.sign == "normal"
        outside = np.zeros(0 if by_normal else len(pts), dtype=bool)
        if not by_normal:
            ask = sq >= unsigned_mm * unsigned_mm
            kept, inside = SideGrid.sides(*self._grid, pts)
            outside[kept] = ~inside[kept]
            ask &= ~kept
            far = np.flatnonzero(ask)
            outside[far] = self._winding(pts[far]) < 0.5
        depth, grad = signed_closest(pts, closest, sq, self._normals[face], outside,
                                     by_normal)
        return depth, grad, face

    def tree_closest(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The tree's (squared distance mm², closest face, closest point mm) of points
        (n, 3) (master frame): the points bitwise equal to one of the last call's take its
        answers, the others are asked; the arrays returned are the caller's to change."""
        pts = np.ascontiguousarray(pts, dtype=float)
        last = self._last_tree
        ask = np.arange(len(pts))
        sq, face = np.empty(len(pts)), np.empty(len(pts), dtype=np.int64)
        closest = np.empty((len(pts), 3))
        if last is not None and len(last[0]) and len(pts):
            row = np.dtype((np.void, 24))
            known = last[0].view(row).ravel()
            order = np.argsort(known, kind="stable")
            ranked = known[order]
            keys = pts.view(row).ravel()
            at = np.minimum(np.searchsorted(ranked, keys), len(known) - 1)
            hit = ranked[at] == keys
            old = order[at[hit]]
            sq[hit], face[hit], closest[hit] = last[1][old], last[2][old], last[3][old]
            ask = np.flatnonzero(~hit)
        if ask.size:
            sq[ask], face[ask], closest[ask] = self._tree.squared_distance(self._V, self._F,
                                                                           pts[ask])
        # copies: a walk updates the closest faces it is given in place (`WalkState`)
        self._last_tree = (pts.copy(), sq.copy(), face.copy(), closest.copy())
        return sq, face, closest

    def reach(self, y: np.ndarray) -> np.ndarray:
        """Signed distance, positive inside, mm (1-Lipschitz)."""
        return self.depth_values(y)

    def margin_reach(self, margin_mm: float):
        """A `reach` for a broad phase that asks only reach > -margin_mm: a value on the
        same side of -margin_mm as the signed distance. Where the side grid's bounds of
        the signed distance (`SideGrid.bounds`) lie on one side, one of them (no query);
        else the distance, signed only beyond margin_mm (a sign cannot change the answer
        within, and a winding number costs ~10 µs a point)."""
        def reach(y: np.ndarray) -> np.ndarray:
            pts = np.ascontiguousarray(y.reshape(-1, 3))
            out = np.empty(len(pts))
            if self._grid is None:
                return self._query(pts)[0].reshape(y.shape[:-1])
            lower, upper = SideGrid.bounds(*self._grid, pts)
            near = lower > -margin_mm
            far = upper <= -margin_mm
            out[near], out[far] = lower[near], upper[far]
            ask = np.flatnonzero(~(near | far))
            out[ask] = self._query(pts[ask], unsigned_mm=margin_mm)[0]
            return out.reshape(y.shape[:-1])

        return reach

    def depth_values(self, y: np.ndarray, u: np.ndarray | None = None) -> np.ndarray:
        """(…,) signed closest-point depth, mm."""
        return self._query(y)[0].reshape(y.shape[:-1])

    def depth_and_gradients(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Depth (n,) and its gradient (n, 3) at points (n, 3) from one tree query: minus
        the outward unit direction from the closest point (minus the face normal for a
        point on the surface)."""
        return self._query(y)[:2]

    def depth_gradients_faces(self, y: np.ndarray, start: np.ndarray | None = None
                              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """`depth_and_gradients` and the closest face (n,) of each point; with `start`
        (n,) faces (the last call's, -1 for none) the closest faces are found by a local
        walk from them (`fecheck.contact.coherent`), the tree answering only points
        whose walk does not settle."""
        return self._query(y, start)

    def surface(self, clipped: bool, cand, R: np.ndarray, t: np.ndarray, Rm: np.ndarray,
                tm: np.ndarray, Rs: np.ndarray, state: WalkState | None = None,
                rim: tuple[np.ndarray, float] = (NO_RIM, 0.0)) -> tuple:
        """Contact of candidate slave faces `cand` (`fecheck.contact.broadphase.Candidates`)
        at the relative pose y = R p + t (master pose Rm, tm; slave rotation Rs).

        Returns (the points' `WalkState` for the next call, the returns of
        `fecheck.contact.kernels.mesh_surface`). With the last call's `state` and the
        side-of-normal sign, one compiled call walks and integrates
        (`walked_mesh_surface`); the tree answers otherwise, or if a walk does not settle.
        `rim`: (`rim_distance`, fade width mm) to fade the depths to zero at the rim (a
        width of 0: no fade, `NO_RIM`).
        """
        if state is not None and self.sign == "normal":
            settled, *out = walked_mesh_surface(
                clipped, True, cand.points, cand.local_faces, cand.normals, cand.areas, R, t, Rm,
                tm, Rs, self._edges, *self._ring, self._normals, *rim, state.face,
                state.position, state.upper, state.travel, state.ring, MAX_STEPS)
            if settled:
                return state, out
        y = cand.points @ R.T + t
        # the winding sign takes the tree's closest face: a walk from the last one can stop
        # at a local closest face inside a thin closed master (a meniscus's rim), which
        # makes the depth depend on the calls before
        warm = state is not None and self.sign == "normal"
        depth, grad, face = self._query(y, state.face if warm else None)
        start = WalkState.start(face, y, depth, self._ring_width)
        if rim[1] > 0.0:
            fade_at_rim(y, face, depth, grad, self._edges, *rim)
        return start, mesh_surface(clipped, True, cand.local_faces, y, depth, grad,
                                   cand.normals, cand.areas, Rm, tm, Rs)

    def depth_gradients(self, y: np.ndarray, u: np.ndarray | None = None):
        """(∂d/∂y, None) at points of any leading shape, see `depth_and_gradients`."""
        return self.depth_and_gradients(y.reshape(-1, 3))[1].reshape(y.shape), None
