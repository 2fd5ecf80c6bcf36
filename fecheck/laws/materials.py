"""Cartilage materials: validated E, ν, h and the stiffnesses the laws use.

Units: MPa, mm; EF stiffness in N/mm³.

>>> round(ef_stiffness(20.0, 0.3, 6.0), 4)
4.4872
"""

from __future__ import annotations

import math
import warnings

from fecheck.errors import FecheckError
from fecheck.reference.closed_forms import column_stiffness, hertz_effective_modulus


def _check_number(name: str, value: float) -> float:
    value = float(value)
    if math.isnan(value):
        raise FecheckError(f"{name} is NaN; give a number")
    return value


def validate_material(youngs_MPa: float, poisson: float, thickness_mm: float | None = None
                      ) -> None:
    """Reject E ≤ 0, h ≤ 0, ν < 0, ν ≥ 0.5 and NaN (`FecheckError`); warn when ν > 0.49."""
    e = _check_number("Young's modulus (contact.youngs_MPa)", youngs_MPa)
    nu = _check_number("Poisson's ratio (contact.poisson)", poisson)
    if not e > 0:
        raise FecheckError(f"Young's modulus must be > 0 MPa, got {e:g}")
    if nu >= 0.5:
        raise FecheckError(f"Poisson's ratio {nu:g} ≥ 0.5: the EF stiffness diverges as "
                           f"ν → 0.5 (1 − 2ν in the denominator); use ν < 0.5")
    if nu < 0:
        raise FecheckError(f"Poisson's ratio must be ≥ 0, got {nu:g}")
    if nu > 0.49:
        warnings.warn(f"Poisson's ratio {nu:g} is within 0.01 of 0.5: the EF stiffness "
                      f"(∝ 1/(1 − 2ν)) is very large and ill-conditioned", stacklevel=2)
    if thickness_mm is not None:
        h = _check_number("cartilage thickness (contact.thickness_mm)", thickness_mm)
        if not h > 0:
            raise FecheckError(f"cartilage thickness must be > 0 mm, got {h:g}")


def ef_stiffness(youngs_MPa: float, poisson: float, thickness_mm: float) -> float:
    """EF stiffness per unit area k = (1−ν)E / ((1+ν)(1−2ν)h), N/mm³ (eq. 4.3)."""
    validate_material(youngs_MPa, poisson, thickness_mm)
    return column_stiffness(youngs_MPa, poisson, thickness_mm)


def hertz_modulus(youngs_MPa: float, poisson: float, indenter_youngs_MPa: float = math.inf,
                  indenter_poisson: float = 0.3) -> float:
    """Effective modulus E* (MPa): 1/E* = (1−ν²)/E + (1−ν_i²)/E_i (E_i = inf: rigid)."""
    validate_material(youngs_MPa, poisson)
    if not math.isinf(indenter_youngs_MPa):
        validate_material(indenter_youngs_MPa, indenter_poisson)
    return hertz_effective_modulus(youngs_MPa, poisson, indenter_youngs_MPa, indenter_poisson)

