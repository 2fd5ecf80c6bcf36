"""Exact load-controlled contact (fecheck.fe.contact) and the closed-form references."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.optimize import brentq

from fecheck.errors import FecheckError
from fecheck.fe.contact.active_set import active_set
from fecheck.fe.contact.load_control import solve_contact
from fecheck.reference.closed_forms import ef_sphere_on_plane, hertz_sphere_on_plane


def _spring_bed(n: int = 60):
    """Independent vertical springs under a parabolic indenter: the discrete EF law."""
    rng = np.random.default_rng(3)
    k = rng.uniform(5.0, 15.0, n)
    x = np.linspace(-3.0, 3.0, n)
    g0 = 0.05 * x ** 2
    return k, g0


@pytest.mark.parametrize("solver", ["cholmod", "superlu"])
def test_independent_springs_match_the_hand_solution(solver):
    k, g0 = _spring_bed()
    load = 25.0
    # Hand solution: Σ k_i max(0, δ - g0_i) = F, solved by bracketing.
    delta = brentq(lambda d: np.sum(k * np.maximum(0.0, d - g0)) - load, 0.0, 10.0, xtol=1e-14)
    sol = solve_contact(sp.diags(k), np.arange(len(k)), lambda shift: g0, load, 0.01,
                        solver=solver)
    assert sol.delta_mm == pytest.approx(delta, rel=1e-10)
    np.testing.assert_allclose(sol.force_N, k * np.maximum(0.0, delta - g0), atol=1e-10)
    assert sol.force_N.sum() == pytest.approx(load, rel=1e-12)


def test_coupled_contact_is_complementary_and_balances_the_load():
    # A 1D chain of springs (a bar on an elastic bed): coupled nodes, smooth indenter.
    n = 80
    main = np.full(n, 2.0 + 0.05)
    K = sp.diags([main, -np.ones(n - 1), -np.ones(n - 1)], [0, 1, -1]).tocsc()
    g0 = 0.02 * np.linspace(-4, 4, n) ** 2
    sol = solve_contact(K, np.arange(n), lambda shift: g0, 3.0, 0.0)
    assert sol.force_N.sum() == pytest.approx(3.0, rel=1e-12)
    assert sol.force_N.min() >= 0.0
    assert sol.gap_mm.min() > -1e-12
    assert np.max(np.abs(sol.force_N * sol.gap_mm)) < 1e-12
    # Equilibrium of the whole chain: K u = -λ.
    np.testing.assert_allclose(K @ sol.u, -sol.force_N, atol=1e-10)


def test_a_nonpositive_load_is_rejected():
    k, g0 = _spring_bed()
    with pytest.raises(FecheckError, match="load"):
        solve_contact(sp.diags(k), np.arange(len(k)), lambda s: g0, -1.0, 0.0)


def test_ef_closed_form_matches_design_reference_values():
    # Exact EF closed forms: medial d 0.955 mm, A 150.1 mm², p_max 4.28 MPa, p_mean 2.16 MPa;
    # lateral d 1.015, A 199.5, p_max 4.55, p_mean 2.29 (printed to 3-4 digits).
    m = ef_sphere_on_plane(323.71, 25.5, 20.0, 0.3, 6.0)
    lat = ef_sphere_on_plane(456.67, 31.8, 20.0, 0.3, 6.0)
    for got, want in ((m.depth_mm, 0.955), (m.area_mm2, 150.1), (m.max_pressure_MPa, 4.28),
                      (m.mean_pressure_MPa, 2.16), (lat.depth_mm, 1.015),
                      (lat.area_mm2, 199.5), (lat.max_pressure_MPa, 4.55),
                      (lat.mean_pressure_MPa, 2.29)):
        assert got == pytest.approx(want, abs=0.006 * want)


def test_hertz_closed_form_is_self_consistent():
    h = hertz_sphere_on_plane(800.0, 30.0, 20.0, 0.3)
    a = np.sqrt(h.area_mm2 / np.pi)
    # F = 4/3 E* R^1/2 d^3/2 and p0 = 3F / (2πa²) with d = a²/R.
    e_star = 20.0 / (1 - 0.09)
    assert 4 / 3 * e_star * np.sqrt(30.0) * h.depth_mm ** 1.5 == pytest.approx(800.0, rel=1e-12)
    assert h.max_pressure_MPa == pytest.approx(1.5 * h.mean_pressure_MPa, rel=1e-12)
    assert h.depth_mm == pytest.approx(a * a / 30.0, rel=1e-12)


def test_condensed_compliance_equals_the_solves_it_replaces():
    # a P2 layer's compliance along tilted unit directions at scattered surface nodes,
    # against K⁻¹ column by column; and its solver solves K
    from fecheck.fe.bodies.solid import layer_solid
    from fecheck.fe.contact.compliance import condensed_compliance
    from geometry.plateau import plane_patch

    sheet = plane_patch((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), radius=8.0, size=2.0, cache=False)
    solid = layer_solid(sheet, 3.0, 20.0, 0.45, layers=2)
    rng = np.random.default_rng(3)
    nodes = rng.choice(sheet.n_points, 25, replace=False)
    directions = rng.normal(size=(25, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    C, solve = condensed_compliance(solid.K, solid.vertex_dofs[nodes], directions)
    rows = np.zeros((25, solid.K.shape[0]))
    rows[np.arange(25)[:, None], solid.vertex_dofs[nodes]] = directions
    K = solid.K.toarray()
    reference = rows @ np.linalg.solve(K, rows.T)
    assert np.abs(C - reference).max() <= 1e-10 * np.abs(reference).max()
    b = rng.normal(size=K.shape[0])
    assert np.linalg.norm(K @ solve(b) - b) <= 1e-10 * np.linalg.norm(b)


def test_deformed_gap_is_read_where_the_load_moves_the_surface():
    # One candidate (vertical dof 0) coupled to its tangential dof 1: K = [[k, c], [c, kt]].
    # The indenter pushes it down with F, so u = K⁻¹ (-F, 0) = (-kt F, c F) / (k kt - c²):
    # by hand, with k = 10, kt = 4, c = 2, F = 3 N, the node slides u_t = +1/6 mm. The gap
    # must be re-evaluated there (the shift passed to gap0), not at -1/6 mm.
    K = sp.csc_matrix(np.array([[10.0, 2.0], [2.0, 4.0]]))
    seen = []

    def gap0(shift):
        seen.append(None if shift is None else shift.copy())
        return np.array([0.1]) if shift is None else 0.1 + 0.05 * shift[:, 0]

    sol = solve_contact(K, np.array([0]), gap0, 3.0, 0.0, tangential=[np.array([1])],
                        deformed_gap=True)
    assert seen[-1] is not None
    assert seen[-1][0, 0] == pytest.approx(1.0 / 6.0, rel=1e-12)
    assert sol.u[1] == pytest.approx(1.0 / 6.0, rel=1e-12)   # the field it solved agrees
    assert sol.u[0] == pytest.approx(-1.0 / 3.0, rel=1e-12)  # -kt F / det = -12/36 mm


def test_active_set_by_hand():
    # two candidates of compliance 1 mm/N, gaps 0 and 0.5 mm, pushed by δ with 1 N: from
    # {0}: λ0 = 1, δ = 1, candidate 1 penetrates (0.5 − 1 < 0) and joins; then
    # λ0 − δ = 0, λ1 − δ = −0.5, λ0 + λ1 = 1: δ = 0.75, λ = (0.75, 0.25)
    lam, step, active, it = active_set(np.eye(2), np.array([0.0, 0.5]), -np.ones((2, 1)),
                                       np.ones((2, 1)), np.array([-1.0]), np.zeros((1, 1)),
                                       np.array([True, False]), 10, "hint")
    assert lam == pytest.approx([0.75, 0.25], abs=1e-14) and step == pytest.approx([0.75])
    assert active.tolist() == [True, True] and it == 2
