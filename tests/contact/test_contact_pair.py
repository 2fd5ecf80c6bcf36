"""ContactPair: input validation, invariance, symmetry and candidate reuse."""

import numpy as np
import pytest
from contact_helpers import IDENTITY, volume
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from fecheck.contact import ContactPair, Plane, PolynomialSurface, Sphere
from fecheck.errors import FecheckError
from geometry.icosphere import icosphere
from geometry.mesh import TriMesh
from geometry.plateau import plane_patch
from geometry.polynomial import Polynomial2D

CONDYLE = icosphere(25.5, 3)
PLATEAU = plane_patch([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], radius=12.0, size=1.0)


def _pairs():
    poly = PolynomialSurface(Polynomial2D(np.array([[0.0, 0.05], [0.1, 0.0], [0.004, 0.0]])))
    return {
        "plane": (ContactPair(CONDYLE, Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0])),
                  (np.eye(3), np.array([0.2, 0.1, 25.5 - 0.8]))),
        "polynomial": (ContactPair(CONDYLE, poly), (np.eye(3), np.array([0.2, 0.1, 25.5 - 0.8]))),
        "sphere": (ContactPair(PLATEAU, Sphere([0.3, -0.2, 25.5 - 0.8], 25.5)), IDENTITY),
        "mesh": (ContactPair(PLATEAU, icosphere(25.5, 3, center=(0.3, -0.2, 25.5 - 0.8))),
                 IDENTITY),
    }


PAIRS = _pairs()


@pytest.mark.parametrize(("bad", "says"), [
    ((np.full((3, 3), np.nan), np.zeros(3)), "rotation is not orthonormal"),
    ((np.eye(3), np.array([0.0, np.inf, 0.0])), "translation contains NaN"),
    ((2.0 * np.eye(3), np.zeros(3)), "rotation is not orthonormal"),
    ((np.diag([1.0, 1.0, -1.0]), np.zeros(3)), "det \\+1"),
    ((np.eye(3) + 2e-6, np.zeros(3)), "rotation is not orthonormal"),
    ((np.eye(3), np.zeros(2)), "got shapes"),
    ("not a pose", "must be a pair"),
])
def test_invalid_pose_raises_fecheck_error_naming_the_pose(bad, says):
    pair, _ = PAIRS["plane"]
    with pytest.raises(FecheckError, match=f"^slave.*{says}"):
        pair.evaluate(bad, IDENTITY)
    with pytest.raises(FecheckError, match=f"^master.*{says}"):
        pair.evaluate(IDENTITY, bad)


def test_a_rotation_within_the_tolerance_is_accepted():
    pair, pose = PAIRS["plane"]
    R = np.eye(3) + 4e-7 * np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    ref = pair.evaluate(pose, IDENTITY)
    assert pair.evaluate(pose, (R, np.zeros(3))).area == pytest.approx(ref.area, rel=1e-5)


def test_invalid_construction_raises_fecheck_error():
    plane = Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    with pytest.raises(FecheckError, match="no faces"):
        ContactPair(TriMesh(np.zeros((0, 3)), np.zeros((0, 3), int)), plane)
    with pytest.raises(FecheckError, match="unknown contact method"):
        ContactPair(CONDYLE, plane, method="magic")
    with pytest.raises(FecheckError, match="needs a mesh master"):
        ContactPair(CONDYLE, plane, method="bvh")
    with pytest.raises(FecheckError, match="analytic master"):
        ContactPair(PLATEAU, CONDYLE, method="closed-form")
    with pytest.raises(FecheckError):
        ContactPair(CONDYLE, plane, area="some")
    with pytest.raises(FecheckError):
        ContactPair(CONDYLE, plane, margin_mm=float("nan"))
    with pytest.raises(FecheckError):
        Sphere([0.0, 0.0, 0.0], -1.0)
    with pytest.raises(FecheckError):
        Plane([0.0, 0.0, np.nan], [0.0, 0.0, 1.0])


def test_no_contact_gives_an_empty_surface():
    pair, _ = PAIRS["plane"]
    s = pair.evaluate((np.eye(3), np.array([0.0, 0.0, 40.0])), IDENTITY)
    assert s.n_faces == 0 and s.area == 0.0 and s.max_depth == 0.0
    assert s.n_slave_faces == CONDYLE.n_faces


@settings(max_examples=15, deadline=None)
@given(kind=st.sampled_from(sorted(PAIRS)),
       rotvec=st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3),
       shift=st.lists(st.floats(-50.0, 50.0), min_size=3, max_size=3))
