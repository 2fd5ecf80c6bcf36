"""Closed-form references for a rigid sphere pressed on a cartilage layer, and Donahue 2002.

Units: mm, N, MPa. Each function returns `ContactMetrics` for the same load, so the FE,
elastic-foundation (EF) and Hertz answers sit side by side.
"""

from __future__ import annotations

import numpy as np

from fecheck.errors import FecheckError
from fecheck.fe.results import ContactMetrics


def _check(load_N: float, radius_mm: float, E_MPa: float, nu: float) -> None:
    for name, value in (("load", load_N), ("sphere radius", radius_mm), ("E", E_MPa)):
        if not np.isfinite(value) or value <= 0:
            raise FecheckError(f"{name} must be positive and finite, got {value}")
    if not (np.isfinite(nu) and -1.0 < nu < 0.5):
        raise FecheckError(f"Poisson's ratio must lie in (-1, 0.5), got {nu}")


def ef_stiffness(E_MPa: float, nu: float, thickness_mm: float) -> float:
    """Elastic-foundation stiffness k = (1-ν)E / ((1+ν)(1-2ν)h), N/mm³ (thesis eq. 4.3)."""
    return (1 - nu) * E_MPa / ((1 + nu) * (1 - 2 * nu) * thickness_mm)


def ef_sphere_on_plane(load_N: float, radius_mm: float, E_MPa: float, nu: float,
                       thickness_mm: float) -> ContactMetrics:
    """EF law for a sphere on a plane: F = kπd²(R - d/3), A = π(2Rd - d²), p_max = k d."""
    _check(load_N, radius_mm, E_MPa, nu)
    k = ef_stiffness(E_MPa, nu, thickness_mm)
    R = radius_mm
    d = np.sqrt(load_N / (k * np.pi * R))
    for _ in range(50):
        f = k * np.pi * d * d * (R - d / 3) - load_N
        d -= f / (k * np.pi * (2 * R * d - d * d))
        if abs(f) < 1e-12 * load_N:
            break
    if not 0 < d < R:
        raise FecheckError(f"EF depth {d:.3g} mm exceeds the sphere radius: load too large")
    area = np.pi * (2 * R * d - d * d)
    return ContactMetrics(max_pressure_MPa=float(k * d), mean_pressure_MPa=float(load_N / area),
                          area_mm2=float(area), depth_mm=float(d), force_N=float(load_N))


def hertz_sphere_on_plane(load_N: float, radius_mm: float, E_MPa: float,
                          nu: float) -> ContactMetrics:
    """Hertz, rigid sphere on an elastic half-space: E* = E/(1-ν²), a = (3FR/4E*)^(1/3)."""
    _check(load_N, radius_mm, E_MPa, nu)
    e_star = E_MPa / (1 - nu * nu)
    a = (3 * load_N * radius_mm / (4 * e_star)) ** (1 / 3)
    area = np.pi * a * a
    return ContactMetrics(max_pressure_MPa=float(3 * load_N / (2 * area)),
                          mean_pressure_MPa=float(load_N / area), area_mm2=float(area),
                          depth_mm=float(a * a / radius_mm), force_N=float(load_N))


#: Donahue et al. 2002 FE results at 800 N, 0° flexion (thesis Tables 5.7a, 5.8a), keyed
#: by compartment and element size (mm).
DONAHUE_2002: dict[str, dict[float, ContactMetrics]] = {
    "lateral": {
        5.0: ContactMetrics(3.05, 1.02, 365.0, float("nan"), 410.0),
        2.0: ContactMetrics(2.38, 0.88, 409.0, float("nan"), 404.0),
        1.0: ContactMetrics(2.36, 0.88, 415.0, float("nan"), 408.0),
    },
    "medial": {
        5.0: ContactMetrics(2.75, 1.16, 401.0, float("nan"), 415.0),
        2.0: ContactMetrics(2.51, 0.80, 483.0, float("nan"), 411.0),
        1.0: ContactMetrics(2.55, 0.78, 490.0, float("nan"), 409.0),
    },
}
