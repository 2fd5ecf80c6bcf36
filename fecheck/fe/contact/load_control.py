"""Exact frictionless unilateral contact with a rigid indenter under load control.

The layer's stiffness K (free dofs only, N/mm) is pressed by a rigid body moving down by
δ (mm). At each candidate node i the vertical gap is ``g_i = g0_i - δ - w_i`` with
``w_i`` the upward displacement of the node and ``g0_i`` the gap when δ = 0; the node
carries a downward force λ_i ≥ 0 with ``λ_i g_i = 0``, and ``Σ λ_i = F``.

Method, no penalty anywhere:

1. Condense K onto the candidate dofs: one sparse Cholesky factorization (CHOLMOD; SuperLU
   as the fallback) and one block solve for the unit loads at the m candidates give the
   compliance C (m × m, ``w = -C λ``) and the tangential displacements per unit load.
2. Solve the small mixed LCP ``g0 - δ + C λ ≥ 0, λ ≥ 0, λ·g = 0, Σλ = F`` with a
   primal-dual active set (Hintermüller-Ito-Kunisch): for a set A the equalities
   ``C_AA λ_A - δ = -g0_A`` and ``Σ λ_A = F`` are one dense symmetric solve; nodes that
   pull are released and nodes that penetrate are added until the set stops changing.
   With ``deformed_gap`` the gaps g0 are re-evaluated at the displaced node positions
   (fixed point on the tangential displacements) until they stop changing.
3. The displacement field is one more solve with the contact forces.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from fecheck.errors import FecheckError
from fecheck.fe.contact.active_set import active_set
from fecheck.fe.contact.compliance import factorize


@dataclass(frozen=True, eq=False)
class ContactSolution:
    """Solution of the contact problem.

    u : all free dofs, mm; force_N : (m,) downward nodal contact forces λ, N;
    delta_mm : indenter displacement, mm; gap_mm : (m,) final gaps, mm;
    active : (m,) candidates in contact.
    """

    u: np.ndarray
    force_N: np.ndarray
    delta_mm: float
    gap_mm: np.ndarray
    active: np.ndarray
    iterations: int
    timing_s: dict


def solve_contact(K: sp.spmatrix, candidates: np.ndarray,
                  gap0: Callable[[np.ndarray | None], np.ndarray], load_N: float,
                  delta_guess_mm: float, *, tangential: Sequence[np.ndarray] = (),
                  solver: str = "cholmod", deformed_gap: bool = False,
                  max_iter: int = 60, block: int = 128) -> ContactSolution:
    """Solve the load-controlled contact problem exactly.

    Parameters
    ----------
    K : (n, n) symmetric positive definite stiffness of the free dofs, N/mm
    candidates : (m,) indices of the vertical-displacement (up) dofs that may touch
    gap0 : gaps g0 (m,) at δ = 0, mm, as a function of the tangential displacements
        ((m, len(tangential)) array, mm) or of None (reference configuration)
    load_N : total downward force the indenter transmits, N (> 0)
    delta_guess_mm : indentation used to guess the first active set, mm
    tangential : dof indices (m,) of each tangential displacement of the candidates
        (needed with ``deformed_gap``)
    solver : "cholmod" (default, fastest measured) or "superlu"
    deformed_gap : re-evaluate the gaps at the displaced positions until they settle
    max_iter : active-set iterations allowed (per gap update)
    block : right-hand sides per block solve (the cost is m solves)

    Returns
    -------
    ContactSolution with λ ≥ 0, g ≥ 0, λ·g = 0 at every candidate and Σλ = load_N.
    """
    if not (np.isfinite(load_N) and load_N > 0):
        raise FecheckError(f"contact load must be positive and finite, got {load_N} N")
    timing = {}
    t = time.perf_counter()
    solve = factorize(K, solver)
    timing["factorize"] = time.perf_counter() - t
    t = time.perf_counter()
    cand = np.asarray(candidates, dtype=np.int64)
    n, m = K.shape[0], len(cand)
    rows = np.concatenate([cand, *tangential]) if tangential else cand
    # G[:, c]: displacements (candidates, then tangential) under a unit upward force at
    # candidate c; `block` right-hand sides per solve. C = G[:m] is the compliance.
    G = np.empty((len(rows), m))
    for start in range(0, m, block):
        cols = np.arange(start, min(start + block, m))
        rhs = np.zeros((n, len(cols)))
        rhs[cand[cols], np.arange(len(cols))] = 1.0
        G[:, cols] = solve(rhs)[rows]
    C = 0.5 * (G[:m] + G[:m].T)
    timing["condense"] = time.perf_counter() - t
    t = time.perf_counter()
    g0 = gap0(None)
    active = g0 < delta_guess_mm
    if not active.any():
        active[np.argmin(g0)] = True
    iterations = 0
    for _ in range(max_iter):
        lam, step, active, it = active_set(C, g0, -np.ones((m, 1)), np.ones((m, 1)),
                                           np.array([-load_N]), np.zeros((1, 1)), active,
                                           max_iter, "refine the mesh under the contact or "
                                           "change the load")
        delta = float(step[0])
        iterations += it
        if not deformed_gap:
            break
        shift = -(G[m:] @ lam).reshape(len(tangential), m).T
        g_new = gap0(shift)
        change = float(np.max(np.abs(g_new - g0)))
        g0 = g_new
        if change < 1e-10:
            break
    else:
        raise FecheckError("deformed-configuration gaps did not settle; use gap='reference'")
    gap = g0 - delta + C @ lam
    timing["active_set"] = time.perf_counter() - t
    t = time.perf_counter()
    f = np.zeros(n)
    f[cand] = -lam
    u = solve(f)
    timing["displacement"] = time.perf_counter() - t
    if not (np.all(np.isfinite(u)) and np.isfinite(delta)):
        raise FecheckError("FE contact solve produced NaN: the stiffness matrix is singular")
    return ContactSolution(u=u, force_N=lam, delta_mm=delta, gap_mm=gap, active=active,
                           iterations=iterations, timing_s=timing)
