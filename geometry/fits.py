"""Least-squares surface fits of thesis §2.2 with their mean errors (mm).

- `fit_sphere`: femoral condyle as a sphere, mean error ME = mean |‖p - c‖ - R| (eq. 2.1).
- `fit_plane`: tibial condyle as z = ax + by + c (eq. 2.4-2.5) with iterative statistical
  outlier removal, and its sagittal λ / frontal γ angles (App. C.2, convention below).
- `fit_polynomial_surface`: z = Σ a_ij x^i y^j (eq. 2.6).
- `fit_spherical_polynomial`: r = Σ a_ij θ^i φ^j about a centre (eq. 2.2, App. C.1 angles).

Angle convention (γ frontal, λ sagittal, degrees) for the plane z = ax + by + c:
γ = atan(a), λ = atan(b / √(1 + a²)); conversely a = tan γ, b = tan λ / cos γ. γ > 0
when the plane rises towards +x (right), λ > 0 when it rises towards +y (anterior). The
plane's upward unit normal is (-a, -b, 1)/√(1 + a² + b²) = Ry(-γ)·Rx(λ)·e_z. These are
the magnitudes of the thesis's App. C.2 rotations (θ_y = -atan a, θ_x = atan(b/√(1+a²))),
with the signs of its Table 2.1 (medial γ < 0, lateral γ > 0 for z = -0.12x ... and
z = 0.19x ...).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geometry.errors import FecheckError
from geometry.polynomial import Polynomial2D


@dataclass(frozen=True)
class SphereFit:
    center: np.ndarray
    radius_mm: float
    mean_error_mm: float


@dataclass(frozen=True)
class PlaneFit:
    a: float
    b: float
    c: float
    sagittal_deg: float
    frontal_deg: float
    mean_error_mm: float
    inlier_mask: np.ndarray
    transverse_mean_error_mm: float


@dataclass(frozen=True)
class PolyFit:
    poly: Polynomial2D
    mean_error_mm: float
    rank: int
    rank_deficient: bool


@dataclass(frozen=True)
class SphericalPolyFit:
    coeffs: np.ndarray
    center: np.ndarray
    mean_error_mm: float
    rank: int
    rank_deficient: bool

    def radius(self, theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
        """r = f(θ, φ), mm, angles in radians (App. C.1)."""
        return np.polynomial.polynomial.polyval2d(theta, phi, self.coeffs)


def _points(points: np.ndarray, minimum: int) -> np.ndarray:
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3:
        raise FecheckError(f"fit points must be an (n, 3) array in mm, got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise FecheckError("fit points contain NaN or infinite coordinates")
    if len(p) < minimum:
        raise FecheckError(f"this fit needs at least {minimum} points, got {len(p)}")
    return p


def plane_angles(a: float, b: float) -> tuple[float, float]:
    """(sagittal λ, frontal γ) in degrees of the plane z = ax + by + c (module docstring)."""
    return float(np.degrees(np.arctan(b / np.sqrt(1.0 + a * a)))), float(np.degrees(np.arctan(a)))


def plane_coefficients(sagittal_deg: float, frontal_deg: float) -> tuple[float, float]:
    """(a, b) of z = ax + by + c from λ, γ in degrees (inverse of `plane_angles`)."""
    gamma, lam = np.radians(frontal_deg), np.radians(sagittal_deg)
    return float(np.tan(gamma)), float(np.tan(lam) / np.cos(gamma))


def _weights(weights: np.ndarray | None, n: int) -> np.ndarray:
    if weights is None:
        return np.ones(n)
    w = np.asarray(weights, dtype=float)
    if w.shape != (n,) or not np.all(np.isfinite(w)) or np.any(w < 0) or not w.sum() > 0:
        raise FecheckError(f"weights must be {n} finite non-negative numbers, not all zero")
    return w


def fit_sphere(points: np.ndarray, *, weights: np.ndarray | None = None,
               refine: bool = True) -> SphereFit:
    """Best sphere through `points` (mm): algebraic LSQ, then geometric Gauss-Newton.

    The geometric step minimises Σ w_i (‖p_i - c‖ - R)² (thesis §2.2.1; `weights`, e.g.
    face areas for face centroids, default 1); the reported mean error is eq. 2.1,
    ME = (1/n) Σ |‖p_i - c‖ - R| (unweighted).
    """
    p = _points(points, 4)
    sw = np.sqrt(_weights(weights, len(p)))
    shift = p.mean(axis=0)
    q = p - shift
    A = np.column_stack([2.0 * q, np.ones(len(q))])
    sol, *_ = np.linalg.lstsq(A * sw[:, None], (q * q).sum(axis=1) * sw, rcond=None)
    c, r2 = sol[:3], sol[3] + sol[:3] @ sol[:3]
    if r2 <= 0 or not np.isfinite(r2):
        raise FecheckError("sphere fit failed: the points are (nearly) coplanar")
    r = np.sqrt(r2)
    if refine:
        from scipy.optimize import least_squares

        def residual(x: np.ndarray) -> np.ndarray:
            return sw * (np.linalg.norm(q - x[:3], axis=1) - x[3])

        def jacobian(x: np.ndarray) -> np.ndarray:
            d = q - x[:3]
            dist = np.linalg.norm(d, axis=1, keepdims=True)
            return sw[:, None] * np.column_stack([-d / dist, -np.ones(len(q))])

        res = least_squares(residual, np.append(c, r), jac=jacobian, method="lm")
        c, r = res.x[:3], float(res.x[3])
    err = np.abs(np.linalg.norm(q - c, axis=1) - r)
    return SphereFit(center=c + shift, radius_mm=float(r), mean_error_mm=float(err.mean()))


def fit_plane(points: np.ndarray, *, outlier_sigma: float | None = 2.0,
              weights: np.ndarray | None = None, max_iterations: int = 50) -> PlaneFit:
    """Fit z = ax + by + c (eq. 2.5, vertical residuals) with statistical outlier removal.

    `weights` (e.g. face areas for face centroids) weight the squared residuals.

    Iterates: fit on the inliers, then keep the points whose residual lies within
    ``outlier_sigma``·σ̂ of the median residual, until the inlier set stops changing.
    σ̂ = 1.4826·MAD of all points' residuals, a standard deviation estimate that outliers
    do not inflate and that does not shrink as points are dropped (the plain standard
    deviation of the inliers does, so iterating with it erodes good points: on the
    scanned tibial plateaus it kept only 31-48% of the faces). ``outlier_sigma=None``
    fits all points once. Mean errors are the
    mean |z - (ax + by + c)| over the inliers, and over the same inliers for the
    transverse plane z = mean(z) (thesis Table 2.1 "Tran").
    """
    p = _points(points, 3)
    if outlier_sigma is not None and not outlier_sigma > 0:
        raise FecheckError(f"outlier_sigma must be positive or None, got {outlier_sigma}")
    sw = np.sqrt(_weights(weights, len(p)))
    A = np.column_stack([p[:, 0], p[:, 1], np.ones(len(p))])
    inliers = np.ones(len(p), dtype=bool)
    for _ in range(max_iterations):
        coef, _, rank, _ = np.linalg.lstsq(A[inliers] * sw[inliers, None],
                                           p[inliers, 2] * sw[inliers], rcond=None)
        if rank < 3:
            raise FecheckError("plane fit failed: the points are collinear in x-y")
        if outlier_sigma is None:
            break
        res = p[:, 2] - A @ coef
        centre = np.median(res)
        sigma_hat = 1.4826 * np.median(np.abs(res - centre))
        new = np.abs(res - centre) <= outlier_sigma * sigma_hat
        if np.array_equal(new, inliers) or new.sum() < 3:
            break
        inliers = new
    a, b, c = (float(v) for v in coef)
    res = p[inliers, 2] - A[inliers] @ coef
    lam, gam = plane_angles(a, b)
    z_in = p[inliers, 2]
    return PlaneFit(a, b, c, lam, gam, float(np.abs(res).mean()), inliers,
                    float(np.abs(z_in - z_in.mean()).mean()))


def _monomial_powers(shift: float, scale: float, degree: int) -> np.ndarray:
    """M[i, k]: coefficient of x^k in ((x - shift)/scale)^i."""
    P = np.polynomial.polynomial
    M = np.zeros((degree + 1, degree + 1))
    for i in range(degree + 1):
        M[i, : i + 1] = P.polypow([-shift / scale, 1.0 / scale], i)
    return M


def fit_polynomial_surface(points: np.ndarray, deg_x: int, deg_y: int) -> PolyFit:
    """Least-squares z = Σ_{i≤deg_x, j≤deg_y} a_ij x^i y^j (eq. 2.6), coefficients in mm.

    Solved in centred, scaled coordinates (x - x̄)/s_x for conditioning, then expanded
    back to the mm frame. `rank` is the rank of the scaled design matrix; the fit is
    rank deficient when it is below (deg_x + 1)(deg_y + 1). Mean error: mean |z - f|.
    """
    if min(deg_x, deg_y) < 0:
        raise FecheckError(f"polynomial degrees must be >= 0, got ({deg_x}, {deg_y})")
    n_coef = (deg_x + 1) * (deg_y + 1)
    p = _points(points, 1)
    x0, y0 = p[:, 0].mean(), p[:, 1].mean()
    sx = max(np.abs(p[:, 0] - x0).max(), 1e-12)
    sy = max(np.abs(p[:, 1] - y0).max(), 1e-12)
    V = np.polynomial.polynomial.polyvander2d((p[:, 0] - x0) / sx, (p[:, 1] - y0) / sy,
                                              [deg_x, deg_y])
    d, _, rank, _ = np.linalg.lstsq(V, p[:, 2], rcond=None)
    D = d.reshape(deg_x + 1, deg_y + 1)
    coeffs = _monomial_powers(x0, sx, deg_x).T @ D @ _monomial_powers(y0, sy, deg_y)
    poly = Polynomial2D(coeffs)
    err = np.abs(p[:, 2] - V @ d)
    return PolyFit(poly, float(err.mean()), int(rank), bool(rank < n_coef))


def spherical_angles(points: np.ndarray, center: np.ndarray) -> tuple[np.ndarray, ...]:
    """(r mm, θ, φ radians) of points about `center` (App. C.1; θ = atan2(y, x))."""
    d = np.asarray(points, dtype=float) - np.asarray(center, dtype=float)
    r = np.linalg.norm(d, axis=1)
    if np.any(r == 0):
        raise FecheckError("a fit point coincides with the spherical centre")
    return r, np.arctan2(d[:, 1], d[:, 0]), np.arccos(np.clip(d[:, 2] / r, -1.0, 1.0))


def fit_spherical_polynomial(points: np.ndarray, center: np.ndarray, deg_theta: int,
                             deg_phi: int) -> SphericalPolyFit:
    """Least-squares r = Σ a_ij θ^i φ^j about `center` (mm; eq. 2.2, angles of App. C.1).

    θ = atan2(y, x) ∈ (-π, π], φ = arccos(z / r) ∈ [0, π], radians. Mean error (eq. 2.3)
    is mean |r - f(θ, φ)|.
    """
    if min(deg_theta, deg_phi) < 0:
        raise FecheckError(f"polynomial degrees must be >= 0, got ({deg_theta}, {deg_phi})")
    p = _points(points, 1)
    c = np.asarray(center, dtype=float)
    if c.shape != (3,) or not np.all(np.isfinite(c)):
        raise FecheckError(f"centre must be 3 finite coordinates in mm, got {center}")
    r, theta, phi = spherical_angles(p, c)
    V = np.polynomial.polynomial.polyvander2d(theta, phi, [deg_theta, deg_phi])
    norms = np.linalg.norm(V, axis=0)
    norms[norms == 0] = 1.0
    a, _, rank, _ = np.linalg.lstsq(V / norms, r, rcond=None)
    coeffs = (a / norms).reshape(deg_theta + 1, deg_phi + 1)
    err = np.abs(r - np.polynomial.polynomial.polyval2d(theta, phi, coeffs))
    return SphericalPolyFit(coeffs, c, float(err.mean()), int(rank),
                            bool(rank < (deg_theta + 1) * (deg_phi + 1)))
