"""GJK/EPA against closed forms: spheres, sphere–box, box–box."""

import numpy as np
import pytest
from gjk_reference import BoxShape, ConvexPoints, SphereShape, gjk_epa, max_penetration
from scipy.spatial.transform import Rotation

from fecheck.errors import FecheckError


@pytest.mark.parametrize("gap", [-1.2, -0.3, 0.0, 0.25, 4.0])
def test_two_spheres(gap):
    # Centres 3 + 2 + gap apart along a skew axis: distance max(gap, 0), depth max(-gap, 0).
    axis = np.array([1.0, -2.0, 0.5]) / np.linalg.norm([1.0, -2.0, 0.5])
    a, b = SphereShape([1.0, 2.0, 3.0], 3.0), SphereShape(np.array([1.0, 2.0, 3.0])
                                                          + (5.0 + gap) * axis, 2.0)
    r = gjk_epa(a, b)
    assert r.overlap == (gap <= 0)
    assert r.distance == pytest.approx(max(gap, 0.0), abs=1e-9)
    assert r.depth == pytest.approx(max(-gap, 0.0), abs=1e-9)
    np.testing.assert_allclose(r.normal, axis, atol=1e-9)
    np.testing.assert_allclose(r.point_a, a.center + 3.0 * axis, atol=1e-9)
    np.testing.assert_allclose(r.point_b, b.center - 2.0 * axis, atol=1e-9)


@pytest.mark.parametrize("z, depth", [(1.5 + 2.0 + 0.7, 0.0), (1.5 + 2.0, 0.0),
                                      (1.5 + 2.0 - 0.4, 0.4), (1.0, 2.5)])
def test_sphere_on_box_face(z, depth):
    # Box half-height 1.5 about the origin, sphere R 2 above its top face: depth
    # R - (z - 1.5) when z > 1.5; with the centre inside, 1.5 - z + R (nearest face).
    box = BoxShape([0.0, 0.0, 0.0], [4.0, 3.0, 1.5])
    d, n = max_penetration(box, SphereShape([0.3, -0.2, z], 2.0))
    assert d == pytest.approx(depth, abs=1e-9)
    if depth > 0:
        np.testing.assert_allclose(n, [0.0, 0.0, 1.0], atol=1e-9)
    r = gjk_epa(box, SphereShape([0.3, -0.2, z], 2.0))
    assert r.distance == pytest.approx(max(z - 3.5, 0.0), abs=1e-9)


def test_sphere_near_box_corner_uses_the_euclidean_distance():
    box = BoxShape([0.0, 0.0, 0.0], [1.0, 1.0, 1.0])
    centre = np.array([2.0, 2.0, 2.0])
    r = gjk_epa(box, SphereShape(centre, 1.0))
    assert r.distance == pytest.approx(np.sqrt(3.0) - 1.0, abs=1e-9)
    np.testing.assert_allclose(r.point_a, [1.0, 1.0, 1.0], atol=1e-9)


@pytest.mark.parametrize("shift, overlap_depth, gap", [
    ([3.5, 0.2, 0.1], 0.0, 0.5),        # separated along x
    ([3.0, 0.5, -0.3], 0.0, 0.0),       # touching faces
    ([2.6, 0.3, 0.2], 0.4, 0.0),        # overlap 0.4 along x (smallest axis overlap)
    ([0.5, 0.2, 2.9], 0.1, 0.0),        # overlap 0.1 along z
])
def test_axis_aligned_boxes(shift, overlap_depth, gap):
    # Minkowski difference of two axis-aligned boxes is a box: depth = smallest overlap.
    a = BoxShape([0.0, 0.0, 0.0], [1.5, 2.0, 1.0])
    b = BoxShape(shift, [1.5, 1.0, 2.0])
    r = gjk_epa(a, b)
    assert r.depth == pytest.approx(overlap_depth, abs=1e-9)
    assert r.distance == pytest.approx(gap, abs=1e-9)
    if overlap_depth > 0:
        axis = np.argmax(np.abs(r.normal))
        assert abs(r.normal[axis]) == pytest.approx(1.0)
        assert np.sign(r.normal[axis]) == np.sign(shift[axis])


def test_rotated_box_corner_into_box_face():
    # A cube stood on its corner (diagonal along z) reaches the half-diagonal √3 below
    # its centre: its depth into the floor is exactly how far that corner is below it.
    R = Rotation.align_vectors([[0.0, 0.0, 1.0]], [[1.0, 1.0, 1.0]])[0].as_matrix()
    cube = BoxShape([0.0, 0.0, 0.0], [1.0, 1.0, 1.0], R)
    lowest = cube.points[:, 2].min()
    assert lowest == pytest.approx(-np.sqrt(3.0))
    floor = BoxShape([0.0, 0.0, -5.0], [10.0, 10.0, 5.0])
    d, n = max_penetration(floor, ConvexPoints(cube.points + [0.0, 0.0, np.sqrt(3) - 0.3]))
    assert d == pytest.approx(0.3, abs=1e-9)
    np.testing.assert_allclose(n, [0.0, 0.0, 1.0], atol=1e-9)


def test_invalid_shapes_raise():
    with pytest.raises(FecheckError):
        SphereShape([0.0, 0.0, np.nan], 1.0)
    with pytest.raises(FecheckError):
        ConvexPoints(np.zeros((0, 3)))