def test_common_rigid_motion_moves_the_surface_rigidly(kind, rotvec, shift):
    pair, slave_pose = PAIRS[kind]
    base = pair.evaluate(slave_pose, IDENTITY)
    Q, c = Rotation.from_rotvec(rotvec).as_matrix(), np.array(shift)
    moved = pair.evaluate((Q @ slave_pose[0], Q @ slave_pose[1] + c), (Q, c))
    np.testing.assert_array_equal(moved.face, base.face)
    np.testing.assert_allclose(moved.qp_depth, base.qp_depth, atol=1e-9)
    np.testing.assert_allclose(moved.qp_weight, base.qp_weight, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(moved.qp_point, base.qp_point @ Q.T + c, atol=1e-8)
    np.testing.assert_allclose(moved.normal, base.normal @ Q.T, atol=1e-9)
    # Linear-momentum rows of the depth gradient rotate with the bodies.
    np.testing.assert_allclose(moved.qp_depth_twist[:, :3], base.qp_depth_twist[:, :3] @ Q.T,
                               atol=1e-8)


def test_symmetric_sphere_on_plane_gives_symmetric_resultants():
    # An icosphere centred over the plane: Σ w·d·x and Σ w·d·y vanish (mesh symmetry
    # about x = 0 and y = 0 planes of the icosahedron), force is along the normal.
    pair, _ = PAIRS["plane"]
    s = pair.evaluate((np.eye(3), np.array([0.0, 0.0, 25.5 - 1.0])), IDENTITY)
    wd = s.qp_weight * s.qp_depth
    moment_arm = (wd[:, None] * s.qp_point[:, :2]).sum(axis=0) / wd.sum()
    np.testing.assert_allclose(moment_arm, 0.0, atol=1e-9)
    mirrored = pair.evaluate((np.diag([-1.0, -1.0, 1.0]), np.array([0.0, 0.0, 25.5 - 1.0])),
                             IDENTITY)
    assert volume(mirrored) == pytest.approx(volume(s), rel=1e-12)


def test_candidate_set_is_reused_for_small_motions_and_gives_identical_results():
    plane = Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    reused = ContactPair(CONDYLE, plane, margin_mm=2.0)
    poses = [(Rotation.from_rotvec([0.0, 0.002 * k, 0.0]).as_matrix(),
              np.array([0.05 * k, 0.0, 25.5 - 1.0 + 0.02 * k])) for k in range(8)]
    for pose in poses:
        a = reused.evaluate(pose, IDENTITY)
        b = ContactPair(CONDYLE, plane, margin_mm=2.0).evaluate(pose, IDENTITY)
        np.testing.assert_array_equal(a.face, b.face)
        np.testing.assert_allclose(a.qp_depth, b.qp_depth, atol=1e-12)
    assert reused.cache.n_rebuilds == 1 and reused.cache.n_reuses == len(poses) - 1
    # A jump larger than half the margin (an analytic master's limit) forces a rebuild,
    # and contact is still found.
    far = reused.evaluate((np.eye(3), np.array([5.0, 0.0, 25.5 - 1.0])), IDENTITY)
    assert reused.cache.n_rebuilds == 2 and far.max_depth == pytest.approx(1.0, abs=0.05)


def test_describe_names_the_method():
    assert "closed form (analytic plane), no BVH" in PAIRS["plane"][0].describe()
    assert "AABB" in PAIRS["mesh"][0].describe()


def test_duplicate_slave_faces_are_dropped_once_with_a_warning():
    # The same faces repeated (one copy in reversed winding) must give exactly the clean
    # mesh's contact: area and the depth-weighted quadrature sum (∝ the EF force).
    f = CONDYLE.faces
    doubled = TriMesh(CONDYLE.points, np.vstack([f, f[:10], f[10:13, ::-1]]))
    plane = Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    with pytest.warns(UserWarning, match="13 duplicate face"):
        pair = ContactPair(doubled, plane)
    assert pair.slave.n_faces == CONDYLE.n_faces
    pose = (np.eye(3), np.array([0.2, 0.1, 25.5 - 0.8]))
    clean = PAIRS["plane"][0].evaluate(pose, IDENTITY)
    s = pair.evaluate(pose, IDENTITY)
    assert s.area == pytest.approx(clean.area, rel=1e-12)
    assert float((s.qp_weight * s.qp_depth).sum()) == pytest.approx(
        float((clean.qp_weight * clean.qp_depth).sum()), rel=1e-12)


def test_boundary_vertices_are_the_rim_of_a_disc_and_none_of_a_sphere():
    rim = ContactPair(PLATEAU, Sphere([0.0, 0.0, 30.0], 25.5)).boundary_vertex
    r = np.linalg.norm(PLATEAU.points[:, :2], axis=1)
    np.testing.assert_array_equal(rim, np.isclose(r, 12.0, atol=1e-9))
    assert rim.sum() >= 12
    assert not PAIRS["plane"][0].boundary_vertex.any()


SURFACE_FIELDS = ("face", "normal", "vertex_depth", "qp_point", "qp_depth", "qp_weight",
                  "qp_depth_twist", "qp_weight_twist")


def _assert_same_surface(a, b):
    for name in SURFACE_FIELDS:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


def test_a_forgotten_pair_evaluates_as_a_fresh_one_and_reuses_a_set_built_at_that_pose():
    master = icosphere(25.5, 3, center=(0.3, -0.2, 25.5 - 0.8))
    start = (np.eye(3), np.zeros(3))
    moved = (Rotation.from_rotvec([0.002, -0.003, 0.004]).as_matrix(), np.array([0.2, -0.1, 0.05]))
    pair = ContactPair(PLATEAU, master)
    reach_calls = []
    reach = pair.cache.reach
    pair.cache.reach = lambda y: reach_calls.append(len(y)) or reach(y)
    fresh = ContactPair(PLATEAU, master).evaluate(moved, IDENTITY)
    pair.evaluate(start, IDENTITY)
    pair.evaluate(moved, IDENTITY)       # from the set and closest faces kept at `start`
    assert pair.cache.n_reuses == 1
    pair.forget()
    _assert_same_surface(pair.evaluate(moved, IDENTITY), fresh)
    # a rebuild at a pose of an earlier one takes that set without asking the master again
    pair.forget()
    asked = len(reach_calls)
    again = pair.evaluate(moved, IDENTITY)
    assert len(reach_calls) == asked and pair.cache.n_rebuilds == 3
    _assert_same_surface(again, fresh)
