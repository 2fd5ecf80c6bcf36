"""Load control of one contact pair: move the slave along a direction until the contact
pushes back with a given force (N), by Newton on the approach δ (mm)."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from fecheck.errors import FecheckError


# --------------------------------------------------------------------- load control
class NotConverged(FecheckError):
    """The load-controlled contact solve stopped without reaching the force."""


def load_controlled(pair, law: Callable, direction: np.ndarray, force_N: float,
                    start_mm: float, tol: float = 1e-8, max_iter: int = 50):
    """Move the slave by δ along `direction` until the contact pushes back with `force_N`.

    Newton on δ (mm) with the law's tangent, bisection safeguard. Returns (LawResult, δ,
    iterations). `NotConverged` if it does not converge.
    """
    u = np.asarray(direction, dtype=float)
    eye, zero = np.eye(3), np.zeros(3)
    lo, hi = 0.0, math.inf
    delta = start_mm
    for it in range(1, max_iter + 1):
        res = law(pair.evaluate((eye, delta * u), (eye, zero)))
        f = -float(res.force @ u)
        g = f - force_N
        if abs(g) <= tol * force_N:
            return res, delta, it
        if g < 0:
            lo = delta
        else:
            hi = delta
        slope = -float(u @ res.tangent[:3, :3] @ u)
        step = -g / slope if slope > 0 else math.inf
        new = delta + step
        if not lo < new < hi:
            new = 0.5 * (lo + hi) if math.isfinite(hi) else max(2.0 * delta, lo + 1e-3)
        delta = new
    raise NotConverged(f"load-controlled contact solve did not converge in {max_iter} steps "
                       f"(force {f:.4g} N of {force_N:.4g} N at δ = {delta:.4g} mm)")

