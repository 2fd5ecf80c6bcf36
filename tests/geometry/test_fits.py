"""Surface fits of thesis §2.2 recover known parameters within their statistical error.

Tolerances come from the noise: a least-squares estimate has covariance σ²(JᵀJ)⁻¹ at
the truth; we accept 5 standard errors (a false failure every ~2·10⁶ runs, fixed seeds).
"""

import json

import numpy as np
import pytest
from conftest import require_knee_data

from fecheck.errors import FecheckError
from geometry.fits import (
    fit_plane,
    fit_polynomial_surface,
    fit_sphere,
    fit_spherical_polynomial,
    plane_angles,
    plane_coefficients,
)
from geometry.io import load_mesh
from geometry.polynomial import Polynomial2D

MEAN_ABS = np.sqrt(2 / np.pi)  # E|N(0, σ²)| / σ


def _condyle_points(rng, center, radius, n, sigma):
    """Points on the lower cap (polar angle 110°-180°) of a sphere, radial noise σ."""
    phi = np.arccos(rng.uniform(-1, np.cos(np.radians(110)), n))
    theta = rng.uniform(-np.pi, np.pi, n)
    u = np.column_stack([np.sin(phi) * np.cos(theta), np.sin(phi) * np.sin(theta), np.cos(phi)])
    return center + u * (radius + sigma * rng.standard_normal(n))[:, None], u


def test_sphere_fit_recovers_centre_and_radius_within_5_standard_errors():
    rng = np.random.default_rng(1)
    c, R, sigma, n = np.array([-20.4, 12.8, 16.8]), 25.5, 0.2, 3000
    pts, u = _condyle_points(rng, c, R, n, sigma)
    fit = fit_sphere(pts)
    J = np.column_stack([-u, -np.ones(n)])  # ∂(‖p - c‖ - R)/∂(c, R) at the truth
    se = sigma * np.sqrt(np.diag(np.linalg.inv(J.T @ J)))
    assert np.all(np.abs(fit.center - c) < 5 * se[:3])
    assert abs(fit.radius_mm - R) < 5 * se[3]
    assert fit.mean_error_mm == pytest.approx(MEAN_ABS * sigma, rel=0.05)  # eq. 2.1


def test_sphere_fit_is_exact_without_noise():
    rng = np.random.default_rng(2)
    pts, _ = _condyle_points(rng, np.array([28.3, 12.8, 25.8]), 31.8, 200, 0.0)
    fit = fit_sphere(pts)
    np.testing.assert_allclose(fit.center, [28.3, 12.8, 25.8], atol=1e-9)
    assert fit.radius_mm == pytest.approx(31.8, abs=1e-9)
    assert fit.mean_error_mm < 1e-9


def test_plane_angles_follow_the_documented_convention():
    # thesis §2.2.2 medial plane z = -0.12x - 0.024y: γ = atan(-0.12), λ ≈ atan(-0.024)
    lam, gam = plane_angles(-0.12, -0.024)
    assert gam == pytest.approx(np.degrees(np.arctan(-0.12)))  # -6.84°
    assert lam == pytest.approx(np.degrees(np.arctan(-0.024 / np.sqrt(1 + 0.0144))))
    assert plane_coefficients(lam, gam) == pytest.approx((-0.12, -0.024))


def _plateau_points(rng, a, b, c, n, sigma, outlier_fraction):
    xy = rng.uniform([-35, -5], [-5, 30], (n, 2))
    z = a * xy[:, 0] + b * xy[:, 1] + c + sigma * rng.standard_normal(n)
    k = int(outlier_fraction * n)
    z[:k] += rng.uniform(4, 8, k)  # osteophyte-like outliers above the plateau
    return np.column_stack([xy, z]), xy


