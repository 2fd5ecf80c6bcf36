"""Articular sheets prepared for the FE (`geometry.prepare`), on sheets made like
segmentations (`geometry.synthetic.voxel_knee`: marching cubes of voxel labels) and on
closed-form sheets."""

from __future__ import annotations

import numpy as np
import pytest

from geometry.cache import STATS
from geometry.errors import FecheckError
from geometry.mesh import TriMesh
from geometry.planar import plane_interpolation
from geometry.prepare import MAX_TILT_DEG, prepare_sheet
from geometry.synthetic.knee import CONDYLES, plateau_height, tibia_compartment
from geometry.synthetic.voxel_knee import voxel_knee

SPACING_MM = 0.6


@pytest.fixture(scope="module")
def voxel():
    return voxel_knee(SPACING_MM)


def _part(mesh: TriMesh, keep: np.ndarray) -> TriMesh:
    faces = mesh.faces[keep[mesh.faces].all(axis=1)]
    used = np.unique(faces)
    remap = np.full(mesh.n_points, -1)
    remap[used] = np.arange(len(used))
    return TriMesh(mesh.points[used], remap[faces])


def _angles(mesh: TriMesh) -> np.ndarray:
    """(m, 3) interior angles of the faces, degrees."""
    p = mesh.points[mesh.faces]
    out = []
    for k in range(3):
        a, b = p[:, (k + 1) % 3] - p[:, k], p[:, (k + 2) % 3] - p[:, k]
        cos = np.einsum("ij,ij->i", a, b) / np.linalg.norm(a, axis=1) / np.linalg.norm(b, axis=1)
        out.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
    return np.column_stack(out)


def _plane_sheet(n: int = 30, seed: int = 1) -> TriMesh:
    """A randomly jittered grid on the plane z = 0.2 x - 0.1 y + 3 (20 × 20 mm), normals
    up."""
    rng = np.random.default_rng(seed)
    u = np.linspace(0.0, 20.0, n)
    X, Y = np.meshgrid(u, u, indexing="ij")
    X = X + rng.uniform(-0.2, 0.2, X.shape)
    Y = Y + rng.uniform(-0.2, 0.2, Y.shape)
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    p00 = (i * n + j).ravel()
    faces = np.concatenate([np.column_stack([p00, p00 + n, p00 + n + 1]),
                            np.column_stack([p00, p00 + n + 1, p00 + 1])])
    pts = np.column_stack([X.ravel(), Y.ravel(), 0.2 * X.ravel() - 0.1 * Y.ravel() + 3.0])
    return TriMesh(pts, faces)


def test_voxel_sheets_have_what_breaks_extrusion(voxel):
    """The test data look like a segmentation: slivers, rims turned beyond the trimming
    angle, and terraces (vertical error to the smooth plateau up to about half a voxel)."""
    tibia = _part(voxel["tibia"], voxel["tibia"].points[:, 0] < 0)
    edges = np.linalg.norm(tibia.points[tibia.faces[:, [1, 2, 0]]]
                           - tibia.points[tibia.faces], axis=2)
    assert edges.min() < 0.01 * SPACING_MM                                # slivers
    assert np.degrees(np.arccos(tibia.face_normals[:, 2].min())) > 80.0      # curled rims
    c = CONDYLES["medial"]
    err = tibia.points[:, 2] - plateau_height(c, tibia.points[:, 0], tibia.points[:, 1])
    centre = (np.abs(tibia.points[:, 0] - c.patch_centre[0]) < 10) \
        & (np.abs(tibia.points[:, 1] - c.patch_centre[1]) < 10)
    assert 0.3 * SPACING_MM < np.abs(err[centre]).max() < 0.6 * SPACING_MM   # terraces


