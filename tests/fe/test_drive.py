"""The outer loop shared by every FE contact solve with rigid unknowns, on a rigid bar that
slides and turns on springs: its answer must satisfy the bar's own nonlinear equations (hand
statics), not their linearisation."""

import numpy as np
import pytest

from fecheck.errors import FecheckError
from fecheck.fe.solve.drive import Linearised, equilibrium

X = np.array([-20.0, -5.0, 10.0, 25.0])
"""The springs' places along the bar, mm."""
HEIGHT = np.array([0.3, 0.1, 0.0, 0.2])
"""Each spring's gap under the bar at q = 0, mm."""
COMPLIANCE = 2e-3
"""Each spring's compliance, mm/N."""


def bar(force: float, moment: float):
    """The bar lowered by q[0] (mm) and turned by q[1] (rad, finite) onto four springs,
    pushed down by `force` (N) and turned by `moment` (N·mm): gap g_i = h_i − q0 − x_i sin
    q1, a spring's force acts on the bar with the arm x_i cos q1."""

    def linearise(q: np.ndarray, lam: np.ndarray | None) -> Linearised:
        g0 = HEIGHT - q[0] - X * np.sin(q[1])
        J = -np.column_stack([np.ones_like(X), X * np.cos(q[1])])
        return Linearised(g0, J, J, COMPLIANCE * np.eye(len(X)), np.array([force, moment]),
                          np.zeros((2, 2)))

    return linearise


def solve(force: float, moment: float, **kwargs):
    kwargs = {"scale": np.array([1.0, 30.0]), "tolerance": 1e-12, "max_outer": 40,
              "max_active": 50, "hint": "check the bar", "failure": "the bar does not settle"
              } | kwargs
    return equilibrium(bar(force, moment), lambda lin, active: lin.g0 <= np.sort(lin.g0)[1]
                       if active is None else active, np.zeros(2), **kwargs)


@pytest.mark.parametrize("force, moment", [(400.0, 0.0), (400.0, 2500.0), (900.0, -9000.0)])
def test_the_bar_balances_with_finite_turns(force, moment):
    out = solve(force, moment)
    z, theta = out.q
    gap = HEIGHT - z - X * np.sin(theta) + COMPLIANCE * out.lam
    assert np.all(out.lam >= 0.0)
    assert np.all(gap >= -1e-10)
    np.testing.assert_allclose(out.lam * gap, 0.0, atol=1e-9)
    assert out.lam.sum() == pytest.approx(force, rel=1e-10)
    assert (out.lam * X * np.cos(theta)).sum() == pytest.approx(moment, abs=1e-7)
    np.testing.assert_allclose(out.gap_mm, gap, atol=1e-10)


def test_a_large_moment_lifts_a_spring_and_turns_the_bar_far():
    out = solve(300.0, 6000.0)
    assert out.lam[0] == 0.0 and out.lam[-1] > 0.0
    assert abs(out.q[1]) > 0.02                      # a turn whose sine and angle differ
    assert out.outer > 2


def test_a_long_step_is_shortened_and_still_converges():
    free = solve(900.0, -9000.0)
    short = solve(900.0, -9000.0, max_step=0.05)
    assert short.outer > free.outer
    np.testing.assert_allclose(short.q, free.q, atol=1e-10)


def test_a_loop_that_does_not_settle_says_so():
    with pytest.raises(FecheckError, match="the bar does not settle"):
        solve(900.0, -9000.0, max_outer=1)


def test_a_gap_that_is_not_a_number_is_refused_not_passed_on():
    def broken(q, lam):
        lin = bar(400.0, 0.0)(q, lam)
        return Linearised(np.where(X > 0, np.nan, lin.g0), lin.J, lin.G, lin.C, lin.Q, lin.dQ)

    with pytest.raises(FecheckError, match="not a number; check the bar"):
        equilibrium(broken, lambda lin, active: np.ones(len(X), dtype=bool), np.zeros(2),
                    scale=np.ones(2), tolerance=1e-12, max_outer=5, max_active=5,
                    hint="check the bar", failure="unused")