def test_plane_fit_with_outlier_removal_recovers_thesis_angles():
    rng = np.random.default_rng(3)
    a, b = plane_coefficients(-0.36, -5.93)  # thesis Table 2.1, medial, without outliers
    c, sigma, n = -8.7, 0.3, 2000
    pts, xy = _plateau_points(rng, a, b, c, n, sigma, 0.05)
    X = np.column_stack([xy, np.ones(n)])
    se = sigma * np.sqrt(np.diag(np.linalg.inv(X.T @ X)))
    fit = fit_plane(pts, outlier_sigma=2.0)
    assert not fit.inlier_mask[: int(0.05 * n)].any()  # every outlier removed
    assert np.all(np.abs(np.array([fit.a, fit.b, fit.c]) - [a, b, c]) < 5 * se)
    assert fit.frontal_deg == pytest.approx(-5.93, abs=5 * np.degrees(se[0]))
    assert fit.sagittal_deg == pytest.approx(-0.36, abs=5 * np.degrees(se[1]))
    # the transverse plane ignores the tilt, so its mean error is larger (Table 2.1)
    assert fit.transverse_mean_error_mm > 2 * fit.mean_error_mm
    # without removal the 5% outliers lift c by ≈ 0.05 · 6 mm = 0.3 mm ≫ 5 SE
    raw = fit_plane(pts, outlier_sigma=None)
    assert raw.c - c == pytest.approx(0.3, abs=0.1)
    assert raw.mean_error_mm > fit.mean_error_mm


def _poly_truth():
    c = np.zeros((4, 4))
    c[0, 0], c[1, 0], c[0, 1], c[2, 0], c[1, 1], c[0, 2] = -8.0, -0.1, -0.02, 0.004, 1e-3, 0.006
    c[3, 0], c[0, 3], c[2, 1] = 2e-5, -3e-5, 1e-5
    return c


def test_polynomial_fit_recovers_mm_frame_coefficients_off_centre():
    rng = np.random.default_rng(4)
    truth = _poly_truth()
    xy = rng.uniform([-35, -5], [-5, 30], (500, 2))  # far from the origin: ill-conditioned raw
    z = Polynomial2D(truth).value(xy[:, 0], xy[:, 1])
    fit = fit_polynomial_surface(np.column_stack([xy, z]), 3, 3)
    assert (fit.rank, fit.rank_deficient) == (16, False)
    np.testing.assert_allclose(fit.poly.coeffs, truth, rtol=1e-7, atol=1e-10)
    assert fit.mean_error_mm < 1e-9


def test_polynomial_fit_mean_error_matches_the_noise():
    rng = np.random.default_rng(5)
    sigma, n, p = 0.1, 4000, 16
    xy = rng.uniform([-35, -5], [-5, 30], (n, 2))
    z = Polynomial2D(_poly_truth()).value(xy[:, 0], xy[:, 1]) + sigma * rng.standard_normal(n)
    fit = fit_polynomial_surface(np.column_stack([xy, z]), 3, 3)
    # residual spread is σ·√(1 - p/n); its mean |·| is √(2/π) of that (5% sampling margin)
    assert fit.mean_error_mm == pytest.approx(MEAN_ABS * sigma * np.sqrt(1 - p / n), rel=0.05)


def test_polynomial_fit_flags_rank_deficiency():
    x = np.linspace(-10, 10, 50)
    pts = np.column_stack([x, np.full(50, 3.0), 0.1 * x])  # one line: no y information
    fit = fit_polynomial_surface(pts, 2, 2)
    assert fit.rank_deficient and fit.rank == 3


