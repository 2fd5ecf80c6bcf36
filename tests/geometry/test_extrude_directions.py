"""Extrusion along smoothed normals (`geometry.extrude`) and midpoint subdivision
(`geometry.subdivide`).

References: exact planes (the normal is known, depths are exact), a seeded noisy sphere
cap that the raw normals invert, a closed sphere thicker than its radius (impossible),
and the exact area and facing of a split flat triangle.
"""

from __future__ import annotations

import numpy as np
import pytest

from geometry.errors import FecheckError
from geometry.extrude import extrude_layer, extrusion_directions
from geometry.icosphere import icosphere
from geometry.mesh import TriMesh
from geometry.plateau import plane_patch
from geometry.subdivide import subdivide

UP = np.array([0.0, 0.0, 1.0])


def _disc() -> TriMesh:
    """A flat disc of radius 10 mm in z = 0, normals up."""
    return plane_patch((0.0, 0.0, 0.0), UP, radius=10.0, size=1.5)


def _cap(radius: float, level: int, noise: float, seed: int = 0) -> TriMesh:
    """The icosphere's cap above z = 0.3·radius, each vertex moved radially by a seeded
    normal deviate of `noise` mm (outward normals)."""
    ball = icosphere(radius, level, method="trimesh", cache=False)
    faces = ball.faces[ball.face_centroids[:, 2] > 0.3 * radius]
    used, inverse = np.unique(faces, return_inverse=True)
    rng = np.random.default_rng(seed)
    scale = 1.0 + noise / radius * rng.standard_normal(len(used))
    return TriMesh(ball.points[used] * scale[:, None], inverse.reshape(-1, 3))


def _edge_counts(mesh: TriMesh) -> np.ndarray:
    e = np.sort(mesh.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    return np.unique(e, axis=0, return_counts=True)[1]


# --- extrusion directions ---------------------------------------------------------------


def test_a_flat_disc_extrudes_along_its_normal_without_smoothing():
    disc = _disc()
    d, rounds = extrusion_directions(disc, 6.0, layers=3, ratio=1.5)
    assert rounds == 0
    assert np.array_equal(d, disc.vertex_normals)
    assert np.array_equal(d, np.broadcast_to(UP, d.shape))          # outward side: up


def test_smoothed_directions_mend_a_noisy_cap_the_raw_normals_invert():
    # R 8 mm, 0.57 mm edges, 0.1 mm radial noise, 3 mm deep: the raw normals invert
    # 797 of 3584 prisms; measured: 4 rounds of 1-ring smoothing mend them all
    cap = _cap(8.0, 4, 0.1)
    with pytest.raises(FecheckError, match="inverted or flat"):
        extrude_layer(cap, 3.0, layers=2)
    d, rounds = extrusion_directions(cap, 3.0, layers=2)
    assert 0 < rounds <= 8
    assert np.allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-12)
    cosine = np.einsum("ij,ij->i", d, cap.vertex_normals)
    assert cosine.min() > 0.5            # outward side, within 60° (measured: 0.83)
    layer = extrude_layer(cap, 3.0, layers=2, directions=d)
    assert np.all(layer.tet_volumes > 0)
    # each bottom vertex 3 mm below the surface along its own normal
    n = cap.n_points
    depth = np.einsum("ij,ij->i", cap.points - layer.points[2 * n:], cap.vertex_normals)
    assert np.allclose(depth, 3.0, atol=1e-12)


def test_tilted_directions_keep_the_thickness_along_the_normal():
    disc = _disc()
    n = disc.n_points
    h = 2.0 + 0.1 * disc.points[:, 0]                               # 1 … 3 mm
    tilt = np.radians(27.5 + 2.75 * disc.points[:, 0])              # 0 … 55°: exact
    azimuth = np.radians(30.0)
    d = np.column_stack([np.sin(tilt) * np.cos(azimuth), np.sin(tilt) * np.sin(azimuth),
                         np.cos(tilt)])
    layer = extrude_layer(disc, h, layers=2, directions=d)
    bottom = layer.points[2 * n:]
    assert np.allclose(bottom[:, 2], -h, atol=1e-12)                # depth h along z
    slide = np.linalg.norm(bottom[:, :2] - disc.points[:, :2], axis=1)
    assert np.allclose(slide, h * np.tan(tilt), atol=1e-12)         # along -d
    # beyond 60° the stretch stops at 1 / 0.5: a 70° direction goes 2h along -d
    steep = np.tile([np.sin(np.radians(70.0)), 0.0, np.cos(np.radians(70.0))], (n, 1))
    layer = extrude_layer(disc, 1.0, layers=1, directions=steep)
    assert np.allclose(layer.points[n:, 2], -2.0 * np.cos(np.radians(70.0)), atol=1e-12)


