"""Warm-started closest faces (issue 3): Ericson's point-triangle routine and the 1-ring
walk against libigl's AABB tree, and reused mesh-master evaluations against fresh ones."""

import numpy as np
import pytest
from contact_helpers import IDENTITY, moved

from fecheck.contact import ContactPair
from fecheck.contact.coherent import closest_on_triangle, edge_frames, face_rings, local_closest
from fecheck.contact.mesh_master import MeshMaster
from geometry.icosphere import icosphere
from geometry.mesh import TriMesh


def _igl_closest(V, F, pts):
    import igl

    tree = igl.AABB()
    tree.init(V, F)
    return tree.squared_distance(V, F, pts)


def test_closest_point_on_a_triangle_matches_libigl_in_every_voronoi_region():
    # Points spread around random triangles land in all seven regions (3 vertices,
    # 3 edges, interior); libigl's own point-triangle routine is the reference, equal to
    # rounding (1e-12 mm on coordinates of order 1 mm).
    rng = np.random.default_rng(7)
    for _ in range(20):
        V = rng.normal(size=(3, 3))
        F = np.array([[0, 1, 2]])
        pts = V.mean(axis=0) + 2.0 * rng.normal(size=(200, 3))
        sq_ref, _, q_ref = _igl_closest(V, F, pts)
        for p, s, q in zip(pts, sq_ref, q_ref, strict=True):
            qx, qy, qz, sq = closest_on_triangle(p[0], p[1], p[2], edge_frames(V, F), 0)
            np.testing.assert_allclose([qx, qy, qz], q, atol=1e-12)
            assert sq == pytest.approx(s, rel=1e-12, abs=1e-24)


def test_face_rings_are_the_faces_sharing_a_vertex():
    mesh = icosphere(10.0, 2)
    ptr, index = face_rings(mesh.faces, mesh.n_points)
    for f in range(mesh.n_faces):
        shares = np.isin(mesh.faces, mesh.faces[f]).any(axis=1)
        shares[f] = False
        np.testing.assert_array_equal(index[ptr[f]:ptr[f + 1]], np.flatnonzero(shares))


def _bumpy_sheet(n: int = 60, size_mm: float = 40.0) -> TriMesh:
    """An open, wavy, irregularly triangulated sheet (mm): z = 1.5 sin(x/4) cos(y/5)."""
    rng = np.random.default_rng(2)
    u = np.linspace(-size_mm / 2, size_mm / 2, n)
    x, y = np.meshgrid(u, u, indexing="ij")
    h = u[1] - u[0]
    x = x + 0.3 * h * rng.uniform(-1, 1, x.shape)
    y = y + 0.3 * h * rng.uniform(-1, 1, y.shape)
    z = 1.5 * np.sin(x / 4.0) * np.cos(y / 5.0)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    faces = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3),
                            np.stack([a, c, d], -1).reshape(-1, 3)])
    return TriMesh(np.stack([x, y, z], -1).reshape(-1, 3), faces)


@pytest.mark.parametrize("master", [icosphere(25.5, 4), _bumpy_sheet()],
                         ids=["closed-sphere", "open-wavy-sheet"])
def test_walk_from_the_last_faces_finds_the_bvh_closest_faces(master):
    # Points within 2 mm of the surface drift in 0.05 mm steps (a Newton walk); from
    # each step's faces the 1-ring walk must settle on libigl's closest faces (same
    # squared distance to rounding, same face unless two faces are exactly equidistant).
    rng = np.random.default_rng(5)
    V, F = np.ascontiguousarray(master.points), np.ascontiguousarray(master.faces)
    ptr, index = face_rings(F, master.n_points)
    E = edge_frames(V, F)
    seeds = master.face_centroids[rng.choice(master.n_faces, 400, replace=False)]
    normals = master.face_normals[rng.choice(master.n_faces, 400, replace=False)]
    pts = seeds + rng.uniform(-2.0, 2.0, (400, 1)) * normals
    _, face, _ = _igl_closest(V, F, pts)
    n_moved = 0
    for _ in range(10):
        pts = pts + 0.05 * rng.normal(size=pts.shape)
        sq_ref, face_ref, q_ref = _igl_closest(V, F, pts)
        sq, walked, q, settled = local_closest(E, ptr, index, pts,
                                               face.astype(np.int64), 4)
        assert settled.all()
        np.testing.assert_allclose(sq, sq_ref, rtol=1e-12, atol=1e-24)
        np.testing.assert_allclose(q, q_ref, atol=1e-10)
        same = walked == face_ref
        if not same.all():                      # only exact ties may pick another face
            other = ~same
            pairs = zip(pts[other], face_ref[other], strict=True)
            _, _, _, sq_other = np.array([closest_on_triangle(*p, E, f) for p, f in pairs]).T
            np.testing.assert_allclose(sq_other, sq[other], rtol=1e-12)
        n_moved += int((walked != face).sum())
        face = walked
    assert n_moved > 50                         # the walk really moved between faces


