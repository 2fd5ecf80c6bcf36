"""The broad phase's point tree (`fecheck.contact.bvh`): region queries against brute
force, and a rebuilt candidate set that touches only the vertices near the master."""

import numpy as np
import pytest

from fecheck.contact import ContactPair, Plane, Sphere
from fecheck.contact.bvh import BALL, BOX, HALF_SPACE, PointTree
from fecheck.statics.frames import rotation
from geometry.icosphere import icosphere

_NO_FACES = (np.zeros((0, 3), dtype=np.int64), np.zeros((0, 3)), np.zeros(0))


def _brute(kind, params, y):
    if kind == HALF_SPACE:
        return y @ params[:3] < params[3]
    if kind == BALL:
        return np.linalg.norm(y - params[:3], axis=1) < params[3]
    return np.all((y >= params[:3]) & (y <= params[3:]), axis=1)


@pytest.mark.parametrize("kind, params", [
    (HALF_SPACE, np.array([0.3, -0.2, 0.93, 1.5])),
    (BALL, np.array([4.0, 1.0, -3.0, 6.5])),
    (BOX, np.array([-2.0, -9.0, 0.0, 7.0, 3.0, 12.0])),
])
def test_region_queries_find_exactly_the_points_brute_force_finds(kind, params):
    rng = np.random.default_rng(7)
    points = rng.normal(size=(5000, 3)) * [10.0, 6.0, 3.0]
    tree = PointTree(points, *_NO_FACES)
    for _ in range(5):
        R = rotation(*rng.normal(size=3))
        t = rng.normal(size=3) * 4.0
        found = np.sort(tree.near(kind, params, R, t))
        expected = np.flatnonzero(_brute(kind, params, points @ R.T + t))
        np.testing.assert_array_equal(found, expected)


def test_empty_and_single_point_trees():
    one = PointTree(np.zeros((1, 3)), *_NO_FACES)
    assert one.near(BALL, np.array([0.0, 0.0, 0.0, 1.0]), np.eye(3), np.zeros(3)).tolist() == [0]
    none = PointTree(np.zeros((0, 3)), *_NO_FACES)
    assert none.near(HALF_SPACE, np.array([0.0, 0.0, 1.0, 0.0]), np.eye(3),
                     np.zeros(3)).size == 0


@pytest.mark.parametrize("master", [Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
                                    Sphere([0.0, 0.0, -30.0], 29.0)])
def test_rebuilt_candidates_equal_the_all_vertex_reach_test(master):
    """The tree's candidates are those of testing every vertex's reach (the old rebuild)."""
    mesh = icosphere(25.5, 4)
    pair = ContactPair(mesh, master)
    R, t = rotation(0.1, -0.05, 0.2), np.array([0.3, -0.2, 24.5])
    cand = pair.cache.get(R, t)
    near = master.reach(mesh.points @ R.T + t) > -pair.margin_mm
    ref_faces = np.flatnonzero(near[mesh.faces].any(axis=1))
    np.testing.assert_array_equal(cand.faces, ref_faces)
    np.testing.assert_array_equal(np.sort(cand.vertices), np.unique(mesh.faces[ref_faces]))
    assert 0 < cand.faces.size < mesh.n_faces / 4
