"""The outer loop of every FE contact solve with rigid unknowns: linearise, solve, step.

A configuration (the joint's rigid bodies at finite rotations, `fecheck.fe.solve.joint`;
the femur's travel and turns with the menisci's floating translations,
`fecheck.fe.knee.knee_menisci`) says what its k unknowns q are by linearising its contact
problem at q (`Linearised`): the gaps g0 (m,) mm at the candidates, their map J (m, k) and
the contact forces' map G (m, k) to the unknowns, the condensed compliance C (m, m) mm/N,
the unknowns' load Q (k,) N or N·mm and its stiffness dQ (k, k). `equilibrium` solves the
mixed complementarity problem of that linearisation
(`fecheck.fe.contact.active_set.settled`), steps q by the answer δq (shortened to a trust
region where it runs long) and linearises again, until the step stops: the contact and the
balance are then exact at the final q, with no penalty.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from fecheck.errors import FecheckError
from fecheck.fe.contact.active_set import settled


@dataclass(frozen=True, eq=False)
class Linearised:
    """The contact problem at the unknowns q: g = g0 + J δq + C λ ≥ 0, λ ≥ 0, λ·g = 0,
    Gᵀλ + dQ δq = −Q (`fecheck.fe.contact.active_set`). g0 (m,) mm; J, G (m, k); C (m, m)
    mm/N; Q (k,) N, N·mm; dQ (k, k) N/mm, N·mm/rad."""

    g0: np.ndarray
    J: np.ndarray
    G: np.ndarray
    C: np.ndarray
    Q: np.ndarray
    dQ: np.ndarray


@dataclass(frozen=True, eq=False)
class Driven:
    """The equilibrium: the unknowns q (k,), the contact forces λ (m,) N and the active set
    (m,) of the last solve, δq (k,) its step, the linearisation it solved (`at`), the outer
    and summed active-set iterations."""

    q: np.ndarray
    lam: np.ndarray
    active: np.ndarray
    dq: np.ndarray
    at: Linearised
    outer: int
    inner: int

    @property
    def gap_mm(self) -> np.ndarray:
        """(m,) the gaps of the last solve, mm: ≥ 0 up to round-off, 0 where λ > 0."""
        return self.at.g0 + self.at.J @ self.dq + self.at.C @ self.lam


def equilibrium(linearise: Callable[[np.ndarray, np.ndarray | None], Linearised],
                first: Callable[[Linearised, np.ndarray | None], np.ndarray],
                q0: np.ndarray, *, scale: np.ndarray, tolerance: float, max_outer: int,
                max_active: int, hint: str, failure: str, max_step: float = np.inf,
                log: Callable[[int, np.ndarray, np.ndarray], None] | None = None) -> Driven:
    """Step the unknowns from `q0` (k,) until the contact problem balances (module
    docstring).

    Parameters
    ----------
    linearise : (q, λ of the last solve or None) → the problem linearised at q
    first : (the linearisation, the last active set or None) → the active set to start
        its solve from, (m,) bool
    scale : (k,) the length of a unit step of each unknown, mm (1 for a translation, a
        lever arm for a rotation)
    tolerance : the loop stops when max |δq·scale| is at most this, mm
    max_step : a longer step max |δq·scale| (mm) is shortened along its direction to it
    hint : what the user can do, ending the error of an active set that does not settle
    failure : the error when the step has not stopped after `max_outer` solves
    log : called with (the update's number, δq, the active set) after each step
    """
    q = np.asarray(q0, dtype=float).copy()
    lam = active = None
    inner = 0
    for outer in range(1, max_outer + 1):
        lin = linearise(q, lam)
        if np.isnan(lin.g0).any() or not np.all(np.isfinite(lin.Q)):
            raise FecheckError(f"the contact problem at update {outer} has a gap or a load "
                               f"that is not a number; {hint}")
        lam, dq, active, iterations = settled(lin.C, lin.g0, lin.J, lin.G, lin.Q, lin.dQ,
                                              first(lin, active), max_active, hint)
        inner += iterations
        if not (np.all(np.isfinite(dq)) and np.all(np.isfinite(lam))):
            raise FecheckError(f"the contact solve at update {outer} gives a step or a force "
                               f"that is not finite; {hint}")
        size = float(np.max(np.abs(dq) * scale, initial=0.0))
        if size > max_step:
            dq = dq * (max_step / size)
        q = q + dq
        if log is not None:
            log(outer, dq, active)
        if size <= tolerance:
            return Driven(q, lam, active, dq, lin, outer, inner)
    raise FecheckError(failure)
