"""Plateau boxes, flat disc patches and polynomial plateaus; spherical caps."""

import numpy as np
import pytest

from fecheck.errors import FecheckError
from geometry.cap import spherical_cap
from geometry.checks import mesh_report
from geometry.fits import fit_plane, plane_coefficients
from geometry.plateau import plane_patch, plateau_box, polynomial_patch, polynomial_plateau
from geometry.polynomial import Polynomial2D

MEDIAL_CONTACT = np.array([-20.4, 12.8, -8.7])  # thesis Table B.1


@pytest.mark.parametrize("lam, gam", [(0.0, 0.0), (-0.36, -5.93), (-0.34, 9.82), (12.0, -20.0)])
def test_box_top_normal_matches_plane_angle_formula(lam, gam):
    box = plateau_box(MEDIAL_CONTACT, 80, 60, 10, sagittal_deg=lam, frontal_deg=gam)
    a, b = plane_coefficients(lam, gam)
    expected = np.array([-a, -b, 1.0]) / np.sqrt(1 + a * a + b * b)
    top = box.regions["top"]
    np.testing.assert_allclose(box.face_normals[top], np.tile(expected, (len(top), 1)),
                               atol=1e-12)
    # the top plane passes through the centre, and a plane fit of its corners gives λ, γ
    corners = box.points[np.unique(box.faces[top])]
    np.testing.assert_allclose((corners - MEDIAL_CONTACT) @ expected, 0.0, atol=1e-12)
    fit = fit_plane(corners, outlier_sigma=None)
    assert (fit.sagittal_deg, fit.frontal_deg) == pytest.approx((lam, gam), abs=1e-9)
    assert box.n_faces == 12
    assert box.signed_volume == pytest.approx(80 * 60 * 10, rel=1e-12)


