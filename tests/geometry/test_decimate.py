"""Quadric decimation against exact surfaces: a sphere, a spherical-cap sheet with its border
circle, and the scanned tibial cartilage sheet; the fold repair; the input checks."""

import igl
import numpy as np
import pytest
from conftest import require_knee_data

from geometry import decimate as decimate_module
from geometry.decimate import decimate, decimated, folded, unfold
from geometry.distance import closest_distance
from geometry.errors import FecheckError
from geometry.icosphere import icosphere
from geometry.mesh import TriMesh
from geometry.plateau import plane_patch

CAP_R, CAP_RHO = 60.0, 15.0          # sphere radius and geodesic radius of the cap sheet, mm


def border_edges(mesh: TriMesh) -> np.ndarray:
    return igl.boundary_facets(mesh.faces)[0]


def border_length(mesh: TriMesh) -> float:
    e = border_edges(mesh)
    return float(np.linalg.norm(mesh.points[e[:, 0]] - mesh.points[e[:, 1]], axis=1).sum())


@pytest.fixture(scope="module")
def cap_sheet() -> TriMesh:
    """An open sheet on the sphere |p| = CAP_R, within geodesic distance CAP_RHO of the pole:
    a meshed flat disc (edges 0.7 mm, 3,393 faces) wrapped on by arc length."""
    disc = plane_patch((0, 0, 0), (0, 0, 1), radius=CAP_RHO, size=0.7, cache=False)
    x, y = disc.points[:, 0], disc.points[:, 1]
    polar, azimuth = np.hypot(x, y) / CAP_R, np.arctan2(y, x)
    points = CAP_R * np.column_stack([np.sin(polar) * np.cos(azimuth),
                                      np.sin(polar) * np.sin(azimuth), np.cos(polar)])
    return TriMesh(points, disc.faces)