@pytest.mark.parametrize("size", [2.0, 1.0])
def test_prepared_voxel_sheet_quality_and_distance(voxel, size):
    tibia = _part(voxel["tibia"], voxel["tibia"].points[:, 0] < 0)
    prepared = prepare_sheet(tibia, size)
    mesh = prepared.mesh
    # equilateral in the plane; in space tilted by the plateau's slopes: bounded angles and
    # edges no shorter than the element size (no sliver)
    uv = prepared.plane(mesh.points)
    flat = np.linalg.norm(uv[mesh.faces[:, [1, 2, 0]]] - uv[mesh.faces], axis=2)
    assert np.allclose(flat, size, rtol=1e-9)
    edges = np.linalg.norm(mesh.points[mesh.faces[:, [1, 2, 0]]] - mesh.points[mesh.faces],
                           axis=2)
    assert edges.min() >= size * (1 - 1e-9)
    assert _angles(mesh).min() > 50.0
    # facing: every normal on the axis's side, within the trimming angle
    assert (mesh.face_normals @ prepared.axis).min() > np.cos(np.radians(MAX_TILT_DEG))
    assert prepared.axis[2] > 0.99
    # the terraces smoothed: within the voxels' half step of the smooth plateau itself
    # (measured 0.24 mm at 0.6 mm voxels: the voxel sheet's own error there, a flat
    # terrace on the bump's top, is longer than the smoothing length)
    c = CONDYLES["medial"]
    err = mesh.points[:, 2] - plateau_height(c, mesh.points[:, 0], mesh.points[:, 1])
    centre = (np.abs(mesh.points[:, 0] - c.patch_centre[0]) < 10) \
        & (np.abs(mesh.points[:, 1] - c.patch_centre[1]) < 10)
    assert np.abs(err[centre]).max() < 0.5 * SPACING_MM
    # covers the sheet's outline to about a lattice step: 26 × 26 mm patch
    lo, hi = mesh.points[:, :2].min(axis=0), mesh.points[:, :2].max(axis=0)
    assert np.all(hi - lo > 26.0 - 2.5 * size) and np.all(hi - lo < 26.0 + SPACING_MM)


def test_a_plane_is_kept_exactly():
    """The smoothing penalises curvature only: a jittered plane, tilted from the axis (so
    that its height over the lattice is not constant), comes out on the plane."""
    sheet = _plane_sheet()
    prepared = prepare_sheet(sheet, 1.0, smooth_mm=3.0, axis=np.array([0.0, 0.0, 1.0]))
    p = prepared.mesh.points
    assert np.abs(p[:, 2] - (0.2 * p[:, 0] - 0.1 * p[:, 1] + 3.0)).max() < 1e-6
    # the lattice covers the 20 x 20 mm square to about one element along its edges
    assert 400 - 4 * 20 < prepared.mesh.area / np.sqrt(1 + 0.2 ** 2 + 0.1 ** 2) < 400


def test_the_same_sheet_prepared_again_reads_its_heights_from_the_cache():
    """`fecheck knee import` and `fecheck fe` prepare the same sheets: a copy of a
    prepared sheet reads the quadric heights back (one cache hit, no build, the same
    points); another smoothing length fits anew."""
    sheet = _plane_sheet(seed=7)
    first = prepare_sheet(sheet, 1.0, smooth_mm=3.0)
    hits, builds = STATS.hits, STATS.builds
    again = prepare_sheet(TriMesh(sheet.points.copy(), sheet.faces.copy()), 1.0, smooth_mm=3.0)
    assert (STATS.hits, STATS.builds) == (hits + 1, builds)
    assert np.array_equal(again.mesh.points, first.mesh.points)
    prepare_sheet(sheet, 1.0, smooth_mm=2.0)
    assert (STATS.hits, STATS.builds) == (hits + 1, builds + 1)


def test_a_quadric_is_kept_exactly():
    """The heights are local quadric fits: a jittered sheet on a quadric (curvatures
    0.02 to -0.04 /mm, a twist, a slope) comes out on the quadric at every lattice
    vertex, edges included (a smoothing that penalises curvature flattens it)."""
    sheet = _plane_sheet()
    x, y = sheet.points[:, 0] - 10.0, sheet.points[:, 1] - 10.0

    def quadric(x, y):
        return 0.01 * x * x + 0.005 * x * y - 0.02 * y * y + 0.2 * x + 3.0

    sheet = TriMesh(np.column_stack([sheet.points[:, :2], quadric(x, y)]), sheet.faces)
    # at 2 mm the samples are the sheet's vertices (no split), all on the quadric
    p = prepare_sheet(sheet, 2.0, smooth_mm=3.0, axis=np.array([0.0, 0.0, 1.0])).mesh.points
    assert np.abs(p[:, 2] - quadric(p[:, 0] - 10.0, p[:, 1] - 10.0)).max() < 1e-9


