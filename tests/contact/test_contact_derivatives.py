"""Twist derivatives of the contact surface against central finite differences."""

import numpy as np
import pytest
from contact_helpers import central_difference, extrapolated_difference, moments, moments_twist

from fecheck.contact import ContactPair, Plane, PolynomialSurface, Sphere
from fecheck.contact.surface import skew_rows
from fecheck.statics.frames import rotation
from geometry.icosphere import icosphere
from geometry.plateau import plane_patch, polynomial_patch
from geometry.polynomial import Polynomial2D

POLY = Polynomial2D(np.array([[0.2, 0.1, 0.01], [0.15, 0.02, 0.0], [0.012, 0.0, 0.0]]))
MASTER_POSE = (rotation(0.1, 0.2, 0.3), np.array([1.0, 2.0, 3.0]))


def _condyle_case(master):
    slave = icosphere(31.8, 4)
    slave_pose = (rotation(0.1, 0.25, 0.3),
                  MASTER_POSE[0] @ np.array([0.3, 0.2, 31.8 - 1.0]) + MASTER_POSE[1])
    return slave, master, slave_pose, MASTER_POSE


def _plateau_case(master):
    plateau = polynomial_patch(Polynomial2D(np.array([[0.0, 0.0, 0.002], [0.0, 0.0, 0.0],
                                                      [0.003, 0.0, 0.0]])),
                               half_x=15.0, half_y=15.0, size=1.0)
    slave_pose = (MASTER_POSE[0] @ rotation(0.05, 0.1, 0.3),
                  MASTER_POSE[0] @ np.array([0.4, -0.3, 0.2]) + MASTER_POSE[1])
    return plateau, master, slave_pose, MASTER_POSE


CASES = {
    "plane": lambda: _condyle_case(Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0])),
    "polynomial": lambda: _condyle_case(PolynomialSurface(POLY)),
    "sphere": lambda: _plateau_case(Sphere([0.0, 0.0, 25.5 - 1.0], 25.5)),
    "mesh": lambda: _plateau_case(icosphere(25.5, 4, center=(0.0, 0.0, 25.5 - 1.0))),
}


@pytest.mark.parametrize("kind", CASES)
def test_clipped_integrals_have_exact_twist_derivatives(kind):
    # Σ w·d and Σ w·d² vanish at the clip line, so their derivatives need no boundary
    # term: the fields' derivatives must match central differences (h = 1e-6, error
    # ~h² + rounding/h ~ 1e-10 relative; measured ≤ 2e-9).
    slave, master, slave_pose, master_pose = CASES[kind]()
    pair = ContactPair(slave, master)
    s = pair.evaluate(slave_pose, master_pose)
    assert s.n_faces > 20
    analytic = moments_twist(s)
    numeric = central_difference(lambda p: moments(pair.evaluate(p, master_pose)), slave_pose)
    scale = np.abs(analytic).max(axis=1, keepdims=True)
    assert np.abs(analytic - numeric).max() / scale.min() < 1e-6


@pytest.mark.parametrize("kind", CASES)
def test_whole_face_point_fields_have_exact_twist_derivatives(kind):
    # In whole-face mode the points keep their barycentric coordinates under the motion,
    # so every point's depth and weight can be differenced directly.
    slave, master, slave_pose, master_pose = CASES[kind]()
    pair = ContactPair(slave, master, area="whole-face")
    s = pair.evaluate(slave_pose, master_pose)

    def fields(pose):
        t = pair.evaluate(pose, master_pose)
        assert np.array_equal(t.face, s.face)
        return np.concatenate([t.qp_depth, t.qp_weight, t.normal.ravel()])

    numeric = central_difference(fields, slave_pose)
    q = len(s.qp_depth)
    depth_err = np.abs(s.qp_depth_twist - numeric[:q]).max()
    weight_err = np.abs(s.qp_weight_twist - numeric[q:2 * q]).max()
    normal_err = np.abs(s.normal_twist.reshape(-1, 6) - numeric[2 * q:]).max()
    assert depth_err < 1e-6 * max(1.0, np.abs(s.qp_depth_twist).max())
    assert weight_err < 1e-6 * max(1.0, np.abs(s.qp_weight_twist).max(), s.qp_weight.max())
    assert normal_err < 1e-6


@pytest.mark.parametrize("kind", CASES)
def test_clipped_point_fields_have_exact_twist_derivatives(kind):
    # On a clipped face the points move with the clip line: their depth, weight and
    # position (rigid motion v + ω × x plus the in-face slide) must match differences
    # point by point while no vertex changes side (h = 1e-6 keeps every sign pattern).
    # A short clip (a vertex 1 µm deep) makes plain central differences err by ~1e-5
    # here; extrapolated ones agree to ≤ 4e-7 (measured).
    slave, master, slave_pose, master_pose = CASES[kind]()
    pair = ContactPair(slave, master)
    s = pair.evaluate(slave_pose, master_pose)
    assert s.clip_face.size > 30

    def fields(pose):
        t = pair.evaluate(pose, master_pose)
        assert np.array_equal(t.face, s.face) and np.array_equal(t.qp_face, s.qp_face)
        return np.concatenate([t.qp_depth, t.qp_weight, t.qp_point.ravel()])

    numeric = extrapolated_difference(fields, slave_pose)
    q = len(s.qp_depth)
    point = np.zeros((q, 3, 6))
    point[:, :, :3] = np.eye(3)
    point[:, :, 3:] = -skew_rows(s.qp_point)              # ω × x = −[x]× ω
    on = s.qp_clip >= 0                                   # + Σ_e share·edge ⊗ rate
    point[on] += np.einsum("qe,qei,qek->qik", s.clip_share[on], s.clip_edge[s.qp_clip[on]],
                           s.clip_rate[s.qp_clip[on]])
    depth_err = np.abs(s.qp_depth_twist - numeric[:q]).max()
    weight_err = np.abs(s.qp_weight_twist - numeric[q:2 * q]).max()
    point_err = np.abs(point.reshape(-1, 6) - numeric[2 * q:]).max()
    assert depth_err < 1e-6 * max(1.0, np.abs(s.qp_depth_twist).max())
    assert weight_err < 1e-6 * max(1.0, np.abs(s.qp_weight_twist).max(), s.qp_weight.max())
    assert point_err < 1e-6 * max(1.0, np.abs(s.qp_point).max())


def test_sphere_depth_gradient_matches_differences_for_flat_patch():
    # Depth along the plateau normal to the sphere, for the moving plateau of
    # geometry.plateau (independent builder), against differences of vertex depths.
    plateau = plane_patch([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], radius=10.0, size=1.0)
    pair = ContactPair(plateau, Sphere([0.0, 0.0, 20.0 - 0.7], 20.0), area="whole-face")
    pose = (rotation(0.02, -0.03, 0.1), np.array([0.2, 0.1, 0.0]))
    s = pair.evaluate(pose, (np.eye(3), np.zeros(3)))
    numeric = central_difference(
        lambda p: pair.evaluate(p, (np.eye(3), np.zeros(3))).qp_depth, pose)
    np.testing.assert_allclose(s.qp_depth_twist, numeric, atol=1e-7)