def test_sphere_stays_on_the_sphere_closed_and_outward():
    centre, radius = np.array([1.0, 2.0, 3.0]), 10.0
    ball = icosphere(radius, 5, centre, method="trimesh", cache=False)      # 20,480 faces
    small = decimate(ball, 2000)
    assert 1800 <= small.n_faces <= 2000
    # measured 0.005 to 0.021 mm outside (the quadric optimum of tangent planes); the sagitta
    # of an equilateral edge at 2,000 faces (1.2 mm) is h²/8R = 0.018 mm
    r = np.linalg.norm(small.points - centre, axis=1)
    assert np.abs(r - radius).max() < 0.03
    # measured -0.095 % (the 20,480-face input: -0.030 %)
    assert small.area == pytest.approx(4 * np.pi * radius**2, rel=0.002)
    edges = np.sort(small.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    assert len(small.points) - len(np.unique(edges, axis=0)) + small.n_faces == 2
    outward = np.einsum("ij,ij->i", small.face_normals, small.face_centroids - centre)
    assert outward.min() > 0.99 * radius         # measured 9.96 mm: every face faces outward


def test_open_cap_sheet_keeps_its_border_area_and_side(cap_sheet):
    small = decimate(cap_sheet, 848)
    assert 0.9 * 848 <= small.n_faces <= 848
    # vertices on the sphere: measured 0 to 0.0047 mm outside (edge sagitta ~ 0.004 mm)
    assert np.abs(np.linalg.norm(small.points, axis=1) - CAP_R).max() < 0.01
    # the border stays on the circle polar = CAP_RHO / CAP_R: measured within 0.0039 mm
    # (libigl's edge-midpoint `decimate` moves it by 0.87 mm)
    b = np.unique(border_edges(small))
    polar = np.arccos(small.points[b, 2] / np.linalg.norm(small.points[b], axis=1))
    assert np.abs(polar - CAP_RHO / CAP_R).max() * CAP_R < 0.01
    # exact border circle and cap area; measured -0.006 % and -0.074 % (chords and flat
    # faces; the input mesh: -0.009 % and -0.037 %); edge-midpoint decimation: -0.4 %, -4 %
    phi = CAP_RHO / CAP_R
    assert border_length(small) == pytest.approx(2 * np.pi * CAP_R * np.sin(phi), rel=5e-4)
    assert small.area == pytest.approx(2 * np.pi * CAP_R**2 * (1 - np.cos(phi)), rel=2e-3)
    # outward side kept: face normals along the sphere's radius, measured cos >= 0.993
    radial = small.face_centroids / np.linalg.norm(small.face_centroids, axis=1, keepdims=True)
    assert np.einsum("ij,ij->i", small.face_normals, radial).min() > 0.9


def test_scanned_sheet_halved_stays_close_unfolded_and_keeps_its_border():
    from fecheck.scene import lenhart

    require_knee_data()
    sheet = lenhart.mesh("tibia_cartilage_medial")
    small = decimate(sheet, 2122)
    assert 0.9 * 2122 <= small.n_faces <= 2122
    # measured: new to old max 0.011 mm, old to new max 0.071 mm (mean 0.0012, 0.0021)
    assert closest_distance(small.points, sheet)[0].max() < 0.02
    assert closest_distance(sheet.points, small)[0].max() < 0.1
    # every face on the side of the closest old face: measured cos >= 0.94; raw qslim
    # folds 7 faces over (cos = -1) and so also counts +0.08 % area (measured -0.004 %)
    _, closest = closest_distance(small.face_centroids, sheet)
    assert np.einsum("ij,ij->i", small.face_normals, sheet.face_normals[closest]).min() > 0.5
    assert small.area == pytest.approx(sheet.area, rel=5e-4)
    # border length: measured -0.005 % (vertex clustering: +7.4 %)
    assert border_length(small) == pytest.approx(border_length(sheet), rel=5e-4)


def flat_grid() -> tuple[TriMesh, np.ndarray]:
    """A 4 mm x 4 mm grid sheet at z = 0 (1 mm cells, two faces each) and its +z normals."""
    x, y = np.meshgrid(np.arange(5.0), np.arange(5.0), indexing="ij")
    points = np.column_stack([x.ravel(), y.ravel(), np.zeros(25)])
    idx = np.arange(25).reshape(5, 5)
    a, b = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel()
    c, d = idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    faces = np.vstack([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    return TriMesh(points, faces), np.tile([0.0, 0.0, 1.0], (len(faces), 1))


def test_unfold_moves_a_folded_inner_vertex_to_its_neighbours_mean(monkeypatch):
    grid, up = flat_grid()
    bent = grid.points.copy()
    bent[12] = [3.5, 2.3, 0.0]               # the centre (2, 2) pushed past its neighbour (3, 2)
    assert folded(bent, grid.faces, up).sum() >= 2
    with monkeypatch.context() as m:
        m.setattr(decimate_module, "UNFOLD_ROUNDS", 0)
        with pytest.raises(FecheckError, match="could not unfold"):
            unfold(grid, bent, grid.faces, up)
    fixed, kept = unfold(grid, bent, grid.faces, up)
    np.testing.assert_allclose(fixed[12], [2.0, 2.0, 0.0], atol=1e-12)  # mean of 6 neighbours
    assert not folded(fixed, kept, up).any() and len(kept) == grid.n_faces


def test_unfold_keeps_folded_border_vertices_on_the_old_border():
    grid, up = flat_grid()
    side = grid.points.copy()
    side[2] = [0.0, 3.4, 0.0]                # (0, 2) slid along the border past (0, 3)
    assert folded(side, grid.faces, up).any()
    fixed, kept = unfold(grid, side, grid.faces, up)
    # the mean of its two border neighbours, not of all four neighbours (0.5, 2.25)
    np.testing.assert_allclose(fixed[2], [0.0, 2.0, 0.0], atol=1e-12)
    corner = grid.points.copy()
    corner[0] = [1.5, 1.5, 0.0]              # the corner (0, 0) pushed inside past (1, 1)
    assert folded(corner, grid.faces, up).any()
    fixed, kept = unfold(grid, corner, grid.faces, up)
    # projected onto the old border (x = 0 or y = 0), not onto the sheet at (0.5, 0.5)
    assert min(fixed[0, :2]) == pytest.approx(0.0, abs=1e-12)
    assert not folded(fixed, kept, up).any()


def test_unfold_drops_a_folded_ear():
    """An ear (two border edges) on a concave border, its tip inside the chord: no position
    of the tip unfolds it."""
    tri = np.array([[0.0, 0, 0], [2, 0, 0], [1, 1, 0], [1, 0.3, 0]])
    ear = np.array([[0, 1, 2], [1, 0, 3]])
    _, kept = unfold(TriMesh(tri, ear[:1]), tri, ear, np.tile([0.0, 0, 1], (2, 1)))
    np.testing.assert_array_equal(kept, ear[:1])


def test_unreachable_target_is_an_error():
    ball = icosphere(1.0, 0, method="trimesh", cache=False)
    two = TriMesh(np.vstack([ball.points, ball.points + 5.0]),
                  np.vstack([ball.faces, ball.faces + len(ball.points)]))
    with pytest.raises(FecheckError, match="stopped at 8 faces"):   # two closed tetrahedra
        decimate(two, 4)


def test_small_enough_meshes_come_back_unchanged():
    ball = icosphere(10.0, 2, method="trimesh", cache=False)
    assert decimate(ball, ball.n_faces) is ball
    assert decimate(ball, 10_000) is ball
    assert decimate(ball, np.int64(100)).n_faces <= 100


@pytest.mark.parametrize("target", [3, 0, -10, 100.0, 99.5, True, "100"])
def test_bad_targets_are_rejected(target):
    ball = icosphere(10.0, 2, method="trimesh", cache=False)
    with pytest.raises(FecheckError, match="target_faces"):
        decimate(ball, target)


def test_empty_nan_and_non_manifold_meshes_are_rejected():
    with pytest.raises(FecheckError, match="empty"):
        decimate(TriMesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=int)), 10)
    ball = icosphere(10.0, 2, method="trimesh", cache=False)
    broken = TriMesh(ball.points.copy(), ball.faces)
    broken.points[5, 1] = np.nan             # arrays stay writable after the checks
    with pytest.raises(FecheckError, match="cannot decimate a mesh with NaN"):
        decimate(broken, 100)
    fins = TriMesh(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]]),
                   np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4], [2, 1, 4], [3, 0, 4]]))
    with pytest.raises(FecheckError, match="edge-manifold"):
        decimate(fins, 4)


