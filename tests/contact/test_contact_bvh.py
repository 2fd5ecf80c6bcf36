"""The broad phase's point tree (`fecheck.contact.bvh`): region queries against brute
force, and a rebuilt candidate set that touches only the vertices near the master."""

import numpy as np
import pytest

from fecheck.contact import ContactPair, Plane, Sphere
from fecheck.contact.broadphase import REUSE_FRACTION, CandidateCache
from fecheck.contact.bvh import BALL, BOX, HALF_SPACE, PointTree
from fecheck.statics.frames import rotation
from geometry.icosphere import icosphere
from geometry.plateau import plane_patch

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
@pytest.mark.parametrize("level", [3, 5])
def test_rebuilt_candidates_hold_every_face_within_the_margin(master, level):
    """The tree's candidates hold those of testing every vertex's reach against the
    margin (the old rebuild), each face once, and no face whose corners are all farther
    than the margin plus the longest edge."""
    mesh = icosphere(25.5, level)
    pair = ContactPair(mesh, master)
    R, t = rotation(0.1, -0.05, 0.2), np.array([0.3, -0.2, 24.5])
    cand = pair.cache.get(R, t)
    reach = master.reach(mesh.points @ R.T + t)
    within = np.flatnonzero((reach > -pair.margin_mm)[mesh.faces].any(axis=1))
    corners = mesh.points[mesh.faces]
    edge = np.linalg.norm(corners - corners[:, [1, 2, 0]], axis=2).max()
    beyond = np.flatnonzero((reach <= -pair.margin_mm - edge)[mesh.faces].all(axis=1))
    assert len(set(cand.faces.tolist())) == cand.faces.size
    assert set(within.tolist()) <= set(cand.faces.tolist())
    assert not set(beyond.tolist()) & set(cand.faces.tolist())
    np.testing.assert_array_equal(np.sort(cand.vertices), np.unique(mesh.faces[cand.faces]))
    assert 0 < cand.faces.size < mesh.n_faces / 4


@pytest.mark.parametrize("kind, params", [
    (HALF_SPACE, np.array([0.0, 0.0, 1.0, -21.0])),
    (HALF_SPACE, np.array([0.6, 0.0, 0.8, 3.0])),
    (BALL, np.array([0.0, 0.0, -30.0, 12.0])),
    (BALL, np.array([5.0, 0.0, 0.0, 40.0])),
    (BALL, np.array([0.0, 0.0, 0.0, 0.5])),
])
@pytest.mark.parametrize("mesh", [icosphere(25.5, 3), icosphere(25.5, 5),
                                  plane_patch([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], radius=30.0,
                                              size=2.5)], ids=["ico3", "ico5", "plate"])
def test_faces_in_a_region_are_those_whose_owner_is_within_its_extent(kind, params, mesh):
    """`PointTree.faces_in` (whole subtrees as ranges of owned faces) against brute force
    (a face's owner: its corner first in the tree's order; the owner's extent: its
    farthest corner over the faces it owns), at random poses: every face with a corner in
    the region, each once; the gathered data consistent."""
    tree = PointTree(mesh.points, mesh.faces, mesh.face_normals, mesh.face_areas)
    owner = mesh.faces[np.arange(mesh.n_faces), np.argmin(tree.pos[mesh.faces], axis=1)]
    far = np.linalg.norm(mesh.points[mesh.faces] - mesh.points[owner][:, None], axis=2)
    extent = np.zeros(mesh.n_points)
    np.maximum.at(extent, owner, far.max(axis=1))
    grown = params.copy()
    rng = np.random.default_rng(11)
    for _ in range(6):
        R = rotation(*rng.normal(size=3) * 0.5)
        t = rng.normal(size=3) * 3.0
        faces, vertices, local, points, normals, areas = tree.faces_in(kind, params, R, t)
        y = mesh.points @ R.T + t
        inside = np.array([_brute(kind, np.append(grown[:3], grown[3] + e), y[[v]])[0]
                           for v, e in enumerate(extent)])
        np.testing.assert_array_equal(faces, tree.ranked[0][np.isin(tree.ranked[0],
                                                                     np.flatnonzero(inside[owner]))])
        touching = np.flatnonzero(_brute(kind, params, y)[mesh.faces].any(axis=1))
        assert set(touching.tolist()) <= set(faces.tolist())
        np.testing.assert_array_equal(vertices[local], mesh.faces[faces])
        assert len(set(vertices.tolist())) == len(vertices)
        np.testing.assert_array_equal(points, mesh.points[vertices])
        np.testing.assert_array_equal(normals, mesh.face_normals[faces])
        np.testing.assert_array_equal(areas, mesh.face_areas[faces])
    assert (tree.vertex_index == -1).all()                              # left clean


