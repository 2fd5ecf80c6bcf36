"""Icospheres: exact face counts, vertices on the sphere, outward winding, Fig. 3.3."""

import time

import numpy as np
import pytest

from fecheck.errors import FecheckError
from geometry.icosphere import icosphere, icosphere_volume_error

CENTER = np.array([28.3, 12.8, 25.8])  # lateral condyle centre, thesis Table B.1
RADIUS = 31.8


@pytest.mark.parametrize("method", ["gmsh", "trimesh"])
@pytest.mark.parametrize("n", [0, 1, 2, 3, 4, 5])
def test_icosphere_has_20_4n_faces_all_vertices_on_sphere_outward(method, n):
    m = icosphere(RADIUS, n, CENTER, method=method)
    assert m.n_faces == 20 * 4**n
    assert m.n_points == 10 * 4**n + 2  # Euler: V = F/2 + 2
    r = np.linalg.norm(m.points - CENTER, axis=1)
    np.testing.assert_allclose(r, RADIUS, rtol=1e-13)
    outward = np.einsum("ij,ij->i", m.face_normals, m.face_centroids - CENTER)
    assert np.all(outward > 0)


def test_gmsh_and_trimesh_icospheres_have_the_same_vertices():
    # both subdivide edges at midpoints and project after each level
    a, b = (icosphere(1.0, 3, method=k) for k in ("gmsh", "trimesh"))
    pa = a.points[np.lexsort(np.round(a.points, 9).T)]
    pb = b.points[np.lexsort(np.round(b.points, 9).T)]
    np.testing.assert_allclose(pa, pb, atol=1e-12)


def test_volume_error_below_half_percent_from_5120_faces_and_converges_as_h_squared():
    err = np.array([abs(icosphere_volume_error(RADIUS, n)) for n in range(2, 8)])
    # thesis Fig. 3.3: 1280 faces (n=3) still outside the 0.5% band, 5120 (n=4) inside
    assert err[1] > 0.005 > err[2]
    # h halves per level; an inscribed polyhedron misses O(h²) of the volume, so the
    # error ratio per level tends to 4 (observed 3.90, 3.98, 3.996, 3.999, 4.000)
    ratios = err[:-1] / err[1:]
    assert np.all(np.diff(ratios) > 0)
    np.testing.assert_allclose(ratios[-3:], 4.0, rtol=0.01)
    order = np.log(ratios[-1]) / np.log(2.0)
    assert order == pytest.approx(2.0, abs=0.01)


@pytest.mark.bench
def test_level_7_builds_with_linear_cost():
    times = {}
    for n in (6, 7):
        t0 = time.perf_counter()
        m = icosphere(1.0, n, cache=False)
        times[n] = time.perf_counter() - t0
        assert m.n_faces == 20 * 4**n
    # 4x the faces; a loose bound (noisy shared cores) that still rules out quadratic cost
    assert times[7] < 10 * times[6] + 0.5


@pytest.mark.parametrize("kwargs", [
    {"radius": -1.0, "subdivisions": 2}, {"radius": float("nan"), "subdivisions": 2},
    {"radius": 1.0, "subdivisions": 9}, {"radius": 1.0, "subdivisions": -1},
    {"radius": 1.0, "subdivisions": 1.5}, {"radius": 1.0, "subdivisions": 2, "method": "occ"},
    {"radius": 1.0, "subdivisions": 2, "center": (0, 0)},
])
def test_icosphere_rejects_bad_input(kwargs):
    with pytest.raises(FecheckError):
        icosphere(**kwargs)
