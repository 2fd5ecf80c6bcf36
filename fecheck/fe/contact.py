"""Exact frictionless unilateral contact with a rigid indenter under load control.

The layer's stiffness K (free dofs only, N/mm) is pressed by a rigid body moving down by
δ (mm). At each candidate node i the vertical gap is ``g_i = g0_i - δ - w_i`` with
``w_i`` the upward displacement of the node and ``g0_i`` the gap when δ = 0; the node
carries a downward force λ_i ≥ 0 with ``λ_i g_i = 0``, and ``Σ λ_i = F``.

Method: primal-dual active set (Hintermüller-Ito-Kunisch), no penalty. For an active set
A the constraint ``w_A = g0_A - δ`` is imposed as a Dirichlet condition; the solution is
affine in δ, ``u = u0 + δ u1`` (two solves with one factorization), and δ follows from
``Σ λ_A(δ) = F`` exactly. The set is updated with the nodes that pull (λ < 0, released)
and those that penetrate (g < 0, added) until it no longer changes. Dirichlet rows are
imposed by editing the values of K in place (same sparsity), so the symbolic
factorization is computed once and each iteration is one numeric refactorization.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from fecheck.errors import FecheckError

SOLVERS = ("cholmod", "superlu")


@dataclass(frozen=True, eq=False)
class ContactSolution:
    """u (all free dofs, mm), λ at the candidates (N), δ (mm), final gaps (mm)."""

    u: np.ndarray
    force_N: np.ndarray
    delta_mm: float
    gap_mm: np.ndarray
    active: np.ndarray
    iterations: int
    solve_s: float


class _Factorizer:
    """Numeric refactorization of matrices sharing K's sparsity pattern."""

    def __init__(self, K: sp.csc_matrix, solver: str) -> None:
        if solver not in SOLVERS:
            raise FecheckError(f"FE solver must be one of {SOLVERS}, got {solver!r}")
        self.solver = solver
        self._chol = None
        if solver == "cholmod":
            from sksparse.cholmod import analyze

            self._chol = analyze(K)

    def __call__(self, A: sp.csc_matrix) -> Callable[[np.ndarray], np.ndarray]:
        if self.solver == "cholmod":
            self._chol.cholesky_inplace(A)
            return self._chol.solve_A
        from scipy.sparse.linalg import splu

        return splu(A, permc_spec="MMD_AT_PLUS_A").solve


def _dirichlet_values(K: sp.csc_matrix, dofs: np.ndarray) -> np.ndarray:
    """K's values with the rows and columns of `dofs` zeroed and a unit diagonal."""
    mask = np.zeros(K.shape[0], dtype=bool)
    mask[dofs] = True
    cols = np.repeat(np.arange(K.shape[1]), np.diff(K.indptr))
    rows = K.indices
    data = K.data.copy()
    data[mask[rows] | mask[cols]] = 0.0
    data[mask[rows] & (rows == cols)] = 1.0
    return data


def solve_contact(K: sp.spmatrix, candidates: np.ndarray,
                  gap0: Callable[[np.ndarray], np.ndarray], load_N: float,
                  delta_guess_mm: float, *, solver: str = "cholmod",
                  deformed_gap: bool = False, max_iter: int = 60) -> ContactSolution:
    """Solve the load-controlled contact problem exactly (active set).

    Parameters
    ----------
    K : (n, n) symmetric positive definite stiffness of the free dofs, N/mm
    candidates : (m,) indices of the vertical-displacement dofs that may touch
    gap0 : function of the current displacement u (n,) returning the gaps g0 (m,) at δ = 0,
        mm; it ignores u for the reference-configuration gap and uses the tangential
        displacements for the deformed-configuration gap
    load_N : total downward force the indenter must transmit, N (> 0)
    delta_guess_mm : indentation used to guess the first active set, mm
    solver : "cholmod" (default, fastest measured) or "superlu"
    deformed_gap : re-evaluate ``gap0(u)`` until it stops changing (fixed point)
    max_iter : active-set iterations allowed

    Returns
    -------
    ContactSolution with λ ≥ 0, g ≥ 0 and λ·g = 0 at every candidate and Σλ = load_N.
    """
    if not (np.isfinite(load_N) and load_N > 0):
        raise FecheckError(f"contact load must be positive and finite, got {load_N} N")
    t0 = time.perf_counter()
    K = sp.csc_matrix(K)
    K.sort_indices()
    factorizer = _Factorizer(K, solver)
    cand = np.asarray(candidates, dtype=np.int64)
    m = len(cand)
    g0 = gap0(np.zeros(K.shape[0]))
    active = g0 < delta_guess_mm
    if not active.any():
        active[np.argmin(g0)] = True
    iterations = 0
    for _ in range(max_iter):
        iterations += 1
        dofs = cand[active]
        A = sp.csc_matrix((_dirichlet_values(K, dofs), K.indices, K.indptr), shape=K.shape)
        solve = factorizer(A)
        rhs = np.zeros((K.shape[0], 2))
        u_a = np.zeros((K.shape[0], 2))
        u_a[dofs, 0] = g0[active]
        u_a[dofs, 1] = -1.0
        rhs[:] = -(K @ u_a)
        rhs[dofs] = u_a[dofs]
        U = solve(rhs)
        R = -(K @ U)[cand]
        lam0, lam1 = R[:, 0] * active, R[:, 1] * active
        if lam1.sum() <= 0:
            raise FecheckError("contact stiffness is not positive: check the layer's supports")
        delta = (load_N - lam0.sum()) / lam1.sum()
        u = U[:, 0] + delta * U[:, 1]
        lam = lam0 + delta * lam1
        if deformed_gap:
            g0_new = gap0(u)
            moved = np.max(np.abs(g0_new - g0))
            g0 = g0_new
        else:
            moved = 0.0
        gap = g0 - delta - u[cand]
        new_active = np.where(active, lam > 0, gap < 0)
        if np.array_equal(new_active, active) and moved < 1e-10:
            break
        if not new_active.any():
            new_active[np.argmin(gap)] = True
        active = new_active
    else:
        raise FecheckError(f"contact active set did not settle in {max_iter} iterations; "
                           "refine the mesh under the contact or change the load")
    if m and not np.all(np.isfinite(u)):
        raise FecheckError("FE contact solve produced NaN: the stiffness matrix is singular")
    return ContactSolution(u=u, force_N=np.where(active, lam, 0.0), delta_mm=float(delta),
                           gap_mm=gap, active=active,
                           iterations=iterations, solve_s=time.perf_counter() - t0)