def test_a_point_without_a_start_face_goes_to_the_tree():
    master = icosphere(25.5, 3)
    mm = MeshMaster(master)
    pts = np.array([[0.0, 0.0, 26.0], [1.0, 2.0, -24.0]])
    start = np.array([-1, 0])
    settled = local_closest(mm._edges, *mm._ring, pts, start, 4)[3]
    assert not settled[0]
    depth, grad, face = mm.depth_gradients_faces(pts, start)
    depth_ref, grad_ref, face_ref = mm.depth_gradients_faces(pts)
    np.testing.assert_allclose(depth, depth_ref, rtol=1e-12)
    np.testing.assert_allclose(grad, grad_ref, atol=1e-12)
    assert face[0] == face_ref[0]


def test_reused_mesh_master_evaluations_equal_fresh_ones():
    # Along a pose walk inside the reuse window, the warm-started pair gives the same
    # contact (faces, area, depths and twists to rounding) as a pair rebuilt each time.
    slave = icosphere(31.8, 4)
    master = icosphere(25.5, 4, center=(0.0, 0.0, -56.3))
    warm, fresh = ContactPair(slave, master), ContactPair(slave, master)
    rng = np.random.default_rng(1)
    pose = IDENTITY
    for _ in range(8):
        pose = moved(pose, np.concatenate([0.03 * rng.normal(size=3),
                                           3e-4 * rng.normal(size=3)]))
        a = warm.evaluate(pose, IDENTITY)
        fresh.cache.reset()
        b = fresh.evaluate(pose, IDENTITY)
        assert a.n_faces > 20
        np.testing.assert_array_equal(a.face, b.face)
        assert a.area == pytest.approx(b.area, rel=1e-12)
        np.testing.assert_allclose(a.qp_depth, b.qp_depth, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(a.qp_depth_twist, b.qp_depth_twist, atol=1e-12)
        np.testing.assert_allclose(a.qp_weight_twist, b.qp_weight_twist, atol=1e-12)
    assert warm.cache.n_reuses >= 6


@pytest.mark.parametrize(("master", "top"), [(icosphere(25.5, 4, center=(0.0, 0.0, -56.3)), -30.8),
                                             (_bumpy_sheet(n=50, size_mm=60.0), 0.0)],
                         ids=["closed-sphere", "open-wavy-sheet"])
def test_points_skipped_by_their_depth_bound_never_miss_a_contact(master, top):
    # The slave sinks in and comes back out across the whole reuse window (steps of
    # 0.13 mm, contact growing from a few faces to tens and shrinking again, sliding
    # sideways): the warm pair, which skips the points whose depth bound is negative and
    # the ring faces whose distance bounds prove them farther than the last face, gives
    # the contact of a pair rebuilt every call.
    slave = icosphere(31.8, 4, center=(0.0, 0.0, top + 31.8))
    warm, fresh = ContactPair(slave, master), ContactPair(slave, master)
    heights = np.r_[np.linspace(0.4, -0.5, 8), np.linspace(-0.5, 0.4, 8)]
    n_contact = []
    for k, h in enumerate(heights):
        pose = (np.eye(3), np.array([0.02 * k, -0.01 * k, h]))
        a = warm.evaluate(pose, IDENTITY)
        fresh.cache.reset()
        b = fresh.evaluate(pose, IDENTITY)
        np.testing.assert_array_equal(a.face, b.face)
        np.testing.assert_allclose(a.vertex_depth, b.vertex_depth, rtol=1e-12, atol=1e-13)
        np.testing.assert_allclose(a.qp_depth_twist, b.qp_depth_twist, atol=1e-12)
        n_contact.append(a.n_faces)
    assert warm.cache.n_rebuilds == 1
    assert max(n_contact) > 20 and min(n_contact) < max(n_contact) / 2
