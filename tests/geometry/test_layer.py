"""Cartilage layer meshes: volume, boundaries and refinement (geometry.layer)."""

from __future__ import annotations

import numpy as np
import pytest

from fecheck.errors import FecheckError
from geometry.layer import cartilage_layer, top_height
from geometry.polynomial import Polynomial2D


@pytest.mark.parametrize("kwargs, footprint_area", [
    # The vertical shear onto the top has unit Jacobian: a rectangle keeps 40 × 30 × h
    # to rounding, flat or inclined.
    ({"footprint": "rectangle", "half_x": 20.0, "half_y": 15.0}, 1200.0),
    ({"footprint": "rectangle", "half_x": 20.0, "half_y": 15.0, "sagittal_deg": 8.0,
      "frontal_deg": -6.0}, 1200.0),
    # An ellipse is a polygon of ~size-long chords: area deficit (2π/n)²/6 < 0.2% here.
    ({"footprint": "ellipse", "half_x": 25.0, "half_y": 18.0, "size": 3.0},
     np.pi * 25.0 * 18.0),
    # Polynomial top: the piecewise-linear map of a curved shear keeps the volume to
    # second order in the element size.
    ({"footprint": "rectangle", "half_x": 20.0, "half_y": 15.0,
      "top": Polynomial2D(np.array([[0.0, 0.02], [0.05, 0.0], [0.004, 0.0]]))}, 1200.0),
])
def test_volume_is_footprint_area_times_thickness(kwargs, footprint_area):
    mesh = cartilage_layer(thickness=6.0, cache=False, **{"size": 4.0, **kwargs})
    assert mesh.volume == pytest.approx(footprint_area * 6.0, rel=5e-3)
    assert np.all(mesh.tet_volumes > 0)


def test_top_and_bottom_boundaries_lie_on_the_mapped_surfaces():
    kw = {"sagittal_deg": 5.0, "frontal_deg": 10.0}
    mesh = cartilage_layer("ellipse", (3.0, -2.0), 15.0, 10.0, 4.0, size=3.0, cache=False, **kw)
    top, bottom = np.unique(mesh.boundaries["top"]), np.unique(mesh.boundaries["bottom"])
    z = top_height(mesh.points[:, :2], (3.0, -2.0), None, **kw)
    np.testing.assert_allclose(mesh.points[top, 2], z[top], atol=1e-9)
    np.testing.assert_allclose(mesh.points[bottom, 2], z[bottom] - 4.0, atol=1e-9)
    assert len(top) and len(bottom) and not np.intersect1d(top, bottom).size


@pytest.mark.parametrize("target", [1.0, 0.25])
def test_element_size_under_the_refinement_point_matches_the_target(target):
    point = (2.0, 1.0)
    mesh = cartilage_layer("rectangle", half_x=15.0, half_y=15.0, thickness=3.0, size=5.0,
                           refine_point=point, refine_size=target, refine_radius=4 * target,
                           cache=False)
    tri = mesh.boundaries["top"]
    centroid = mesh.points[tri].mean(axis=1)
    near = np.hypot(centroid[:, 0] - point[0], centroid[:, 1] - point[1]) < 2 * target
    edges = np.concatenate([mesh.points[tri[near, i]] - mesh.points[tri[near, j]]
                            for i, j in ((0, 1), (1, 2), (0, 2))])
    assert np.median(np.linalg.norm(edges, axis=1)) == pytest.approx(target, rel=0.3)
    # A node sits exactly on the refinement point.
    assert np.min(np.hypot(mesh.points[:, 0] - point[0], mesh.points[:, 1] - point[1])) < 1e-9


def test_second_order_mesh_has_ten_node_tets_on_the_same_volume():
    lin = cartilage_layer("rectangle", half_x=10.0, half_y=8.0, thickness=3.0, size=3.0,
                          cache=False)
    quad = cartilage_layer("rectangle", half_x=10.0, half_y=8.0, thickness=3.0, size=3.0,
                           order=2, cache=False)
    assert quad.tets.shape[1] == 10 and quad.boundaries["top"].shape[1] == 6
    # Edge nodes of a straight-sided tet sit at the midpoints of its corners.
    p = quad.points[quad.tets]
    np.testing.assert_allclose(p[:, 4], 0.5 * (p[:, 0] + p[:, 1]), atol=1e-9)
    assert lin.volume == pytest.approx(320 * 3.0, rel=1e-9)
    assert quad.volume == pytest.approx(320 * 3.0, rel=1e-9)


def test_cache_returns_the_same_mesh():
    a = cartilage_layer("ellipse", half_x=10.0, half_y=10.0, thickness=2.0, size=3.0)
    b = cartilage_layer("ellipse", half_x=10.0, half_y=10.0, thickness=2.0, size=3.0)
    np.testing.assert_array_equal(a.points, b.points)
    np.testing.assert_array_equal(a.tets, b.tets)


@pytest.mark.parametrize("kwargs, message", [
    ({"footprint": "circle"}, "footprint"),
    ({"thickness": -1.0}, "thickness"),
    ({"refine_size": 10.0, "size": 5.0}, "refine_size"),
    ({"order": 3}, "order"),
])
def test_bad_inputs_raise_a_clear_error(kwargs, message):
    with pytest.raises(FecheckError, match=message):
        cartilage_layer(cache=False, **kwargs)
