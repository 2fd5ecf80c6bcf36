"""Thin bonded layers: the asymptotes of `fecheck.reference.thin_layer` against their limits
and a numerical solve of their equation, and the axisymmetric FE (flat punch, sphere)
against them (the `fecheck verify` cases thin-punch-*, thin-sphere-*)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fecheck.errors import FecheckError
from fecheck.reference import thin_layer as tl

E, R, A = 20.0, 100.0, 10.0


def _moduli(nu: float) -> tuple[float, float]:
    mu = E / (2 * (1 + nu))
    return (1 - nu) * E / ((1 + nu) * (1 - 2 * nu)), mu


def test_sphere_tends_to_the_incompressible_limit():
    # ν → 1/2 (βa 0.005): p = 3μ(a² − r²)²/(32Rh³), δ = a²/4R, P = πμa⁶/(32Rh³)
    # (the thin-layer equation's incompressible solution, Chadwick 2002)
    nu, h = 0.5 - 1e-7, 1.0
    _, mu = _moduli(nu)
    s = tl.sphere_at_radius(A, R, E, nu, h)
    assert s.max_pressure_MPa == pytest.approx(3 * mu * A ** 4 / (32 * R * h ** 3), rel=1e-5)
    assert s.depth_mm == pytest.approx(A * A / (4 * R), rel=1e-5)
    assert s.load_N == pytest.approx(math.pi * mu * A ** 6 / (32 * R * h ** 3), rel=1e-5)


def test_sphere_and_punch_tend_to_the_column_law():
    # βa ≫ 1 (h/a 1e-4 at ν 0.3): p = (M/h)(δ − r²/2R), δ = a²/2R, P = πMa⁴/(4Rh);
    # punch P/δ = Mπa²/h; the squeeze corrections are O(1/βa) = O(1e-4)
    nu, h = 0.3, 1e-3
    M, _ = _moduli(nu)
    s = tl.sphere_at_radius(A, R, E, nu, h)
    assert s.max_pressure_MPa == pytest.approx(M / h * A * A / (2 * R), rel=1e-3)
    assert s.depth_mm == pytest.approx(A * A / (2 * R), rel=1e-3)
    assert s.load_N == pytest.approx(math.pi * M * A ** 4 / (4 * R * h), rel=1e-3)
    assert tl.flat_punch_stiffness(E, nu, h, A) == pytest.approx(M * math.pi * A * A / h,
                                                                 rel=1e-3)


def test_punch_tends_to_the_incompressible_limit():
    nu, h = 0.5 - 1e-7, 1.0
    _, mu = _moduli(nu)
    assert tl.flat_punch_stiffness(E, nu, h, A) == pytest.approx(
        3 * math.pi * mu * A ** 4 / (8 * h ** 3), rel=1e-5)
    # Hayes et al. 1972's κ = (1 − ν²)(P/δ)/(2aE)
    assert tl.hayes_kappa(2 * A * E, E, 0.0, A) == pytest.approx(1.0)


@pytest.mark.parametrize("nu", [0.3, 0.49])
def test_sphere_solves_the_thin_layer_equation(nu):
    # Solve L²(1/r)(r p')' − p = −(M/h)(δ − r²/2R), L² = h²M/3μ, on (0, a) by second-order
    # finite volumes (20,000 cells) with p(a) = 0 at the closed form's δ: the flux
    # condition p'(a) = 0 must then hold, and p(0), ∫2πr p dr must be p₀ and P.
    import scipy.sparse as sp
    import scipy.sparse.linalg as sla

    h, n = 1.0, 20000
    M, mu = _moduli(nu)
    s = tl.sphere_at_radius(A, R, E, nu, h)
    L2 = h * h * M / (3 * mu)
    dr = A / n
    r = np.arange(n) * dr                                     # p(a) = p_n = 0 eliminated
    right, left = (r + dr / 2) / np.maximum(r, dr) / dr ** 2, \
        (r - dr / 2) / np.maximum(r, dr) / dr ** 2
    right[0], left[0] = 4 / dr ** 2, 0.0                      # ∇²p = 4(p₁ − p₀)/dr² at 0
    main = -L2 * (right + left) - 1.0
    K = sp.diags([main, L2 * left[1:], L2 * right[:-1]], [0, -1, 1], format="csc")
    p = sla.spsolve(K, -M / h * (s.depth_mm - r * r / (2 * R)))
    slope_a = (0.0 - 4 * p[-1] + p[-2]) / (2 * dr)            # one-sided, second order
    load = 2 * np.pi * np.trapezoid(np.append(r, A) * np.append(p, 0.0), dx=dr)
    assert p[0] == pytest.approx(s.max_pressure_MPa, rel=1e-5)
    assert abs(slope_a) < 1e-4 * s.max_pressure_MPa / A
    assert load == pytest.approx(s.load_N, rel=1e-5)


def test_sphere_at_load_inverts_the_load():
    s = tl.sphere_at_radius(7.0, R, E, 0.45, 1.0)
    back = tl.sphere_on_thin_layer(s.load_N, R, E, 0.45, 1.0)
    assert back.radius_mm == pytest.approx(7.0, rel=1e-10)
    with pytest.raises(FecheckError, match="ν in \\[0, 0.5\\)"):
        tl.flat_punch_stiffness(E, 0.5, 1.0, A)


def test_fe_flat_punch_tends_to_the_column_law():
    # ν 0.3, h/a 0.05 and 0.025: the FE's P/δ exceeds Mπa²/h by O(h/a) (the punch's edge;
    # measured +1.38 % and +0.69 %): within 2 % and 1 %, halving with h/a
    from fecheck.studies.verify_problems import thin_punch

    errs = []
    for h_over_a, tol in ((0.05, 0.02), (0.025, 0.01)):
        fe, ref = thin_punch(h_over_a, 0.3, True)
        errs.append(fe / ref - 1)
        assert 0 < errs[-1] < tol
    assert errs[0] / errs[1] == pytest.approx(2.0, abs=0.2)


def test_fe_sphere_on_a_near_incompressible_thin_layer():
    # ν 0.49 (mixed), h/a 0.05: p₀ and approach within 2 % of the thin-layer asymptote
    # (measured +1.4 %, -1.0 %), contact radius within 8 % (its O(h/a) term: -7.0 %)
    from fecheck.studies.verify_problems import thin_sphere

    for quantity, tol in (("p_max", 0.02), ("depth", 0.02), ("radius", 0.08)):
        fe, ref = thin_sphere(0.05, 0.49, quantity)
        assert fe == pytest.approx(ref, rel=tol), quantity


def test_thin_layer_cases_pass_in_quick_mode():
    from fecheck.studies import verify

    rows = [verify.run_case(c, quick=True) for c in verify.select(["thin-punch",
                                                                   "thin-sphere"])]
    assert len(rows) == 6
    assert [r.status for r in rows] == ["pass"] * 6, [(r.case.name, r.error, r.order)
                                                       for r in rows]
