"""Contact pressure and summary metrics recovered from nodal contact forces.

The nodal contact forces λ_i (N) are the consistent loads ∫ φ_i p dA of the traction p
on the top surface. The pressure field is recovered variationally: the field p_h in the
same (quadratic) space whose consistent nodal loads are exactly λ, i.e. M p = λ with M the
surface mass matrix ∫ φ_i φ_j dA (mm²). It is exact for any pressure the space can hold.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from fecheck.fe.results import ContactMetrics


def project_pressure(mass: np.ndarray | sp.spmatrix, force_N: np.ndarray) -> np.ndarray:
    """Pressure (MPa) at the nodes solving ``mass @ p = force_N`` (mass in mm²)."""
    if sp.issparse(mass):
        from scipy.sparse.linalg import spsolve

        return spsolve(sp.csc_matrix(mass), force_N)
    return np.linalg.solve(mass, force_N)


def contact_metrics(pressure_MPa: np.ndarray, force_N: np.ndarray, area_mm2: float,
                    depth_mm: float) -> ContactMetrics:
    """Max pressure (MPa), mean pressure = Σλ / area (MPa), area (mm²), depth (mm), Σλ (N)."""
    total = float(force_N.sum())
    mean = total / area_mm2 if area_mm2 > 0 else float("nan")
    return ContactMetrics(max_pressure_MPa=float(pressure_MPa.max()), mean_pressure_MPa=mean,
                          area_mm2=float(area_mm2), depth_mm=float(depth_mm), force_N=total)