def test_the_plateau_bump_is_kept_at_the_default_smoothing():
    """The smooth plateau (its 0.4 mm bump of 12-14 mm wavelength on a dish) prepared at
    the default: within 0.05 mm of the plateau (an eighth of the bump; the quadric fits
    over 4 mm miss the bump's fourth-order terms by about 0.03 mm). The first smoothing
    (a spline penalising curvature over 2 mm) left 0.2 mm and 30 % of the FE p_max."""
    c = CONDYLES["medial"]
    mesh = prepare_sheet(tibia_compartment("medial"), 1.0).mesh
    err = mesh.points[:, 2] - plateau_height(c, mesh.points[:, 0], mesh.points[:, 1])
    assert np.abs(err).max() < 0.05


def test_curled_rims_are_trimmed():
    """A flat sheet with a wall curling down along one edge: the wall's faces (90° from
    the axis) go, the flat part stays whole."""
    flat = _plane_sheet()
    flat = TriMesh(np.column_stack([flat.points[:, :2], np.zeros(flat.n_points)]), flat.faces)
    n = 30
    edge = np.flatnonzero(flat.points[:, 0] > 19.5)             # the last grid column
    edge = edge[np.argsort(flat.points[edge, 1])]
    wall = np.concatenate([flat.points[edge] + [0.0, 0.0, -dz] for dz in (1.0, 2.0)])
    pts = np.concatenate([flat.points, wall])
    a, b, c = edge[:-1], np.arange(n - 1) + flat.n_points, np.arange(1, n) + flat.n_points
    strip = [np.column_stack([a, c, edge[1:]]), np.column_stack([a, b, c])]
    b2, c2 = b + n, c + n
    strip += [np.column_stack([b, c2, c]), np.column_stack([b, b2, c2])]
    sheet = TriMesh(pts, np.concatenate([flat.faces, *strip]))
    assert np.degrees(np.arccos(sheet.face_normals[flat.n_faces:, 2])).min() > 80
    prepared = prepare_sheet(sheet, 1.0, axis=np.array([0.0, 0.0, 1.0]))
    assert prepared.trimmed_faces == 4 * (n - 1)
    assert np.abs(prepared.mesh.points[:, 2]).max() < 1e-6
    assert prepared.mesh.points[:, 0].max() < 20.3


def test_interpolation_is_exact_for_linear_fields():
    sheet = _plane_sheet()
    prepared = prepare_sheet(sheet, 1.5)
    rng = np.random.default_rng(3)
    query = np.column_stack([rng.uniform(3, 17, (200, 2)), np.zeros(200)])
    T = prepared.transfer(query)

    def field(p):                                 # linear in the plane's coordinates
        return prepared.plane(p) @ [2.0, -0.5] + 1.0

    assert np.allclose(T @ field(prepared.mesh.points), field(query), atol=1e-9)
    # and from the raw sheet's vertices (its own projection)
    back = plane_interpolation(prepared.plane(sheet.points), sheet.faces,
                               prepared.plane(prepared.mesh.points))
    xy = prepared.mesh.points[:, :2]
    inside = (xy.min(axis=1) > 1) & (xy.max(axis=1) < 19)
    assert np.allclose((back @ field(sheet.points))[inside],
                       field(prepared.mesh.points)[inside], atol=1e-9)


def test_bad_inputs_are_refused():
    sheet = _plane_sheet()
    with pytest.raises(FecheckError, match="element size of the prepared medial sheet"):
        prepare_sheet(sheet, 0.0, name="medial sheet")
    with pytest.raises(FecheckError, match="narrower than one element"):
        prepare_sheet(sheet, 50.0)
    with pytest.raises(FecheckError, match="no faces within 65 deg"):
        prepare_sheet(sheet, 1.0, axis=np.array([1.0, 0.0, 0.0]))


def test_a_coarse_sheet_on_a_fine_lattice_has_no_spikes():
    """A sheet of 2 mm faces prepared at 0.5 mm: the faces are sampled finer than the
    lattice (split at their midpoints), so every lattice vertex is held by data and the
    heights stay within the sheet's own piecewise-linear error (κ s² / 8 ≈ 0.1 mm for the
    bump's curvature κ ≈ 0.2 /mm and s = 2 mm) of the plateau."""
    c = CONDYLES["medial"]
    sheet = tibia_compartment("medial", spacing=2.0)
    mesh = prepare_sheet(sheet, 0.5, smooth_mm=0.5).mesh
    err = mesh.points[:, 2] - plateau_height(c, mesh.points[:, 0], mesh.points[:, 1])
    assert np.abs(err).max() < 0.2
