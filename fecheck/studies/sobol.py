"""Sample designs in the unit cube and Sobol sensitivity indices.

A design for Sobol indices is Saltelli's (2010): two independent base matrices A and B
(n rows each, one column per input) drawn together as one n × 2d matrix from
`scipy.stats.qmc` (a scrambled Sobol sequence, a Latin hypercube) or at random, and
for each input i the matrix A_B^i (A with column i from B). The rows are laid out as
SALib lays them out without second-order indices: for each base row j, A_j, A_B^1_j, …,
A_B^d_j, B_j — so n·(d + 2) evaluations. The first-order and total indices (Saltelli
2010, Jansen 1999) and their bootstrap confidence intervals are SALib's
(`SALib.analyze.sobol`, imported only here, when indices are asked).

>>> design(8, 2, "sobol", seed=1).shape
(32, 2)
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from fecheck.errors import FecheckError

METHODS = ("sobol", "lhs", "random")
MIN_BASE = 8
"""Fewest base rows n for Sobol indices (n·(d + 2) evaluations for d inputs): below
that the bootstrap has too few rows to resample and the intervals mean little."""


def base_matrix(n: int, columns: int, method: str, seed: int | None) -> np.ndarray:
    """n points of the unit cube in `columns` dimensions, (n, columns)."""
    from scipy.stats import qmc

    if method == "sobol":
        with warnings.catch_warnings():          # balance needs n a power of 2: any n
            warnings.simplefilter("ignore", UserWarning)
            return qmc.Sobol(columns, scramble=True, seed=seed).random(n)
    if method == "lhs":
        return qmc.LatinHypercube(columns, seed=seed).random(n)
    if method == "random":
        return np.random.default_rng(seed).random((n, columns))
    raise FecheckError(f"--method {method!r}: choose one of {', '.join(METHODS)}")


def design(n: int, d: int, method: str, seed: int | None = None) -> np.ndarray:
    """Saltelli's design for `d` inputs from `n` base rows: (n·(d + 2), d) unit-cube
    points in SALib's order (module docstring)."""
    ab = base_matrix(n, 2 * d, method, seed)
    a, b = ab[:, :d], ab[:, d:]
    blocks = np.empty((n, d + 2, d))
    blocks[:, 0] = a
    for i in range(d):
        blocks[:, 1 + i] = a
        blocks[:, 1 + i, i] = b[:, i]
    blocks[:, d + 1] = b
    return blocks.reshape(n * (d + 2), d)


def runs_for(samples: int, d: int, indices: bool) -> tuple[int, int]:
    """(base rows n, evaluations) for at most `samples` evaluations of `d` inputs: with
    `indices`, n = samples // (d + 2) and n·(d + 2) evaluations; else n = samples."""
    if not indices:
        return samples, samples
    n = samples // (d + 2)
    return n, n * (d + 2)


def check_samples(samples: int, d: int, indices: bool) -> None:
    """Refuse a sample count too small for the indices asked (`MIN_BASE`)."""
    if samples < 1:
        raise FecheckError(f"--samples {samples}: give at least 1")
    if indices and samples < MIN_BASE * (d + 2):
        raise FecheckError(f"--samples {samples}: Sobol indices of {d} key(s) need at least "
                           f"{MIN_BASE * (d + 2)} samples ({MIN_BASE} base rows of d + 2 = "
                           f"{d + 2} runs); give more, or --indices none")


@dataclass(frozen=True)
class Indices:
    """First-order (S1) and total (ST) Sobol indices of one output, per input, with the
    half-widths of their bootstrap confidence intervals; `groups`: base rows used."""

    names: tuple[str, ...]
    s1: np.ndarray
    s1_conf: np.ndarray
    st: np.ndarray
    st_conf: np.ndarray
    groups: int

    def as_dict(self) -> dict:
        """JSON-ready: per input, S1, ST and their interval half-widths."""
        return {"base_rows": self.groups, "inputs": {
            n: {"S1": float(self.s1[i]), "S1_conf": float(self.s1_conf[i]),
                "ST": float(self.st[i]), "ST_conf": float(self.st_conf[i])}
            for i, n in enumerate(self.names)}}


def usable_groups(y: np.ndarray, d: int) -> np.ndarray:
    """(n,) True for the base rows whose d + 2 evaluations are all finite."""
    return np.isfinite(y.reshape(-1, d + 2)).all(axis=1)


def sobol_indices(y: np.ndarray, names: Sequence[str], *, resamples: int = 200,
                  conf_level: float = 0.95, seed: int | None = 0) -> Indices:
    """Sobol indices of the evaluations `y` (n·(d + 2),) of a `design`, by SALib.

    Base rows with a non-finite evaluation (a failed or unconverged run) are left out
    whole, so that the estimator keeps its pairing; `Indices.groups` says how many were
    used.

    Raises
    ------
    FecheckError
        When fewer than `MIN_BASE` base rows are left, or the output does not vary.
    """
    d = len(names)
    y = np.asarray(y, dtype=float)
    keep = usable_groups(y, d)
    if keep.sum() < MIN_BASE:
        raise FecheckError(f"only {int(keep.sum())} base rows have every run solved: Sobol "
                           f"indices need {MIN_BASE}")
    y = y.reshape(-1, d + 2)[keep].ravel()
    if np.ptp(y) == 0.0:
        raise FecheckError("the output does not vary over the samples: no Sobol indices")
    from SALib.analyze import sobol as salib_sobol

    problem = {"num_vars": d, "names": list(names), "bounds": [[0.0, 1.0]] * d}
    # SALib draws its bootstrap from the global generator for a seed of 0 (falsy): shift
    # the seed so that every seed, 0 (a study's default) included, fixes the intervals
    res = salib_sobol.analyze(problem, y, calc_second_order=False, num_resamples=resamples,
                              conf_level=conf_level, print_to_console=False,
                              seed=None if seed is None else seed + 1)
    return Indices(tuple(names), np.asarray(res["S1"]), np.asarray(res["S1_conf"]),
                   np.asarray(res["ST"]), np.asarray(res["ST_conf"]), int(keep.sum()))