def test_a_layer_thicker_than_the_sphere_cannot_be_mended():
    # a closed sphere of radius 5 mm, 6 mm deep: the bottom level crosses the centre
    # whatever the smoothing (by symmetry the directions stay radial)
    ball = icosphere(5.0, 2, method="trimesh", cache=False)
    with pytest.raises(FecheckError, match=r"320 of 320 faces extrude into inverted prisms "
                                           r"after 1024 rounds .* at \(.*\) mm\): use a "
                                           r"thinner layer, or a smoother or finer"):
        extrusion_directions(ball, 6.0, layers=2)
    with pytest.raises(FecheckError, match="after 5 rounds"):
        extrusion_directions(ball, 6.0, layers=2, max_rounds=5)


def test_directions_must_be_one_per_vertex():
    disc = _disc()
    with pytest.raises(FecheckError, match="one per surface vertex"):
        extrude_layer(disc, 1.0, directions=np.ones((3, 3)))


# --- subdivision --------------------------------------------------------------------------


@pytest.mark.parametrize("times", [0, 1, 3])
def test_subdivision_splits_every_face_into_four_and_keeps_the_surface(times):
    cap = _cap(8.0, 2, 0.3)
    fine, parent = subdivide(cap, times)
    assert fine.n_faces == 4**times * cap.n_faces
    assert fine.area == pytest.approx(cap.area, rel=1e-12)
    assert np.array_equal(fine.points[:cap.n_points], cap.points)
    # one new vertex per unique edge (Euler: each split adds the edge count)
    assert fine.n_points == cap.n_points + (0 if times == 0 else len(_new_edges(cap, times)))
    # conforming: interior edges in two faces, boundary edges double per split
    counts, counts0 = _edge_counts(fine), _edge_counts(cap)
    assert set(np.unique(counts)) == {1, 2}
    assert np.count_nonzero(counts == 1) == 2**times * np.count_nonzero(counts0 == 1)
    # same facing: every child's normal is its parent's
    assert np.allclose(fine.face_normals, cap.face_normals[parent], atol=1e-12)
    # every child inside its parent: barycentric coordinates of its centroid in [0, 1]
    assert np.all(_barycentric(cap.triangles[parent], fine.face_centroids) > 0.0)


def _new_edges(mesh: TriMesh, times: int) -> np.ndarray:
    """Unique edges of all meshes before the last split (one midpoint each)."""
    edges = [subdivide(mesh, k)[0].edges_unique for k in range(times)]
    return np.concatenate(edges)


def _barycentric(tri: np.ndarray, x: np.ndarray) -> np.ndarray:
    """(k, 3) barycentric coordinates of points `x` (k, 3) in triangles `tri` (k, 3, 3)."""
    u, v, w = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0], x - tri[:, 0]
    g = np.stack([np.einsum("ij,ij->i", p, q) for p in (u, v) for q in (u, v)], 1)
    r = np.column_stack([np.einsum("ij,ij->i", u, w), np.einsum("ij,ij->i", v, w)])
    det = g[:, 0] * g[:, 3] - g[:, 1] * g[:, 2]
    s = (g[:, 3] * r[:, 0] - g[:, 1] * r[:, 1]) / det
    t = (g[:, 0] * r[:, 1] - g[:, 2] * r[:, 0]) / det
    return np.column_stack([1.0 - s - t, s, t])


def test_subdivision_keeps_the_winding_and_the_regions():
    square = TriMesh(np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]),
                     np.array([[0, 1, 3], [0, 3, 2]]), {"left": np.array([1])})
    fine, parent = subdivide(square, 1)
    assert fine.faces[:4].tolist() == [[0, 4, 6], [4, 1, 7], [6, 7, 3], [4, 7, 6]]
    assert np.all(fine.face_normals[:, 2] == 1.0)
    assert parent.tolist() == [0, 0, 0, 0, 1, 1, 1, 1]
    assert fine.regions["left"].tolist() == [4, 5, 6, 7]
    assert fine.points[4:].tolist() == [[0.5, 0, 0], [0, 0.5, 0], [0.5, 0.5, 0], [1, 0.5, 0],
                                        [0.5, 1, 0]]


def test_subdivision_count_must_be_a_whole_number():
    with pytest.raises(FecheckError, match="whole number"):
        subdivide(_disc(), -1)
