"""A rigid platen that turns as well as moves (`fecheck.fe.solve.multibody.Condensed` turns):
an off-centre load on two unequal springs splits by its lever arms when the platen turns,
by the springs' stiffness when it is held."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from fecheck.errors import FecheckError
from fecheck.fe.contact.condense import ElasticBody, Pair
from fecheck.fe.solve.multibody import Condensed

K_MINUS, K_PLUS = 1000.0, 3000.0        # N/mm: springs at x = -L and x = +L
L_MM, E_MM, F_N = 10.0, 2.0, 100.0      # half span, load offset along x, load
Y = np.array([0.0, 1.0, 0.0])           # the turn axis, through the origin


def _case(turn: bool, gaps=None):
    """Two vertical springs (z only) at (∓L, 0, 0) under a flat platen pushed down by F at
    (E, 0, 0): the moment on the platen about +y is E F; `gaps` the platen's rigid gaps as
    a function of its travel and turn (None: linear in them)."""
    bed = ElasticBody("bed", sp.diags([K_MINUS, K_PLUS]).tocsc(),
                      np.array([[-1, -1, 0], [-1, -1, 1]]))
    points = np.array([[-L_MM, 0.0, 0.0], [L_MM, 0.0, 0.0]])
    pair = Pair("platen-bed", "bed", np.array([0, 1]), np.tile([0.0, 0.0, 1.0], (2, 1)),
                np.zeros(2), points=points)
    condensed = Condensed([bed], [pair], np.array([0.0, 0.0, -1.0]),
                          turns=[(Y, np.zeros(3))] if turn else ())
    return condensed.solve(np.zeros(2) if gaps is None else gaps, F_N,
                           moments_Nmm=[E_MM * F_N] if turn else None)


def test_a_turning_platen_splits_an_off_centre_load_by_its_lever_arms():
    # Moments about the origin: λ+ L − λ− L = E F, λ+ + λ− = F → λ± = F (1 ± E/L) / 2 =
    # 60 / 40 N, whatever the springs. Compressions 60/3000 = 0.02 and 40/1000 = 0.04 mm
    # = δ ± L θ' with θ' the platen's slope (a turn θ about +y lowers x > 0 by x θ):
    # δ = 0.03 mm, θ = -0.001 rad.
    sol = _case(turn=True)
    np.testing.assert_allclose(sol.pairs["platen-bed"].force_N, [40.0, 60.0], rtol=1e-12)
    assert sol.approach_mm == pytest.approx(0.03, rel=1e-12)
    np.testing.assert_allclose(sol.turns_rad, [-0.001], rtol=1e-12)
    np.testing.assert_allclose(sol.pairs["platen-bed"].gap_mm, 0.0, atol=1e-15)


def test_rigid_gaps_given_as_a_function_hold_exactly_at_the_answer():
    # The flat platen turned by a finite θ about +y and lowered by δ meets the spring at x
    # with the gap −δ − x tan θ. The forces balance on the reference lever arms as above
    # (40 / 60 N, compressions 0.04 / 0.02 mm), so tan θ = −0.001: the loop steps until the
    # exact gaps close, θ = atan(−0.001), 3e-7 off the linear answer's −0.001.
    x = np.array([-L_MM, L_MM])
    sol = _case(turn=True, gaps=lambda q: -q[0] - x * np.tan(q[1]))
    np.testing.assert_allclose(sol.pairs["platen-bed"].force_N, [40.0, 60.0], rtol=1e-12)
    assert sol.approach_mm == pytest.approx(0.03, rel=1e-12)
    np.testing.assert_allclose(sol.turns_rad, [np.arctan(-0.001)], rtol=1e-12)
    assert sol.updates > 2


def test_a_held_platen_splits_it_by_the_springs_stiffness():
    # Held: both springs compress by δ = F / (K− + K+) = 0.025 mm, 25 / 75 N, whatever the
    # offset; the turning platen moves 15 N from the stiff spring to the soft one.
    sol = _case(turn=False)
    np.testing.assert_allclose(sol.pairs["platen-bed"].force_N, [25.0, 75.0], rtol=1e-12)
    assert sol.approach_mm == pytest.approx(0.025, rel=1e-12)
    assert sol.turns_rad.shape == (0,)


def test_a_turn_needs_the_lever_arms_and_one_moment_per_axis():
    bed = ElasticBody("bed", sp.diags([K_MINUS]).tocsc(), np.array([[-1, -1, 0]]))
    bare = Pair("platen-bed", "bed", np.array([0]), np.array([[0.0, 0.0, 1.0]]), np.zeros(1))
    with pytest.raises(FecheckError, match="Pair.points"):
        Condensed([bed], [bare], np.array([0.0, 0.0, -1.0]), turns=[(Y, np.zeros(3))])
    condensed = Condensed([bed], [bare], np.array([0.0, 0.0, -1.0]))
    with pytest.raises(FecheckError, match="one finite moment"):
        condensed.solve(np.zeros(1), F_N, moments_Nmm=[1.0])