def test_refined_box_is_closed_with_exact_volume():
    box = plateau_box((0, 0, 0), 40, 30, 5, frontal_deg=10, mesh_size=4)
    r = mesh_report(box)
    assert (r.watertight, r.winding_consistent, r.convex, r.euler) == (True, True, True, 2)
    assert r.volume_mm3 == pytest.approx(40 * 30 * 5, rel=1e-12)
    assert len(box.regions["top"]) > 2 * (40 // 4) * (30 // 4)


def test_plane_patch_is_a_refined_disc_on_its_plane():
    normal = np.array([0.1, -0.2, 1.0])
    n = normal / np.linalg.norm(normal)
    refine_at = MEDIAL_CONTACT + np.array([3.0, -2.0, 0.0])
    m = plane_patch(MEDIAL_CONTACT, normal, radius=20, size=2, refine_point=refine_at,
                    refine_size=0.25, refine_radius=3)
    d = m.points - MEDIAL_CONTACT
    np.testing.assert_allclose(d @ n, 0.0, atol=1e-10)
    assert np.linalg.norm(d, axis=1).max() <= 20 * (1 + 1e-9)
    np.testing.assert_allclose(m.face_normals, np.tile(n, (m.n_faces, 1)), atol=1e-9)
    # an inscribed polygon with ≤2 mm chords on r = 20 loses < 1 - sinc-ish ≈ 0.2% of πr²
    assert m.area == pytest.approx(np.pi * 400, rel=3e-3)
    # edge lengths: ≈ refine_size near the point, ≈ size far from it
    foot = refine_at - ((refine_at - MEDIAL_CONTACT) @ n) * n
    dist = np.linalg.norm(m.face_centroids - foot, axis=1)
    edge = np.sqrt(4 * m.face_areas / np.sqrt(3))  # equilateral edge of the same area
    assert 0.15 < np.median(edge[dist < 2.5]) < 0.4
    assert 1.4 < np.median(edge[dist > 12]) < 2.6


@pytest.mark.parametrize("footprint", ["rectangle", "ellipse"])
def test_polynomial_patch_lies_on_the_polynomial_with_normals_up(footprint):
    poly = Polynomial2D(np.array([[-8.0, 0.01, 0.002], [0.05, 0.001, 0.0], [0.003, 0.0, 0.0]]))
    m = polynomial_patch(poly, footprint=footprint, center_xy=(-20, 12), half_x=12,
                         half_y=18, size=1.5)
    np.testing.assert_allclose(m.points[:, 2], poly.value(m.points[:, 0], m.points[:, 1]),
                               atol=1e-12)
    assert np.all(m.face_normals[:, 2] > 0)
    u, v = (m.points[:, 0] + 20) / 12, (m.points[:, 1] - 12) / 18
    inside = np.maximum(abs(u), abs(v)) if footprint == "rectangle" else np.hypot(u, v)
    assert inside.max() <= 1 + 1e-9
    e = m.triangles[:, 1:, :2] - m.triangles[:, :1, :2]
    projected = 0.5 * np.abs(e[:, 0, 0] * e[:, 1, 1] - e[:, 0, 1] * e[:, 1, 0]).sum()
    exact = 4 * 12 * 18 if footprint == "rectangle" else np.pi * 12 * 18
    assert projected == pytest.approx(exact, rel=2e-3)


def test_polynomial_plateau_is_closed_with_the_integral_volume():
    # z = -8 + 0.004 x² + 0.006 y² + 0.01 x over [-15, 15] x [-10, 10] (centre (0, 0))
    c = np.zeros((3, 3))
    c[0, 0], c[2, 0], c[0, 2], c[1, 0] = -8.0, 0.004, 0.006, 0.01
    poly = Polynomial2D(c)
    m = polynomial_plateau(poly, half_x=15, half_y=10, thickness=4, size=1.0)
    r = mesh_report(m)
    assert (r.watertight, r.winding_consistent, r.euler, r.components) == (True, True, 2, 1)
    zb = m.points[:, 2].min()
    assert zb == pytest.approx(m.points[m.faces[m.regions["top"]], 2].min() - 4, abs=1e-12)
    exact = 600 * (-8 - zb) + 0.004 * 20 * 2 * 15**3 / 3 + 0.006 * 30 * 2 * 10**3 / 3
    # linear interpolation of f overestimates by ≤ h²/8·(|f_xx| + |f_yy|) per unit area
    bound = 1.0**2 / 8 * (0.008 + 0.012) * 600 * 2
    assert abs(r.volume_mm3 - exact) <= bound


def test_spherical_cap_open_and_closed():
    c = np.array([-20.4, 12.8, 16.8])
    R, cut_height = 25.5, 5.0
    kw = {"cut_point": c + [0, 0, cut_height], "cut_normal": (0, 0, 1)}
    open_cap = spherical_cap(R, 5, c, **kw)
    r = mesh_report(open_cap)
    assert (r.euler, r.watertight, r.winding_consistent, r.convex) == (1, False, True, False)
    assert open_cap.points[:, 2].max() <= c[2] + cut_height + 1e-9
    assert np.isclose(open_cap.points[:, 2], c[2] + cut_height).sum() == r.boundary_edges
    closed = spherical_cap(R, 5, c, closed=True, **kw)
    rc = mesh_report(closed)
    assert (rc.euler, rc.watertight, rc.winding_consistent, rc.convex) == (2, True, True, True)
    cut_faces = closed.regions["cut"]
    np.testing.assert_allclose(closed.face_normals[cut_faces][:, 2], 1.0, atol=1e-12)
    h = R + cut_height  # kept cap height
    exact = np.pi * h**2 * (3 * R - h) / 3
    # level 5 icosphere volume error is -0.054%; the cut adds chord error of the same order
    assert rc.volume_mm3 == pytest.approx(exact, rel=1.5e-3)


def test_plateau_builders_reject_bad_input():
    with pytest.raises(FecheckError):
        plateau_box((0, 0, 0), -1, 10, 10)
    with pytest.raises(FecheckError):
        plateau_box((0, 0, 0), 10, 10, 10, frontal_deg=95)
    with pytest.raises(FecheckError):
        plane_patch((0, 0, 0), (0, 0, 0), radius=5, size=1)
    with pytest.raises(FecheckError):
        plane_patch((0, 0, 0), (0, 0, 1), radius=5, size=1, refine_point=(0, 0, 0))
    with pytest.raises(FecheckError):
        spherical_cap(10, 2, cut_point=(0, 0, -11), cut_normal=(0, 0, 1))  # keeps z <= -11
