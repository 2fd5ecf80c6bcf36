"""Cartilage thickness from the distance to bone, and the per-face elastic foundation."""

import numpy as np
import pytest
from conftest import require_knee_data

from fecheck import laws
from fecheck.contact.analytic import Plane
from fecheck.contact.pair import ContactPair
from fecheck.errors import FecheckError
from fecheck.laws import layer as thickness
from geometry.mesh import TriMesh


def _grid_sheet(n: int, half: float, height) -> TriMesh:
    """An (n x n)-cell sheet over [-half, half]² at z = height(x, y), normals up (mm)."""
    x = np.linspace(-half, half, n + 1)
    X, Y = np.meshgrid(x, x, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel(), height(X.ravel(), Y.ravel())])
    i = np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]
    a, b, c, d = i, i + (n + 1), i + (n + 2), i + 1
    faces = np.vstack([np.column_stack([a.ravel(), b.ravel(), c.ravel()]),
                       np.column_stack([a.ravel(), c.ravel(), d.ravel()])])
    return TriMesh(pts, faces)


def _bone_box(half: float) -> TriMesh:
    """A closed box with its top face at z = 0 (the bone), outward normals."""
    import trimesh

    box = trimesh.creation.box(extents=(2 * half, 2 * half, 10.0))
    box.apply_translation((0, 0, -5.0))
    return TriMesh(box.vertices, box.faces)


def test_flat_sheet_over_bone_has_its_height_as_thickness():
    sheet = _grid_sheet(8, 10.0, lambda x, y: np.full_like(x, 2.5))
    h = thickness.bone_distance_thickness(sheet, _bone_box(20.0))
    np.testing.assert_allclose(h, 2.5, atol=1e-9)   # ray along -n hits the top at z = 0


def test_tilted_sheet_thickness_is_measured_along_its_normal():
    # z = 3 + 0.2x over the plane z = 0: along -n the distance is z·√(1 + 0.2²)
    sheet = _grid_sheet(6, 8.0, lambda x, y: 3.0 + 0.2 * x)
    h = thickness.bone_distance_thickness(sheet, _bone_box(30.0))
    expected = sheet.face_centroids[:, 2] * np.sqrt(1 + 0.2**2)
    np.testing.assert_allclose(h, expected, rtol=1e-9)


def test_sheet_overhanging_the_bone_falls_back_to_closest_distance():
    sheet = _grid_sheet(4, 10.0, lambda x, y: np.full_like(x, 1.0))
    bone = _bone_box(5.0)                         # top face covers |x|, |y| <= 5 only
    h = thickness.bone_distance_thickness(sheet, bone)
    c = sheet.face_centroids
    over = np.all(np.abs(c[:, :2]) < 5.0, axis=1)
    np.testing.assert_allclose(h[over], 1.0, atol=1e-9)
    gap = np.linalg.norm(np.maximum(np.abs(c[~over, :2]) - 5.0, 0.0), axis=1)
    np.testing.assert_allclose(h[~over], np.hypot(gap, 1.0), rtol=1e-9)


def test_thickness_is_floored_and_inputs_are_checked():
    sheet = _grid_sheet(2, 5.0, lambda x, y: np.full_like(x, 0.1))
    assert np.all(thickness.bone_distance_thickness(sheet, _bone_box(10.0)) == 0.5)
    with pytest.raises(FecheckError, match="positive"):
        thickness.uniform_thickness(sheet, 0.0)
    with pytest.raises(FecheckError, match="finite and positive"):
        thickness.face_ef_stiffness(np.array([1.0, np.nan]), 20.0, 0.3)


def test_two_layers_in_series_add_their_compliances():
    k1, k2 = (thickness.face_ef_stiffness(np.array([h]), 20.0, 0.3)[0] for h in (1.4, 2.1))
    k = thickness.face_ef_stiffness(np.array([1.4 + 2.1]), 20.0, 0.3)[0]
    assert k == pytest.approx(1.0 / (1.0 / k1 + 1.0 / k2), rel=1e-12)
    assert thickness.face_ef_stiffness(np.array([6.0]), 20.0, 0.3)[0] == pytest.approx(
        laws.ef_stiffness(20.0, 0.3, 6.0), rel=1e-12)


def test_per_face_foundation_integrates_each_face_with_its_own_stiffness():
    # flat sheet 1 mm under the plane z = 1 (master solid below it): p = k_f·1 mm on every
    # face, so F_z = Σ k_f·A_f exactly (linear depth, clipped faces whole)
    sheet = _grid_sheet(6, 6.0, lambda x, y: np.full_like(x, 0.0))
    pair = ContactPair(sheet, Plane([0.0, 0.0, 1.0], [0.0, 0.0, 1.0]))
    eye, zero = np.eye(3), np.zeros(3)
    surface = pair.evaluate((eye, zero), (eye, zero))
    k = np.where(sheet.face_centroids[:, 0] < 0, 2.0, 5.0)
    res = thickness.face_elastic_foundation(k)(surface)
    assert res.force[2] == pytest.approx((k * sheet.face_areas).sum(), rel=1e-12)
    assert res.max_pressure == pytest.approx(5.0)
    uniform = thickness.face_elastic_foundation(np.full(sheet.n_faces, 4.0))(surface)
    ref = laws.elastic_foundation(surface, 4.0)
    np.testing.assert_allclose(uniform.force, ref.force, rtol=1e-12)
    np.testing.assert_allclose(uniform.tangent, ref.tangent, rtol=1e-12, atol=1e-12)


def test_scanned_cartilage_thickness_matches_the_data_set_measurement():
    from fecheck.scene import lenhart

    require_knee_data()
    # the tibial cartilage as its two packaged halves (the whole sheet's faces)
    for names, bone, median in ((("femur_cartilage",), "femur_bone", 2.07),
                                (("tibia_cartilage_medial", "tibia_cartilage_lateral"),
                                 "tibia_bone", 1.40)):
        h = np.concatenate([thickness.bone_distance_thickness(
            lenhart.mesh(name), lenhart.mesh(bone), min_mm=1e-6) for name in names])
        # README: per-vertex ray casting; ours per face centroid: medians agree to 0.1 mm
        assert np.median(h) == pytest.approx(median, abs=0.1)
