"""Discretization-error estimates from refinement levels: observed order, Richardson
extrapolation and Roache's grid convergence index (GCI).

The procedure of Celik et al. 2008 (J. Fluids Eng. 130:078001, "Procedure for estimation
and reporting of uncertainty due to discretization in CFD applications"), after Roache
1994/1998: with three levels (f1 finest, r21 = h2/h1, r32 = h3/h2), the observed order p
solves p = |ln|ε32/ε21| + q(p)| / ln r21, q(p) = ln((r21^p − s)/(r32^p − s)),
s = sign(ε32/ε21), ε21 = f2 − f1; the extrapolated value is
f_ext = (r21^p f1 − f2)/(r21^p − 1); GCI_fine = Fs·|(f1 − f2)/f1|/(r21^p − 1) with the
safety factor Fs = 1.25. With two levels the order is not observed: the formal order
is assumed and Fs = 3.

>>> r = gci([6.063, 5.972, 5.863], [1.5, 1.333])       # Celik et al. 2008, Table 1
>>> round(r.order, 2), round(r.extrapolated, 3), round(100 * r.gci_fine, 1)
(1.54, 6.168, 2.2)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from fecheck.errors import FecheckError


@dataclass(frozen=True)
class GCIResult:
    """order p (observed, or assumed with two levels), extrapolated value, the fine
    level's relative GCI (a fraction), the safety factor used, and whether the three
    values converge monotonically (False: oscillatory, the estimate is weak)."""

    order: float
    extrapolated: float
    gci_fine: float
    safety_factor: float
    monotone: bool


def observed_order(errors: Sequence[float], sizes: Sequence[float]) -> float:
    """p = ln(e1/e2)/ln(h1/h2) from the last two (error, size) pairs; NaN when an error
    is zero or the sizes are equal."""
    e1, e2 = abs(errors[-2]), abs(errors[-1])
    h1, h2 = sizes[-2], sizes[-1]
    if e1 == 0 or e2 == 0 or h1 == h2:
        return math.nan
    return math.log(e1 / e2) / math.log(h1 / h2)


def gci(values: Sequence[float], ratios: Sequence[float], *,
        formal_order: float = 2.0) -> GCIResult:
    """The GCI of the finest of `values` (finest first: f1, f2[, f3]); `ratios` the
    refinement ratios (r21[, r32]), each > 1. Two values: the `formal_order` is assumed
    (Fs = 3); three: the order is observed (Fs = 1.25)."""
    if len(values) not in (2, 3) or len(ratios) != len(values) - 1:
        raise FecheckError("gci takes 2 or 3 values (finest first) and one ratio fewer")
    if any(not r > 1 for r in ratios):
        raise FecheckError(f"refinement ratios must exceed 1, got {list(ratios)}")
    f1, f2 = float(values[0]), float(values[1])
    r21 = float(ratios[0])
    if len(values) == 2:
        p, fs, monotone = float(formal_order), 3.0, True
    else:
        p, monotone = _three_level_order(f1, f2, float(values[2]), r21, float(ratios[1]))
        fs = 1.25
    growth = r21 ** p - 1.0
    extrapolated = (r21 ** p * f1 - f2) / growth if growth > 0 else math.nan
    rel = abs((f1 - f2) / f1) if f1 != 0 else math.nan
    return GCIResult(p, extrapolated, fs * rel / growth if growth > 0 else math.nan, fs,
                     monotone)


def _three_level_order(f1: float, f2: float, f3: float, r21: float,
                       r32: float) -> tuple[float, bool]:
    """(observed order, monotone) by fixed-point iteration on Celik et al.'s eq. (4)."""
    e21, e32 = f2 - f1, f3 - f2
    if e21 == 0 or e32 == 0:
        return math.nan, False
    s = math.copysign(1.0, e32 / e21)
    p = abs(math.log(abs(e32 / e21))) / math.log(r21)
    for _ in range(200):
        q = math.log((r21 ** p - s) / (r32 ** p - s)) if r21 ** p != s and r32 ** p != s \
            else 0.0
        new = abs(math.log(abs(e32 / e21)) + q) / math.log(r21)
        if abs(new - p) < 1e-12:
            p = new
            break
        p = new
    return p, s > 0
