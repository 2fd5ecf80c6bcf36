"""The primal-dual active set (Hintermüller-Ito-Kunisch) of frictionless contact under
load control: one mixed complementarity problem for every FE contact solve.

With the compliance C (m, m) at the contact candidates (mm/N), the gaps g0 (m,) mm, the
gaps' map J (m, k) and the forces' map G (m, k) to k rigid unknowns δq, and the unknowns'
load Q (k,) and its stiffness dQ (k, k):

    g = g0 + J δq + C λ ≥ 0,   λ ≥ 0,   λ·g = 0,   Gᵀλ + dQ δq = −Q.

For an active set A the equalities are one dense solve (`kkt_step`); candidates that
pull are released and those that penetrate are added until A stops changing
(`active_set`); `settled` falls back to a symmetric tangent and to one change per solve
(`one_at_a_time`) where the block update cycles.
"""

from __future__ import annotations

import numpy as np

from fecheck.errors import FecheckError
from geometry.native import interruptible


def kkt_step(C: np.ndarray, g0: np.ndarray, J: np.ndarray, G: np.ndarray, Q: np.ndarray,
             dQ: np.ndarray, active: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The equalities of `active_set` for the set `active`: contact at every active
    candidate (g = 0), balance of the unknowns. Returns (λ (m,) N, zero off the set, δq
    (k,), the gaps g (m,) mm)."""
    m, k = J.shape
    idx = np.flatnonzero(active)
    a = len(idx)
    kkt = np.zeros((a + k, a + k))
    kkt[:a, :a] = C[np.ix_(idx, idx)]
    kkt[:a, a:] = J[idx]
    kkt[a:, :a] = G[idx].T
    kkt[a:, a:] = dQ
    rhs = np.concatenate([-g0[idx], -Q])
    try:
        with interruptible():
            sol = np.linalg.solve(kkt, rhs)
    except np.linalg.LinAlgError:
        with interruptible():
            sol = np.linalg.lstsq(kkt, rhs, rcond=None)[0]
    lam = np.zeros(m)
    lam[idx] = sol[:a]
    dq = sol[a:]
    return lam, dq, g0 + J @ dq + C @ lam


def active_set(C: np.ndarray, g0: np.ndarray, J: np.ndarray, G: np.ndarray, Q: np.ndarray,
               dQ: np.ndarray, active: np.ndarray, max_iter: int, hint: str
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Primal-dual active set (Hintermüller-Ito-Kunisch) of the mixed LCP
    g = g0 + J δq + C λ ≥ 0, λ ≥ 0, λ·g = 0, Gᵀλ + dQ δq = −Q.

    C (m, m) compliance at the candidates (mm/N), g0 (m,) gaps (mm), J (m, k) and G (m, k)
    the gaps' and the forces' maps to the k unknowns δq, Q (k,) and dQ (k, k) the
    unknowns' load and its stiffness; `active` (m,) the first set. For a set A the
    equalities are one dense solve; candidates that pull are released and those that
    penetrate are added (at least the deepest stays) until A stops changing. Returns
    (λ (m,) N, δq (k,), A, iterations); `FecheckError` ending with `hint` when A keeps
    changing for `max_iter` iterations.
    """
    for it in range(1, max_iter + 1):
        lam, dq, gap = kkt_step(C, g0, J, G, Q, dQ, active)
        new = np.where(active, lam > 0.0, gap < 0.0)
        if not new.any():
            new[np.argmin(gap)] = True
        if np.array_equal(new, active):
            return lam, dq, active, it
        active = new
    raise FecheckError(f"the FE contact active set did not settle in {max_iter} iterations; "
                       f"{hint}")


def settled(C: np.ndarray, g0: np.ndarray, J: np.ndarray, G: np.ndarray, Q: np.ndarray,
            dQ: np.ndarray, active: np.ndarray, max_active: int, hint: str
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """`active_set` from the first set `active`; where it cycles (its tangent is not
    symmetric: a follower load, the contact forces' own change with the pose), the same
    with the symmetric part of dQ (an inexact Newton step: the pose it converges to
    balances the load all the same, as dq → 0 there), then `one_at_a_time`. Measured: the
    decimated knee at 30° under 800 N along the tibial axis, whose dQ has eigenvalues down
    to -3.1e4 N·mm and an antisymmetric part of 3.6e3, cycled at the first update; with
    the symmetric part it settles and converges in 6. Returns as `active_set`."""
    try:
        return active_set(C, g0, J, G, Q, dQ, active, max_active, hint)
    except FecheckError:
        pass
    try:
        return active_set(C, g0, J, G, Q, 0.5 * (dQ + dQ.T), active, max_active, hint)
    except FecheckError:
        return one_at_a_time(C, g0, J, G, Q, dQ, active, 3 * len(g0))


def one_at_a_time(C: np.ndarray, g0: np.ndarray, J: np.ndarray, G: np.ndarray,
                  Q: np.ndarray, dQ: np.ndarray, active: np.ndarray, max_iter: int
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """The complementarity of `active_set` with one change of the set per solve: the most
    pulling active candidate released, else the most penetrating inactive one added;
    slower (a dense solve per change) but it does not jump between sets as the block
    update can. Returns as `active_set`."""
    active = active.copy()
    for it in range(1, max_iter + 1):
        lam, dq, gap = kkt_step(C, g0, J, G, Q, dQ, active)
        pulling = np.where(active, lam, np.inf)
        open_gap = np.where(active, np.inf, gap)
        if pulling.min() <= 0.0 and active.sum() > 1:
            active[np.argmin(pulling)] = False
        elif open_gap.min() < 0.0:
            active[np.argmin(open_gap)] = True
        else:
            return lam, dq, active, it
    raise FecheckError(f"the FE contact active set did not settle in {max_iter} one-at-a-time "
                       "changes after the block updates cycled; refine the layer under the "
                       "contact or check the load")
