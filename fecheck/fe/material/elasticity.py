"""Near-incompressible elasticity that keeps the stiffness symmetric positive definite.

The pure-displacement form ∫ λ div u div v + 2μ ε(u):ε(v) over-stiffens as ν → 0.5
(λ/μ = 2ν/(1 − 2ν): 49 at ν 0.49, 4999 at ν 0.4999). The mixed displacement-pressure
form with an element-constant pressure p (P2 displacement / P0 pressure, inf-sup stable
on triangles and tetrahedra; Herrmann's form ∫ 2μ ε:ε + p div v, ∫ (div u − p/λ) q = 0)
is condensed element by element (the mean-dilatation or B-bar method):

    K = K_μ + Dᵀ diag(λ / |T|) D,    D[T, j] = ∫_T div φ_j dV,

with K_μ the 2μ ε:ε part and |T| = ∫_T dV. K stays symmetric positive definite (the
contact's Cholesky path is kept) and has the pattern of the displacement stiffness (D
couples only the dofs of one element), so it costs about the same per dof. For quadratic
tetrahedra div φ is linear and ∫_T div φ = |T| div φ(centroid): the same as one-point
integration of the λ term. The axisymmetric (r, z) form weights dV = 2πr dA and adds the
hoop strain u_r/r to the divergence. Units: N, mm, MPa.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp

FORMULATIONS = ("auto", "displacement", "mixed")
MIXED_FROM_POISSON = 0.45
"""Poisson's ratio from which ``auto`` picks the mixed form (`resolve`). Measured on the
baseline scene's `fecheck fe` against the converged axisymmetric solve (p_max, area;
medial / lateral; validation/fe_incompressible.py): at ν 0.3 the displacement form is
the closer (-0.07 / -0.02 %, -0.04 / -0.6 %; mixed -0.5 / -0.2 %, +1.0 / +0.7 %: its
element-constant pressure converges at first order); at ν 0.45 the mixed one (+0.3 /
+0.4 %, +0.6 / +0.4 %; displacement +0.9 / +0.8 %, -0.8 / -0.8 %), at ν 0.49 by far
(+0.5 / +0.6 %, +0.8 / +0.5 %; displacement +4.3 / +3.6 %, -1.2 / -1.5 %). The CPU time
per dof of the two is the same at the same mesh (mixed / displacement 0.97, range
0.91-0.99, on the ν 0.45 baseline: validation/fe_mixed_cost.py)."""


def lame(youngs_MPa: float, poisson: float) -> tuple[float, float]:
    """Lamé's λ and μ (MPa) of an isotropic material."""
    lam = youngs_MPa * poisson / ((1.0 + poisson) * (1.0 - 2.0 * poisson))
    return lam, youngs_MPa / (2.0 * (1.0 + poisson))


def resolve(formulation: str, poisson: float) -> str:
    """'displacement' or 'mixed' for `formulation` ('auto': mixed from ν
    `MIXED_FROM_POISSON` on)."""
    if formulation == "auto":
        return "mixed" if poisson >= MIXED_FROM_POISSON else "displacement"
    return formulation


def dilatation_matrix(basis, divergence: Callable | None = None,
                      weight: Callable | None = None) -> tuple[sp.csr_matrix, np.ndarray]:
    """(D, volume): D (elements × dofs) with D[T, j] = ∫_T div φ_j w dV and volume[T] =
    ∫_T w dV on a scikit-fem vector basis (its quadrature must integrate div φ · w exactly
    or nearly). `divergence(field, x)` of a DiscreteField at the quadrature points'
    coordinates x (dim, elements, points) (default: the trace of its gradient);
    `weight(x)`, default 1 (e.g. 2πr for an axisymmetric basis)."""
    div = divergence or (lambda f, x: np.einsum("ii...->...", f.grad))
    x = np.asarray(basis.global_coordinates())
    dx = basis.dx if weight is None else basis.dx * weight(x)
    local = np.array([(div(phi[0], x) * dx).sum(axis=1) for phi in basis.basis])  # (nloc, nel)
    dofs = basis.element_dofs                                                   # (nloc, nel)
    rows = np.broadcast_to(np.arange(dofs.shape[1]), dofs.shape)
    D = sp.csr_matrix((local.ravel(), (rows.ravel(), dofs.ravel())),
                      shape=(dofs.shape[1], basis.N))
    return D, dx.sum(axis=1)


def mean_dilatation_stiffness(D: sp.csr_matrix, volume: np.ndarray,
                              lam: float) -> sp.csr_matrix:
    """Dᵀ diag(λ / volume) D: the element-condensed volumetric stiffness, N/mm."""
    return (D.T @ sp.diags(lam / volume) @ D).tocsr()
