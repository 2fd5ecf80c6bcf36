"""Thin bonded layer asymptotics: a rigid flat punch and a rigid sphere, frictionless, on
an elastic layer of thickness h bonded to a rigid base, in the limit a ≫ h.

The leading-order thin-layer equation (Jaffar 1989, Int. J. Mech. Sci. 31:229-235, for
a layer bonded to a rigid foundation; its incompressible limit is Chadwick 2002, SIAM J.
Appl. Math. 62:1520-1530) follows from the shear-flow profile across the layer: with the
base fixed and the top free of shear, u_r(z) = (∂p/∂r)(z²/2 − hz)/μ carries the flux
−(h³/3μ)∂p/∂r, and the surface's approach w under the pressure p is

    w = p h / M − (h³ / 3μ) ∇²p,       M = λ + 2μ = (1−ν)E / ((1+ν)(1−2ν)),

the column (oedometer) term plus the squeeze of the layer's material out of the contact.
With β² = 3μ / (M h²) (β h → 0 as ν → 1/2):

* flat punch of radius a pressed by δ: p = (M δ / h)(1 − I₀(βr) / I₀(βa)), stiffness
  P/δ = (M π a² / h)(1 − 2 I₁(βa) / (βa I₀(βa))); ν → 1/2: P/δ = 3πμ a⁴ / (8 h³);
  Hayes et al. 1972's P = 2 a E δ κ / (1 − ν²) then reads κ = (1 − ν²)(P/δ) / (2 a E);
* sphere of radius R, contact radius a (p(a) = 0 and, the flux being continuous,
  p'(a) = 0): with x = βa,
  p₀ = (M/h)(a²/R)[1/2 − (I₀(x) − 1)/(x I₁(x))],
  δ = (a²/R)[2/x² + 1/2 − I₀(x)/(x I₁(x))],
  P = 2π(M/h)(a⁴/R)[1/8 − I₀(x)/(2x I₁(x)) + 1/x²];
  the column law (x → ∞: p = (M/h)(δ − r²/2R), δ = a²/2R) and the incompressible
  limit (x → 0: p = 3μ(a² − r²)² / (32 R h³), δ = a²/4R, P = πμ a⁶ / (32 R h³)) are its
  ends. Both neglect terms of relative order h/a (the punch's stiffness, the sphere's
  contact radius) or (h/a)² (the sphere's p₀ and approach), as the FE against them
  shows (`fecheck verify`, thin-punch-*, thin-sphere-*).

Units: mm, N, MPa.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from fecheck.errors import FecheckError


def _moduli(E_MPa: float, nu: float, thickness_mm: float) -> tuple[float, float, float]:
    """(M, μ, β): the column modulus and shear modulus (MPa), β (1/mm)."""
    if not (E_MPa > 0 and 0.0 <= nu < 0.5 and thickness_mm > 0):
        raise FecheckError(f"thin-layer asymptote needs E > 0, ν in [0, 0.5) and h > 0, got "
                           f"E {E_MPa}, ν {nu}, h {thickness_mm}")
    mu = E_MPa / (2 * (1 + nu))
    M = (1 - nu) * E_MPa / ((1 + nu) * (1 - 2 * nu))
    return M, mu, math.sqrt(3 * mu / M) / thickness_mm


def _i1_over_i0(x: float) -> float:
    from scipy.special import ive

    return float(ive(1, x) / ive(0, x))


def flat_punch_stiffness(E_MPa: float, nu: float, thickness_mm: float,
                         punch_radius_mm: float) -> float:
    """P/δ (N/mm) of a rigid frictionless flat punch on the thin bonded layer."""
    M, _, beta = _moduli(E_MPa, nu, thickness_mm)
    a = punch_radius_mm
    x = beta * a
    return M * math.pi * a * a / thickness_mm * (1 - 2 * _i1_over_i0(x) / x)


def hayes_kappa(stiffness_N_per_mm: float, E_MPa: float, nu: float,
                punch_radius_mm: float) -> float:
    """Hayes et al. 1972's κ of a punch stiffness P/δ: κ = (1 − ν²)(P/δ) / (2aE)."""
    return (1 - nu * nu) * stiffness_N_per_mm / (2 * punch_radius_mm * E_MPa)


@dataclass(frozen=True)
class SphereOnThinLayer:
    """The thin-layer answer of a sphere: contact radius a (mm), central pressure p₀
    (MPa), approach δ (mm), load P (N)."""

    radius_mm: float
    max_pressure_MPa: float
    depth_mm: float
    load_N: float


def sphere_at_radius(contact_radius_mm: float, sphere_radius_mm: float, E_MPa: float,
                     nu: float, thickness_mm: float) -> SphereOnThinLayer:
    """The sphere's thin-layer answer at contact radius a (module docstring)."""
    from scipy.special import ive

    M, _, beta = _moduli(E_MPa, nu, thickness_mm)
    a, R, h = contact_radius_mm, sphere_radius_mm, thickness_mm
    x = beta * a
    i0, i1 = float(ive(0, x)), float(ive(1, x))
    g = i0 / (x * i1)                                           # I₀/(x I₁)
    squeeze = (1.0 - math.exp(-x) / i0) * g                    # (I₀ − 1)/(x I₁)
    p0 = M / h * a * a / R * (0.5 - squeeze)
    depth = a * a / R * (2 / x ** 2 + 0.5 - g)
    load = 2 * math.pi * M / h * a ** 4 / R * (0.125 - g / 2 + 1 / x ** 2)
    return SphereOnThinLayer(a, p0, depth, load)


def sphere_on_thin_layer(load_N: float, sphere_radius_mm: float, E_MPa: float, nu: float,
                         thickness_mm: float) -> SphereOnThinLayer:
    """The sphere's thin-layer answer at load P (N): a from P(a) (increasing) by Brent."""
    from scipy.optimize import brentq

    if not load_N > 0:
        raise FecheckError(f"thin-layer sphere needs a positive load, got {load_N} N")

    def excess(a: float) -> float:
        return sphere_at_radius(a, sphere_radius_mm, E_MPa, nu, thickness_mm).load_N - load_N

    hi = thickness_mm
    while excess(hi) < 0:
        hi *= 2
    a = brentq(excess, hi / 2 ** 40, hi, xtol=1e-14 * hi, rtol=1e-14)
    return sphere_at_radius(a, sphere_radius_mm, E_MPa, nu, thickness_mm)