def test_bounded_rebuilds_over_a_sweep_find_the_sets_of_asking_every_vertex():
    """A mesh master's rebuild asks the closest-point reach only where a vertex's last
    reach plus its move since can exceed -margin: over a rolling sweep (60 steps of 1°
    about the sphere's centre, a rebuild every two or three steps) every set is the brute-force
    one at its pose (the faces with a corner in the master's box whose signed distance >
    -margin),
    and the rebuilds ask at most 60 % of the vertices that asking every box vertex does
    (the plate's vertices beyond ~11 mm of the contact stay farther than the margin)."""
    centre = np.array([0.3, -0.2, 25.5 - 0.8])
    master = icosphere(25.5, 3, center=centre)
    pair = ContactPair(plane_patch([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], radius=26.0, size=1.0),
                       master, margin_mm=2.0)
    slave, cache = pair.slave, pair.cache
    every = CandidateCache(slave, cache.reach, 2.0, region=cache.region)
    lo, hi = master.points.min(axis=0) - 2.0, master.points.max(axis=0) + 2.0
    for step in range(60):
        R = rotation(np.radians(step), 0.0, 0.0)
        t = centre - R @ centre
        before = cache.n_rebuilds
        faces = cache.get(R, t).faces
        every.get(R, t)
        if cache.n_rebuilds == before:
            continue
        y = slave.points @ R.T + t
        near = np.all((y >= lo) & (y <= hi), axis=1) & (pair.master.depth_values(y) > -2.0)
        np.testing.assert_array_equal(faces, np.flatnonzero(near[slave.faces].any(axis=1)))
    assert cache.n_rebuilds == every.n_rebuilds >= 20
    assert cache.n_reach_points < 0.6 * every.n_reach_points     # measured 0.53


def test_a_pose_back_near_a_recent_set_takes_it_again_with_a_fresh_pairs_contact():
    """A pose within the reuse limit (1.8 mm of a 2 mm margin) of a set built earlier in the
    run, but not of the current one (a line search's shorter step after a longer trial),
    takes that set again without a rebuild; its contact equals a fresh pair's there (the
    set is a superset of the faces that can touch). A pose near no recent set's own pose
    rebuilds, and after `reset` the recent sets are gone."""
    master = icosphere(25.5, 3, center=[0.0, 0.0, 25.5 - 0.8])
    slave = plane_patch([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], radius=26.0, size=1.0)
    pair = ContactPair(slave, master, margin_mm=2.0)
    at = {x: (np.eye(3), np.array([x, 0.0, 0.0])) for x in (0.0, 4.0, 0.6, 2.0)}
    identity = (np.eye(3), np.zeros(3))
    pair.evaluate(at[0.0], identity)
    first = pair.cache.current.faces
    pair.evaluate(at[4.0], identity)
    back = pair.evaluate(at[0.6], identity)
    assert pair.cache.n_rebuilds == 2
    np.testing.assert_array_equal(pair.cache.current.faces, first)
    fresh = ContactPair(slave, master, margin_mm=2.0).evaluate(at[0.6], identity)
    assert volume_of(back) == pytest.approx(volume_of(fresh), rel=1e-12) and volume_of(back) > 0
    pair.evaluate(at[2.0], identity)                   # 2 mm from both sets' poses
    assert pair.cache.n_rebuilds == 3
    pair.cache.reset()
    pair.evaluate(at[0.6], identity)
    assert pair.cache.n_rebuilds == 4


def volume_of(surface) -> float:
    """Σ weight × depth of a contact surface's quadrature points, mm³."""
    return float((surface.qp_weight * surface.qp_depth).sum())


def test_a_mesh_masters_set_serves_a_move_of_nine_tenths_of_the_margin_with_a_fresh_contact():
    """A mesh master's set (the faces with a vertex within the 2 mm margin) is reused until
    the slave has moved 1.8 mm (`REUSE_FRACTION`): a face left out had every vertex at
    reach <= -2 mm, and a face's contact is made from its vertex depths, so none of them
    can touch yet. The sphere comes down from 1 mm above the plate to 0.75 mm into it in
    one set, whose contact equals a fresh pair's at every step; a reuse over 2.3 mm would
    miss the faces the contact reaches then (8 mm out: 2.3 mm below the sphere at the
    first pose)."""
    master = icosphere(25.5, 3, center=[0.0, 0.0, 25.5 + 1.0])
    slave = plane_patch([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], radius=26.0, size=1.0)
    pair = ContactPair(slave, master, margin_mm=2.0)
    identity = (np.eye(3), np.zeros(3))
    for up in np.arange(0.0, 1.76, 0.25):
        pose = (np.eye(3), np.array([0.0, 0.0, up]))
        surface = pair.evaluate(pose, identity)
        fresh = ContactPair(slave, master, margin_mm=2.0).evaluate(pose, identity)
        assert volume_of(surface) == pytest.approx(volume_of(fresh), rel=1e-12, abs=1e-15)
    assert pair.cache.n_rebuilds == 1 and volume_of(surface) > 0
    pair.evaluate((np.eye(3), np.array([0.0, 0.0, 2.0])), identity)    # past 1.8 mm
    assert pair.cache.n_rebuilds == 2 and REUSE_FRACTION * 2.0 < 2.0 - 0.1
    pair.evaluate((np.eye(3), np.zeros(3)), identity)                   # the first set again
    deeper = (np.eye(3), np.array([0.0, 0.0, 2.3]))
    fresh = ContactPair(slave, master, margin_mm=2.0).evaluate(deeper, identity)
    kept = np.isin(fresh.face, pair.cache.current.faces)
    assert not kept.all()