def test_spherical_polynomial_fit_recovers_radius_function():
    rng = np.random.default_rng(6)
    center = np.array([-20.4, 12.8, 16.8])
    coeffs = np.array([[25.0, 0.3, -0.1], [0.2, 0.05, 0.0], [-0.1, 0.0, 0.02]])
    theta = rng.uniform(-np.pi, np.pi, 800)
    phi = rng.uniform(np.radians(100), np.radians(175), 800)
    r = np.polynomial.polynomial.polyval2d(theta, phi, coeffs)
    pts = center + r[:, None] * np.column_stack(
        [np.sin(phi) * np.cos(theta), np.sin(phi) * np.sin(theta), np.cos(phi)])
    fit = fit_spherical_polynomial(pts, center, 2, 2)
    np.testing.assert_allclose(fit.coeffs, coeffs, atol=1e-8)
    assert not fit.rank_deficient and fit.mean_error_mm < 1e-8
    np.testing.assert_allclose(fit.radius(theta, phi), r, atol=1e-8)
    # degree (0, 0) is the sphere about the given centre: a = mean r
    zero = fit_spherical_polynomial(pts, center, 0, 0)
    assert zero.coeffs[0, 0] == pytest.approx(r.mean())
    assert zero.mean_error_mm == pytest.approx(np.abs(r - r.mean()).mean())


@pytest.mark.parametrize("bad", [np.zeros((3, 2)), np.full((10, 3), np.nan)])
def test_fits_reject_malformed_points(bad):
    for fit in (fit_sphere, fit_plane, lambda p: fit_polynomial_surface(p, 1, 1),
                lambda p: fit_spherical_polynomial(p, (0, 0, 0), 1, 1)):
        with pytest.raises(FecheckError):
            fit(bad)


def test_fits_reject_too_few_or_degenerate_points():
    with pytest.raises(FecheckError):
        fit_sphere(np.zeros((3, 3)))
    with pytest.raises(FecheckError):
        fit_plane(np.column_stack([np.arange(5.0), np.arange(5.0), np.ones(5)]))  # collinear


def test_integer_weights_equal_repeated_points():
    rng = np.random.default_rng(7)
    pts, _ = _condyle_points(rng, np.array([1.0, 2.0, 3.0]), 20.0, 300, 0.3)
    w = rng.integers(1, 4, len(pts))
    rep = np.repeat(pts, w, axis=0)
    a, b = fit_sphere(pts, weights=w), fit_sphere(rep)
    np.testing.assert_allclose(a.center, b.center, atol=1e-8)
    assert a.radius_mm == pytest.approx(b.radius_mm, abs=1e-8)
    pa, pb = fit_plane(pts, weights=w, outlier_sigma=None), fit_plane(rep, outlier_sigma=None)
    assert (pa.a, pa.b, pa.c) == pytest.approx((pb.a, pb.b, pb.c), abs=1e-10)


def test_scanned_knee_fits_match_the_data_set_reference():
    """Reproduce the fits shipped in fits.json (area-weighted, definitions in that file)."""
    knee = require_knee_data()
    ref = json.loads((knee / "fits.json").read_text())["fits"]
    for side in ("medial", "lateral"):
        m = load_mesh(knee / f"lenhart2015_R_tibia_cartilage_{side}.stl")
        fit = fit_plane(m.face_centroids, outlier_sigma=None, weights=m.face_areas)
        r = ref[f"tibial_plateau_{side}_plane"]
        # reference printed to 5 decimals (a, b) and 3 (c)
        assert (fit.a, fit.b, fit.c) == pytest.approx((r["a"], r["b"], r["c_mm"]), abs=6e-4)
        assert fit.frontal_deg == pytest.approx(r["coronal_tilt_deg_atan_a"], abs=0.01)
    femur = load_mesh(knee / "lenhart2015_R_femur_cartilage.stl")
    n, c = femur.face_normals, femur.face_centroids
    angle = np.degrees(np.arctan2(-n[:, 1], -n[:, 2]))
    posterior_distal = (angle > -10) & (angle < 100) & (np.abs(n[:, 0]) < 0.5) & (c[:, 1] < 15)
    for side, keep in (("medial", c[:, 0] < -8), ("lateral", c[:, 0] > 8)):
        k = posterior_distal & keep
        r = ref[f"femoral_condyle_{side}_sphere"]
        assert k.sum() == r["n_faces"]
        fit = fit_sphere(c[k], weights=femur.face_areas[k])
        np.testing.assert_allclose(fit.center, r["centre_mm"], atol=1e-3)
        assert fit.radius_mm == pytest.approx(r["radius_mm"], abs=6e-3)
