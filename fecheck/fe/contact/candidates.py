"""The contact candidates' rounds: solve on the vertices that may touch, widen them while
a vertex outside penetrates.

The dense contact solve condenses each body onto its candidate vertices, those whose
gap at the start lies under a margin (mm). After a solve every vertex's gap is read
again with the bodies displaced; where one outside the candidates penetrates, each
group of candidates (a layer, a pair) takes in its vertices under the margin and the
problem is condensed and solved again. Units: mm.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Mapping
from dataclasses import dataclass
from enum import Enum
from typing import Generic, TypeVar

import numpy as np

Key = TypeVar("Key", bound=Hashable)
Solution = TypeVar("Solution")


class Outcome(Enum):
    """How the rounds ended: no vertex penetrates (SETTLED); one does but widening adds
    none and nothing was re-paired (STUCK); the rounds ran out (EXHAUSTED)."""

    SETTLED = "settled"
    STUCK = "stuck"
    EXHAUSTED = "exhausted"


@dataclass(frozen=True, eq=False)
class Round(Generic[Solution]):
    """One solve on a candidate set: its `solution`, every group's `gaps` (mm) at all the
    vertices it may pair with the bodies displaced, the deepest penetration `worst` (mm,
    ≥ 0) and how many candidates were `repaired` (their rays moved on a deformable
    master: the same set is worth solving again)."""

    solution: Solution
    gaps: Mapping[Hashable, np.ndarray]
    worst: float
    repaired: int = 0


def widened(solve: Callable[[dict[Key, np.ndarray]], Round[Solution]],
            candidates: Mapping[Key, np.ndarray], margin_mm: float, rounds: int,
            tolerance_mm: float, say: Callable[[Round[Solution]], None] = lambda r: None
            ) -> tuple[Round[Solution], Outcome, dict[Key, np.ndarray]]:
    """Solve on `candidates` (group → vertex indices) and widen each group by its vertices
    whose gap after the solve is under `margin_mm` while a vertex penetrates by more than
    `tolerance_mm` (mm), at most `rounds` solves; `say` hears each round that widens.

    Returns the last round, how the rounds ended and the candidates it was solved on.
    """
    cands = dict(candidates)
    for round_ in range(1, rounds + 1):
        result = solve(cands)
        if result.worst <= tolerance_mm:
            return result, Outcome.SETTLED, cands
        grown = {k: np.union1d(c, np.flatnonzero(result.gaps[k] < margin_mm))
                 for k, c in cands.items()}
        if all(len(grown[k]) == len(c) for k, c in cands.items()) and not result.repaired:
            return result, Outcome.STUCK, cands
        if round_ == rounds:
            return result, Outcome.EXHAUSTED, cands
        say(result)
        cands = grown
    raise ValueError(f"at least one round of contact candidates is needed, got {rounds}")
