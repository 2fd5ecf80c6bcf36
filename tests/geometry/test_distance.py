"""Gaps from points to a sphere and to a mesh's vertices (`geometry.distance`), against
hand-computed distances (mm)."""

from __future__ import annotations

import numpy as np
import pytest

from geometry.distance import sphere_gap_mm, vertex_gap_mm
from geometry.mesh import TriMesh


def _grid(n: int, spacing: float) -> TriMesh:
    """An n × n vertex grid in z = 0 (spacing mm), two triangles per cell."""
    x, y = np.meshgrid(np.arange(n) * spacing, np.arange(n) * spacing, indexing="ij")
    points = np.column_stack([x.ravel(), y.ravel(), np.zeros(n * n)])
    i = np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None, :]
    a, b, c, d = i.ravel(), i.ravel() + n, i.ravel() + n + 1, i.ravel() + 1
    return TriMesh(points, np.vstack([np.column_stack([a, b, c]), np.column_stack([a, c, d])]))


def test_sphere_gap_is_the_nearest_point_distance_to_the_surface_and_zero_inside():
    center, radius = np.array([1.0, 2.0, 3.0]), 25.5
    # 3-4-5 triangle: the point (1 + 18, 2 + 24, 3) lies 30 mm from the centre, 4.5 mm out
    points = np.array([[19.0, 26.0, 3.0], [1.0, 2.0, 3.0 + 40.0]])
    assert sphere_gap_mm(points, center, radius) == pytest.approx(4.5, abs=1e-12)
    assert sphere_gap_mm(np.array([[1.0, 2.0, 10.0]]), center, radius) == 0.0


def test_vertex_gap_is_exact_beyond_the_settling_distance_and_a_bound_within_it():
    mesh = _grid(101, 0.5)           # 10,201 vertices (index 101·i + j at x = 0.5 i, y = 0.5 j)
    points = np.array([[10.25, 20.5, 3.0], [40.0, 40.0, 9.0]])
    # nearest vertices of the first point: (10.0 or 10.5, 20.5, 0), √(0.25² + 3²) mm away
    exact = np.hypot(0.25, 3.0)
    assert vertex_gap_mm(points, mesh, settle_mm=1.0) == pytest.approx(exact, abs=1e-12)
    # the first pass keeps every 5th vertex and point (10,201 // 2,000 = 5): the first point
    # and, nearest to it, vertex 2060 = (10.0, 20.0, 0) (index 2061 and 2162 are left out):
    # an upper bound, returned when within the settling distance
    bound = np.sqrt(0.25**2 + 0.5**2 + 3.0**2)
    assert vertex_gap_mm(points, mesh, settle_mm=20.0) == pytest.approx(bound, abs=1e-12)
