"""A body carried by the indenter (`fecheck.fe.contact.condense.ElasticBody.carried`: a
cartilage layer bonded to a rigid bone): it moves and turns with the indenter, its displacement is
relative to it, and the contact forces on it load the indenter. Two springs on a bed under
two springs hung from a platen: each contact sees the two in series."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from fecheck.fe.contact.condense import ElasticBody, Pair
from fecheck.fe.solve.multibody import Condensed

K_BED = (1000.0, 3000.0)                # N/mm: bed springs at x = -L and x = +L
K_PAD = (500.0, 1500.0)                 # N/mm: pad springs hung from the platen above them
L_MM, E_MM, F_N = 10.0, 2.0, 100.0      # half span, load offset along x, load
Y = np.array([0.0, 1.0, 0.0])


def _springs(name: str, k: tuple[float, float], carried: bool) -> ElasticBody:
    return ElasticBody(name, sp.diags(list(k)).tocsc(), np.array([[-1, -1, 0], [-1, -1, 1]]),
                carried=carried)


def _case(turn: bool, carried: bool = True, pad_slave: bool = False):
    """The pad's spring tips (master; slave with `pad_slave`) on the bed's, the platen
    pushed down by F at (E, 0, 0) (moment E F about +y); `carried` False: the pad is left
    off (the platen presses the bed directly)."""
    bed = _springs("bed", K_BED, False)
    points = np.array([[-L_MM, 0.0, 0.0], [L_MM, 0.0, 0.0]])
    up = np.tile([0.0, 0.0, 1.0], (2, 1))
    if pad_slave:
        bodies = [bed, _springs("pad", K_PAD, True)]
        pair = Pair("pad-bed", "pad", np.array([0, 1]), -up, np.zeros(2), "bed",
                    np.array([[0], [1]]), np.ones((2, 1)), points=points)
    elif carried:
        bodies = [bed, _springs("pad", K_PAD, True)]
        pair = Pair("pad-bed", "bed", np.array([0, 1]), up, np.zeros(2), "pad",
                    np.array([[0], [1]]), np.ones((2, 1)), points=points)
    else:
        bodies = [bed]
        pair = Pair("pad-bed", "bed", np.array([0, 1]), up, np.zeros(2), points=points)
    condensed = Condensed(bodies, [pair], np.array([0.0, 0.0, -1.0]),
                          turns=[(Y, np.zeros(3))] if turn else ())
    return condensed.solve(np.zeros(2), F_N, moments_Nmm=[E_MM * F_N] if turn else None)


def test_a_carried_pad_adds_its_compliance_in_series():
    # Held: series stiffness 1/(1/1000 + 1/500) = 333.3 and 1/(1/3000 + 1/1500) = 1000
    # N/mm share F as 1 : 3 = 25 / 75 N; travel F / 1333.3 = 0.075 mm, three times the
    # bed's alone (0.025 mm). The pad's tips rise toward the platen by λ / k: 0.05 mm.
    sol = _case(turn=False)
    np.testing.assert_allclose(sol.pairs["pad-bed"].force_N, [25.0, 75.0], rtol=1e-12)
    assert sol.approach_mm == pytest.approx(0.075, rel=1e-12)
    assert _case(turn=False, carried=False).approach_mm == pytest.approx(0.025, rel=1e-12)
    np.testing.assert_allclose(sol.u["pad"], [0.05, 0.05], rtol=1e-12)
    np.testing.assert_allclose(sol.u["bed"], [-0.025, -0.025], rtol=1e-12)


@pytest.mark.parametrize("pad_slave", [False, True])
def test_a_carried_pad_turns_with_the_platen(pad_slave):
    # Turning: the lever arms split F 40 / 60 N whatever the springs; compressions
    # 40 / 333.3 = 0.12 and 60 / 1000 = 0.06 mm = δ ∓ L θ: δ = 0.09 mm, θ = -0.003 rad.
    # The same whichever of the two is the slave.
    sol = _case(turn=True, pad_slave=pad_slave)
    np.testing.assert_allclose(sol.pairs["pad-bed"].force_N, [40.0, 60.0], rtol=1e-12)
    assert sol.approach_mm == pytest.approx(0.09, rel=1e-12)
    np.testing.assert_allclose(sol.turns_rad, [-0.003], rtol=1e-12)
    np.testing.assert_allclose(sol.pairs["pad-bed"].gap_mm, 0.0, atol=1e-14)


def test_a_condensation_reused_after_re_pairing_is_a_fresh_one():
    # Re-pairing moves the master's weights among the dofs it condensed: the compliance
    # taken from the earlier condensation is the one a fresh condensation gives.
    bed, pad = _springs("bed", K_BED, False), _springs("pad", K_PAD, True)
    points = np.array([[-L_MM, 0.0, 0.0], [L_MM, 0.0, 0.0]])
    up = np.tile([0.0, 0.0, 1.0], (2, 1))

    def pair(nodes, weights):
        return Pair("pad-bed", "bed", np.array([0, 1]), up, np.zeros(2), "pad",
                    np.asarray(nodes), np.asarray(weights), points=points)

    axis = np.array([0.0, 0.0, -1.0])
    first = Condensed([bed, pad], [pair([[0, 1], [0, 1]], [[0.5, 0.5], [0.5, 0.5]])], axis)
    for nodes, weights in (([[0, 1], [0, 1]], [[0.9, 0.1], [0.2, 0.8]]),
                           ([[1], [1]], [[1.0], [1.0]])):      # on a part of those dofs
        again = Condensed([bed, pad], [pair(nodes, weights)], axis, reuse=first)
        fresh = Condensed([bed, pad], [pair(nodes, weights)], axis)
        assert again.kept["pad"].solve is first.kept["pad"].solve    # no new factorization
        np.testing.assert_allclose(again.C, fresh.C, rtol=1e-14)
        # by hand: the pad's tips are independent springs, C_ij = Σ_a w_ia w_ja / k_a,
        # plus the bed's 1 / K_i on the diagonal
        w = np.zeros((2, 2))
        np.put_along_axis(w, np.asarray(nodes), np.asarray(weights), axis=1)
        by_hand = w @ np.diag(1.0 / np.asarray(K_PAD)) @ w.T + np.diag(1.0 / np.asarray(K_BED))
        np.testing.assert_allclose(fresh.C, by_hand, rtol=1e-12)


def test_a_body_rebuilt_under_its_name_is_condensed_afresh():
    # A layer rebuilt larger keeps its name but not its stiffness: the condensation reused
    # from before it was rebuilt must not lend it the old compliance. By hand: the pad's
    # tips in series with the bed's, C_ii = 1 / k_pad,i + 1 / k_bed,i, with the new pad's k.
    bed = _springs("bed", K_BED, False)
    points = np.array([[-L_MM, 0.0, 0.0], [L_MM, 0.0, 0.0]])
    up = np.tile([0.0, 0.0, 1.0], (2, 1))
    axis = np.array([0.0, 0.0, -1.0])

    def pairs():
        return [Pair("pad-bed", "bed", np.array([0, 1]), up, np.zeros(2), "pad",
                     np.array([[0], [1]]), np.ones((2, 1)), points=points)]

    first = Condensed([bed, _springs("pad", K_PAD, True)], pairs(), axis)
    stiffer = (4.0 * K_PAD[0], 4.0 * K_PAD[1])
    again = Condensed([bed, _springs("pad", stiffer, True)], pairs(), axis, reuse=first)
    assert again.kept["pad"].solve is not first.kept["pad"].solve
    assert again.kept["bed"].solve is first.kept["bed"].solve       # the bed is the same
    np.testing.assert_allclose(np.diag(again.C), 1.0 / np.asarray(stiffer)
                               + 1.0 / np.asarray(K_BED), rtol=1e-12)
