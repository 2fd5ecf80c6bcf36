"""Bivariate polynomial surfaces z = f(x, y) (thesis §2.2.2), mm.

``coeffs[i, j]`` multiplies ``x**i * y**j``; a surface of degree (k, m) has a
``(k + 1, m + 1)`` coefficient array. Fits live in `geometry.fits`; the contact engine
uses `value`, `gradient` and `hessian` for closed-form depths.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geometry.errors import FecheckError


@dataclass(frozen=True, eq=False)
class Polynomial2D:
    """z = Σ coeffs[i, j] · x^i · y^j, lengths in mm.

    >>> p = Polynomial2D(np.array([[1.0, 0.0], [2.0, 0.5]]))   # 1 + 2x + 0.5xy
    >>> float(p.value(np.array(1.0), np.array(2.0)))
    4.0
    """

    coeffs: np.ndarray

    def __post_init__(self) -> None:
        c = np.atleast_2d(np.asarray(self.coeffs, dtype=np.float64))
        if c.ndim != 2 or not np.all(np.isfinite(c)):
            raise FecheckError("polynomial coefficients must be a finite 2D array")
        object.__setattr__(self, "coeffs", c)

    @property
    def degree(self) -> tuple[int, int]:
        """Degrees (in x, in y)."""
        return self.coeffs.shape[0] - 1, self.coeffs.shape[1] - 1

    def value(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """f(x, y), mm."""
        return np.polynomial.polynomial.polyval2d(x, y, self.coeffs)

    def gradient(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(∂f/∂x, ∂f/∂y), dimensionless."""
        P = np.polynomial.polynomial
        cx = P.polyder(self.coeffs, axis=0) if self.coeffs.shape[0] > 1 else np.zeros((1, 1))
        cy = P.polyder(self.coeffs, axis=1) if self.coeffs.shape[1] > 1 else np.zeros((1, 1))
        return P.polyval2d(x, y, cx), P.polyval2d(x, y, cy)

    def hessian(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(f_xx, f_xy, f_yy), 1/mm."""
        P = np.polynomial.polynomial
        c = self.coeffs

        def der(coeffs: np.ndarray, axis: int) -> np.ndarray:
            if coeffs.shape[axis] > 1:
                return P.polyder(coeffs, axis=axis)
            return np.zeros((1, 1))

        cxx, cxy, cyy = der(der(c, 0), 0), der(der(c, 0), 1), der(der(c, 1), 1)
        return P.polyval2d(x, y, cxx), P.polyval2d(x, y, cxy), P.polyval2d(x, y, cyy)
