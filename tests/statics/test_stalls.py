"""A stalled Newton solve stops early inside `stopping_stalls`; a converging one is
unchanged by it."""

from __future__ import annotations

import numpy as np
import pytest

from fecheck.statics.newton import (
    STALL_EVALUATIONS,
    Body,
    Problem,
    point_force,
    solve,
    stopping_stalls,
)

K_N_MM = 10.0        # spring stiffness along x, N/mm
PULL_N = 25.0        # constant pull along x, N


def _spring(friction_N: float) -> Problem:
    """A body free along x on a spring from the origin (K_N_MM) under a constant pull
    PULL_N, with a sliding resistance of ±`friction_N` against the sign of x: over
    PULL_N, the force jumps from +pull side to -pull side at x = 0 and no x balances it."""

    def wrench(poses):
        x = poses[0][1]
        force = -K_N_MM * x[0] + PULL_N - friction_N * np.sign(x[0])
        w, dw = point_force(x, np.array([force, 0.0, 0.0]),
                            np.diag([-K_N_MM, 0.0, 0.0]))
        return [((0,), w, dw)]

    body = Body("block", np.array([7.0, 0, 0, 0, 0, 0]), (0,))
    return Problem((body,), wrench, force_scale_N=PULL_N, tolerance=1e-10)


def test_a_converging_solve_is_the_same_inside_the_block():
    # no friction: x = PULL_N / K_N_MM (hand statics), found in and out of the block
    free = solve(_spring(0.0))
    with stopping_stalls(3):
        held = solve(_spring(0.0))
    assert free.converged and free.q[0][0] == pytest.approx(PULL_N / K_N_MM, rel=1e-12)
    assert held.converged and held.iterations == free.iterations
    assert held.q[0][0] == free.q[0][0]


def test_a_stalled_solve_stops_after_the_run_of_stalled_steps():
    # friction 2x the pull: every x > 0 is pushed back, every x < 0 forward, the force's
    # size is at least (friction - pull) everywhere; the line search shrinks without end
    stuck = _spring(2.0 * PULL_N)
    full = solve(stuck)
    assert not full.converged and full.iterations == stuck.max_iterations
    with stopping_stalls(3):
        short = solve(stuck)
    assert not short.converged
    assert short.iterations < 20
    assert short.evaluations < full.evaluations / 3
    # the last three steps each took STALL_EVALUATIONS or more evaluations: no headway
    assert short.residual_norm >= PULL_N - 1e-9
    assert STALL_EVALUATIONS * 3 <= short.evaluations
