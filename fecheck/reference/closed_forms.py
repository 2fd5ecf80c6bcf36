"""Closed-form references, each written once: the EF cap, Hertz, Donahue 2002.

Units: mm, N, MPa. The elastic foundation (EF) of a sphere of radius R pressed by d into
a plane is the spherical cap: F = k·πd²(R − d/3) (k times the cap volume), contact area
π(2Rd − d²), p_max = k·d, with the column stiffness k = (1−ν)E/((1+ν)(1−2ν)h) (thesis
eq. 4.3). Hertz, rigid sphere on an elastic half-space: a = (3FR/(4E*))^(1/3),
p0 = 3F/(2πa²), d = a²/R, E* = E/(1−ν²).

>>> round(ef_sphere_plane(323.71, 25.5, column_stiffness(20.0, 0.3, 6.0))["area_mm2"], 1)
150.1
>>> round(hertz_contact_radius(323.71, 25.5, 20.0 / 0.91), 3)
6.555
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fecheck.errors import FecheckError


@dataclass(frozen=True)
class ContactMetrics:
    """Summary of one contact: pressures (MPa), area (mm²), indentation (mm), force (N).

    ``depth_mm`` is NaN when the source does not report it (Donahue 2002).
    """

    max_pressure_MPa: float
    mean_pressure_MPa: float
    area_mm2: float
    depth_mm: float
    force_N: float

    def as_dict(self) -> dict[str, float | None]:
        out = {"max_pressure_MPa": self.max_pressure_MPa,
               "mean_pressure_MPa": self.mean_pressure_MPa, "area_mm2": self.area_mm2,
               "depth_mm": self.depth_mm, "force_N": self.force_N}
        return {k: (None if not np.isfinite(v) else float(v)) for k, v in out.items()}



def _check(load_N: float, radius_mm: float, E_MPa: float, nu: float) -> None:
    for name, value in (("load", load_N), ("sphere radius", radius_mm), ("E", E_MPa)):
        if not np.isfinite(value) or value <= 0:
            raise FecheckError(f"{name} must be positive and finite, got {value}")
    if not (np.isfinite(nu) and -1.0 < nu < 0.5):
        raise FecheckError(f"Poisson's ratio must lie in (-1, 0.5), got {nu}")


def column_stiffness(E_MPa: float, nu: float, thickness_mm: float) -> float:
    """Elastic-foundation stiffness k = (1-ν)E / ((1+ν)(1-2ν)h), N/mm³ (thesis eq. 4.3)."""
    return (1 - nu) * E_MPa / ((1 + nu) * (1 - 2 * nu) * thickness_mm)


def ef_cap_depth(force_N: float, radius_mm: float, k_N_per_mm3: float) -> float:
    """Depth d (mm) at which the EF cap carries `force_N`: Newton on F = k·πd²(R − d/3).

    Returns ≥ R when the force exceeds the whole hemisphere's, k·π·(2/3)R³.
    """
    r, k = float(radius_mm), float(k_N_per_mm3)
    if force_N <= 0.0:
        return 0.0
    if force_N >= k * math.pi * r ** 3 * (2.0 / 3.0):
        return r
    d = (force_N / (k * math.pi * r)) ** 0.5
    for _ in range(50):
        step = (k * math.pi * d * d * (r - d / 3) - force_N) / (k * math.pi * (2 * r * d - d * d))
        d -= step
        if abs(step) <= 1e-15 * d:
            break
    return d


def ef_sphere_plane(force_N: float, radius_mm: float, k_N_per_mm3: float) -> dict[str, float]:
    """EF sphere on plane at a given force: max_depth_mm d, area_mm2 π(2Rd − d²),
    max_pressure_MPa k·d, mean_pressure_MPa F/A."""
    r, k = radius_mm, k_N_per_mm3
    d = ef_cap_depth(force_N, r, k)
    area = math.pi * (2 * r * d - d * d)
    return {"max_depth_mm": d, "area_mm2": area, "max_pressure_MPa": k * d,
            "mean_pressure_MPa": force_N / area if area > 0 else 0.0}


def ef_sphere_on_plane(load_N: float, radius_mm: float, E_MPa: float, nu: float,
                       thickness_mm: float) -> ContactMetrics:
    """`ef_sphere_plane` from the material (E MPa, ν, h mm), as `ContactMetrics`."""
    _check(load_N, radius_mm, E_MPa, nu)
    k = column_stiffness(E_MPa, nu, thickness_mm)
    d = ef_cap_depth(load_N, radius_mm, k)
    if not 0 < d < radius_mm:
        raise FecheckError(f"EF depth {d:.3g} mm exceeds the sphere radius: load too large")
    ref = ef_sphere_plane(load_N, radius_mm, k)
    return ContactMetrics(max_pressure_MPa=float(ref["max_pressure_MPa"]),
                          mean_pressure_MPa=float(ref["mean_pressure_MPa"]),
                          area_mm2=float(ref["area_mm2"]), depth_mm=float(d),
                          force_N=float(load_N))


# Hertz, sphere of radius R on an elastic half-space (Johnson 1985 §4.2; thesis eq.
# 4.4-4.8): every Hertz formula of fecheck is one of these.
def hertz_effective_modulus(E_MPa: float, nu: float, indenter_E_MPa: float = math.inf,
                            indenter_nu: float = 0.3) -> float:
    """Effective modulus E* (MPa): 1/E* = (1−ν²)/E + (1−ν_i²)/E_i (E_i = inf: rigid)."""
    inv = (1 - nu ** 2) / E_MPa
    if not math.isinf(indenter_E_MPa):
        inv += (1 - indenter_nu ** 2) / indenter_E_MPa
    return 1.0 / inv


def hertz_load(depth_mm: float, radius_mm: float, e_star_MPa: float) -> float:
    """Hertz force at approach d: P = 4/3·E*·√R·d^(3/2), N."""
    return 4.0 / 3.0 * e_star_MPa * math.sqrt(radius_mm) * depth_mm ** 1.5


def hertz_radius_at_depth(depth_mm: float, radius_mm: float) -> float:
    """Hertz contact radius at approach d: a = √(R d), mm."""
    return math.sqrt(radius_mm * depth_mm)


def hertz_contact_radius(force_N: float, radius_mm: float, e_star_MPa: float) -> float:
    """Hertz contact radius a = (3FR / (4E*))^(1/3), mm."""
    return (3 * force_N * radius_mm / (4 * e_star_MPa)) ** (1 / 3)


def hertz_approach(force_N: float, radius_mm: float, e_star_MPa: float) -> float:
    """Hertz approach (maximum depth) under force F: d = a²/R, mm."""
    a = hertz_contact_radius(force_N, radius_mm, e_star_MPa)
    return a * a / radius_mm


def hertz_peak_pressure(force_N: float, contact_radius_mm: float) -> float:
    """Hertz peak pressure p0 = 3F / (2πa²), MPa (1.5 × the mean pressure)."""
    return 3 * force_N / (2 * math.pi * contact_radius_mm * contact_radius_mm)


def hertz_sphere_on_plane(load_N: float, radius_mm: float, E_MPa: float,
                          nu: float) -> ContactMetrics:
    """Hertz, rigid sphere on an elastic half-space: E* = E/(1-ν²), a = (3FR/4E*)^(1/3)."""
    _check(load_N, radius_mm, E_MPa, nu)
    a = hertz_contact_radius(load_N, radius_mm, hertz_effective_modulus(E_MPa, nu))
    area = np.pi * a * a
    return ContactMetrics(max_pressure_MPa=float(hertz_peak_pressure(load_N, a)),
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