def voxel_stair_sheet(step_mm: float = 0.5, n: int = 41) -> TriMesh:
    """A dish sampled as voxel stairs (heights rounded to `step_mm`) with the cells along
    the diagonal left out, so that the cells beside it meet only at their corners: pinched
    vertices, as a sheet cut from a voxel segmentation has them. Normals up, mm."""
    u = np.linspace(-15.0, 15.0, n)
    x, y = (a.ravel() for a in np.meshgrid(u, u, indexing="ij"))
    i, j = (a.ravel() for a in np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij"))
    keep = ~((i == j) & (i > 5))
    p = (i * n + j)[keep]
    faces = np.concatenate([np.stack([p, p + n, p + n + 1], 1), np.stack([p, p + n + 1, p + 1], 1)])
    z = np.round((x ** 2 + y ** 2) / 100.0 / step_mm) * step_mm
    used, remap = np.unique(faces, return_inverse=True)
    return TriMesh(np.column_stack([x, y, z])[used], remap.reshape(-1, 3))


def test_voxel_stair_sheet_with_pinched_vertices_decimates():
    sheet = voxel_stair_sheet()
    pinched = ~igl.is_vertex_manifold(sheet.faces)
    assert np.count_nonzero(pinched) == 33              # corners (k, k), k = 7..39
    out = decimate(sheet, 1000)
    assert 990 <= out.n_faces <= 1000
    assert (out.face_cross[:, 2] > 0).all()             # every face still faces up
    # the decimated vertices lie on the old surface, within the stairs' height (0.5 mm)
    assert closest_distance(out.points, sheet)[0].max() < 0.5
    assert out.area == pytest.approx(sheet.area, rel=0.02)


def test_a_failed_qslim_is_an_error_not_an_index_error(monkeypatch):
    import igl as igl_module

    monkeypatch.setattr(igl_module, "qslim", lambda v, f, m: (np.zeros((0, 3)),
                                                              np.zeros((0, 3), dtype=int),
                                                              np.zeros(0, dtype=int),
                                                              np.zeros(0, dtype=int)))
    with pytest.raises(FecheckError, match="returned no faces.*scanned.decimate_faces = 0"):
        decimate(voxel_stair_sheet(), 1000)


def test_decimated_is_kept_by_the_mesh_content_and_the_target(monkeypatch):
    monkeypatch.setattr(decimate_module, "_kept", {})
    monkeypatch.setattr(decimate_module, "KEPT", 3)
    real, calls = decimate_module.decimate, []
    monkeypatch.setattr(decimate_module, "decimate",
                        lambda mesh, target: calls.append(target) or real(mesh, target))
    sphere = icosphere(10.0, 3, method="trimesh", cache=False)          # 1,280 faces
    first = decimated(sphere, 300)
    assert np.array_equal(first.faces, real(sphere, 300).faces)
    assert np.array_equal(first.points, real(sphere, 300).points)
    assert decimated(TriMesh(sphere.points.copy(), sphere.faces.copy()), 300) is first
    assert decimated(sphere, 200).n_faces <= 200 < first.n_faces
    moved = TriMesh(sphere.points + 1.0, sphere.faces)
    assert decimated(moved, 300) is not first
    assert calls == [300, 200, 300]
    decimated(moved, 100)                 # a fourth mesh: the oldest (the first) is dropped
    assert len(decimate_module._kept) == 3
    assert decimated(sphere, 300) is not first and calls == [300, 200, 300, 100, 300]
