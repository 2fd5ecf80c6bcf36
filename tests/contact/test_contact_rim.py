"""The rim fade of a contact pair (``rim_mm``): no contact behind an open master sheet's
rim, where the side-of-normal test would see a wall."""

import numpy as np
import pytest
from contact_helpers import cap_volume, central_difference, moments, moments_twist

from fecheck.contact import ContactPair
from fecheck.errors import FecheckError
from geometry.icosphere import icosphere
from geometry.mesh import TriMesh

HALF, RADIUS, OVERLAP = 10.0, 10.0, 1.0
MASTER_POSE = (np.eye(3), np.zeros(3))


def _square_sheet(n: int = 20) -> TriMesh:
    """The open square |x|, |y| ≤ HALF mm in z = 0, normals +z (inside below), a 1 mm
    grid."""
    g = np.linspace(-HALF, HALF, n + 1)
    x, y = np.meshgrid(g, g, indexing="ij")
    points = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    idx = np.arange(len(points)).reshape(n + 1, n + 1)
    a, b = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel()
    c, d = idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    return TriMesh(points, np.concatenate([np.column_stack([a, b, c]),
                                           np.column_stack([a, c, d])]))


def _over_the_edge(rim_mm: float):
    """A ball (radius 10 mm) pressed 1 mm into the sheet with its centre over the rim
    x = HALF: the pair and its contact surface."""
    pair = ContactPair(icosphere(RADIUS, 4), _square_sheet(), rim_mm=rim_mm)
    pose = (np.eye(3), np.array([HALF, 0.3, RADIUS - OVERLAP]))
    return pair, pose, pair.evaluate(pose, MASTER_POSE)


def test_points_behind_the_rim_carry_no_contact_with_the_fade():
    # Half of the cap lies beyond x = 10, where the closest sheet point is on the rim.
    # Without the fade those points are "inside" (below the last face's plane) at their
    # distance to the rim edge: contact reaches x = 10 + the broad phase's 2 mm margin
    # (the cap's radius is 4.36 mm). With it nothing beyond the rim carries a depth, bar
    # the clipped part of the slave faces that straddle it (slave edges 0.75 mm).
    _, _, wall = _over_the_edge(0.0)
    _, _, faded = _over_the_edge(0.5)
    assert wall.qp_point[wall.qp_depth > 0.0, 0].max() > HALF + 1.5
    assert faded.qp_point[faded.qp_depth > 0.0, 0].max() < HALF + 0.75


def test_the_faded_volume_is_the_half_cap_less_the_band():
    # The cap's volume (Σ w·d) over the sheet: half of it lies over the sheet; the fade
    # (0.5 mm, on a 1 mm grid: over the row of faces at the rim) takes at most the
    # volume of a strip of one grid width along the 2 x 4.36 mm chord at depth ≤ 1 mm
    # (8.7 mm³). The wall adds the other half's volume below z = 0 instead.
    half = 0.5 * cap_volume(RADIUS, OVERLAP)
    _, _, wall = _over_the_edge(0.0)
    _, _, faded = _over_the_edge(0.5)
    assert half - 8.7 < moments(faded)[0] < half
    assert moments(wall)[0] > 1.3 * half


def test_the_fade_has_exact_twist_derivatives():
    # As the clipped integrals of test_contact_derivatives (measured ≤ 2e-7 relative with
    # the fade's gradient term; 1e-6 allowed): the tangent of the faded depths is their
    # derivative, not only the depths'.
    pair, pose, s = _over_the_edge(0.5)
    numeric = central_difference(lambda p: moments(pair.evaluate(p, MASTER_POSE)), pose)
    analytic = moments_twist(s)
    assert np.abs(analytic - numeric).max() / np.abs(analytic).max() < 1e-6


def test_a_rim_fade_needs_a_mesh_master_by_side_of_normal():
    with pytest.raises(FecheckError, match="rim_mm"):
        ContactPair(icosphere(RADIUS, 2), _square_sheet(), rim_mm=0.5, mesh_sign="winding")
    with pytest.raises(FecheckError, match="rim_mm"):
        ContactPair(icosphere(RADIUS, 2), _square_sheet(), rim_mm=-1.0)
