"""The code-verification suite of `fecheck verify`: one case per quantity, each solved at
two or three discretization levels, its observed order and its error at the finest level
checked against a stated expectation.

A case is judged in one of three ways:

* against a closed form, order from the errors: p = ln(e1/e2)/ln(h1/h2) of the last two
  levels (manufactured solutions, the EF on meshes, the thin-layer limits of a sphere
  and a flat punch);
* against a closed form for the error, order from the values (three levels, Richardson:
  `fecheck.studies.gci`), where the model error does not vanish with h (a 60 mm block is
  not a half-space: the Hertz case);
* against its own refinement (three levels; the error is the Richardson estimate), where
  no closed form exists (the axisymmetric layer at several ν);

and an exactness case (no order: the error must be round-off at every level: patch tests,
load scaling, invariance). A case passes when its error is within its tolerance and its
order within its band; a case with a stated known limitation that fails is reported as
"known" (it does not fail the suite) and one that then passes as "pass".

Units: mm, N, MPa; h is the element size (mm), the cells per side, the icosphere level
mapped to a size, or h/a, as each case says.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import partial

from fecheck.errors import FecheckError
from fecheck.studies import verify_problems as vp
from fecheck.studies.gci import gci, observed_order


@dataclass(frozen=True)
class Case:
    """One verification case.

    name, group : identifiers (the group shares a plot)
    verifies : what the case verifies, one line
    reference : the exact answer and its source
    quantity : the number compared
    levels, quick_levels : discretization parameters h, coarse to fine
    solve : h → (value, exact or None)
    expected : expected order (None: exact to round-off, no order)
    band : accepted observed orders (lo, hi)
    tolerance : largest accepted relative error at the finest level (absolute for exactness)
    order_from : "error" (closed-form errors) or "values" (three levels, Richardson)
    known : the known limitation that explains a failure ('' if none)
    """

    name: str
    group: str
    verifies: str
    reference: str
    quantity: str
    levels: tuple[float, ...]
    quick_levels: tuple[float, ...]
    solve: Callable[[float], tuple[float, float | None]]
    expected: float | None
    band: tuple[float, float]
    tolerance: float
    order_from: str = "error"
    known: str = ""


@dataclass(frozen=True)
class Row:
    """The outcome of one case: levels, values, errors, observed order, status."""

    case: Case
    levels: tuple[float, ...]
    values: tuple[float, ...]
    errors: tuple[float, ...]
    error: float
    order: float
    status: str
    seconds: float
    note: str = field(default="")

    def as_dict(self) -> dict:
        c = self.case
        return {"case": c.name, "group": c.group, "quantity": c.quantity,
                "reference": c.reference, "levels": " ".join(f"{h:g}" for h in self.levels),
                "error": _finite(self.error), "observed_order": _finite(self.order),
                "expected_order": _no_order(c) if c.expected is None else c.expected,
                "band": "" if c.expected is None else f"{c.band[0]:g}-{c.band[1]:g}",
                "tolerance": c.tolerance, "status": self.status,
                "time_s": round(self.seconds, 2), "verifies": c.verifies,
                "note": self.note or c.known}


def _no_order(case: Case) -> str:
    """The expectation of a case judged without an order: 'exact' (round-off) or within
    its tolerance."""
    return "exact" if case.tolerance < 1e-6 else f"<= {case.tolerance:g}"


def _finite(x: float) -> float | None:
    return None if not math.isfinite(x) else float(x)


def judge(case: Case, levels: Sequence[float], samples: Sequence[tuple[float, float | None]]
          ) -> tuple[tuple[float, ...], float, float, str, str]:
    """(errors per level, error at the finest, observed order, status, note) of `case`
    from its (value, exact) `samples` at `levels` (coarse to fine)."""
    values = [v for v, _ in samples]
    exact = samples[-1][1]
    if exact is None:
        errors = [math.nan] * len(values)
    else:
        errors = [abs(v - e) / abs(e) if e else abs(v) for v, e in samples]
    note = ""
    if case.expected is None:
        order, error = math.nan, max(errors)
        ok = error <= case.tolerance
    else:
        if case.order_from == "values":
            if len(values) < 3:
                raise FecheckError(f"verify case {case.name}: Richardson needs 3 levels")
            res = gci(values[::-1], [levels[-2] / levels[-1], levels[-3] / levels[-2]])
            order = res.order
            if not res.monotone:
                note = "oscillatory convergence"
            if exact is None:
                error = abs(values[-1] - res.extrapolated) / abs(res.extrapolated)
                errors[-1] = error
            else:
                error = errors[-1]
        else:
            order, error = observed_order(errors, levels), errors[-1]
        ok = (error <= case.tolerance and math.isfinite(order)
              and case.band[0] <= order <= case.band[1])
    status = "pass" if ok else ("known" if case.known else "FAIL")
    return tuple(errors), error, order, status, note


def run_case(case: Case, quick: bool) -> Row:
    """Solve `case` at its (quick) levels and judge it."""
    levels = case.quick_levels if quick else case.levels
    t = time.perf_counter()
    samples = [case.solve(h) for h in levels]
    errors, error, order, status, note = judge(case, levels, samples)
    return Row(case, tuple(levels), tuple(v for v, _ in samples), errors, error, order,
               status, time.perf_counter() - t, note)


def run_suite(cases: Sequence[Case], quick: bool,
              log: Callable[[Row], None] | None = None) -> list[Row]:
    """Every case of `cases`, in order; `log` sees each row as it finishes."""
    rows = []
    for case in cases:
        row = run_case(case, quick)
        rows.append(row)
        if log:
            log(row)
    return rows


def select(only: Sequence[str] | None) -> list[Case]:
    """The cases whose name or group contains one of `only` (all when None)."""
    every = cases()
    if not only:
        return every
    chosen = [c for c in every if any(s in c.name or s in c.group for s in only)]
    if not chosen:
        raise FecheckError(f"no verification case matches {' '.join(only)}: "
                           "`fecheck verify --list` lists them")
    return chosen


# ---------------------------------------------------------------- the cases
def _cells(f: Callable, index: int, *args) -> Callable[[float], tuple[float, float]]:
    """h → (item `index` of f(1/h cells a side, *args), 0): a problem returning relative
    errors, judged against zero."""
    def solve(h: float) -> tuple[float, float]:
        return f(round(1.0 / h), *args)[index], 0.0
    return solve


_MMS = "u = (1, 0.5, -0.3)·sin πx sin πy sin πz on the unit cube, f = −div σ(u)"
_CAP = "EF cap F = k·πd²(R − d/3), A = π(2Rd − d²) (Istace 2024 eq. 4.3)"
_ICO = {3: 4.0, 4: 2.0, 5: 1.0}
"""Icosphere level → relative face size (each level halves the edges)."""


def _ico(quantity: str) -> Callable[[float], tuple[float, float]]:
    level = {v: k for k, v in _ICO.items()}

    def solve(h: float) -> tuple[float, float]:
        return vp.ef_icosphere(level[h], quantity)
    return solve


def _exactness(name: str, group: str, verifies: str, reference: str, quantity: str,
               solve: Callable[[float], float], levels: tuple[float, ...],
               tolerance: float) -> Case:
    return Case(name, group, verifies, reference, quantity, levels, levels,
                lambda h: (solve(h), 0.0), None, (0.0, 0.0), tolerance)


def cases() -> list[Case]:
    """The suite, in report order."""
    out: list[Case] = []
    for nu in (0.3, 0.45, 0.49):
        low = 1.6 if nu > 0.48 else 1.75     # near-locking: pre-asymptotic at 3-6 cells
        out.append(Case(f"mms-3d-L2-nu{nu}", "manufactured 3-D P2",
                        f"fecheck's P2 elasticity assembly and solve, ν {nu}", _MMS,
                        "relative L2 error of u", (1 / 2, 1 / 4, 1 / 8), (1 / 3, 1 / 6),
                        _cells(vp.manufactured_3d, 0, nu), 3.0, (2.7, 3.4), 0.02))
        out.append(Case(f"mms-3d-energy-nu{nu}", "manufactured 3-D P2",
                        f"the same, energy (H1-seminorm) error, ν {nu}"
                        + (" (near-locking: 1.8 at 3-6 cells, 2.0 at 4-8)" if nu > 0.48
                           else ""), _MMS,
                        "relative H1-seminorm error of u", (1 / 2, 1 / 4, 1 / 8),
                        (1 / 3, 1 / 6), _cells(vp.manufactured_3d, 1, nu), 2.0, (low, 2.3), 0.08))
    out += [
        _exactness("patch-P2-nu0.3", "patch", "P2 solve reproduces a linear field, "
                   "distorted mesh", "u = A x + b", "max |u_h − u| (mm)",
                   lambda h: vp.patch_p2(int(h), 0.3), (3,), 1e-10),
        _exactness("patch-P2-nu0.49", "patch", "the same at ν 0.49", "u = A x + b",
                   "max |u_h − u| (mm)", lambda h: vp.patch_p2(int(h), 0.49), (3,), 1e-10),
        _exactness("patch-traction-P2-nu0.3", "patch", "P2 solve under a uniform top "
                   "pressure, symmetry planes, free sides (reads the traction boundary)",
                   "u = σ(νx, νy, −z)/E", "max |u_h − u| (mm)",
                   lambda h: vp.patch_traction(int(h), 0.3), (3,), 1e-10),
        _exactness("patch-traction-P2-nu0.49", "patch", "the same at ν 0.49",
                   "u = σ(νx, νy, −z)/E", "max |u_h − u| (mm)",
                   lambda h: vp.patch_traction(int(h), 0.49), (3,), 1e-10),
        _exactness("patch-P1-nu0.3", "patch", "linear tetrahedra (scikit-fem form), "
                   "distorted mesh", "u = A x + b", "max |u_h − u| (mm)",
                   lambda h: vp.patch_p1(int(h), 0.3), (3,), 1e-10),
        _exactness("load-scaling-nu0.3", "load scaling", "bonded layer without contact: "
                   "u ∝ load", "u(3.7 f) = 3.7 u(f)", "relative difference",
                   lambda h: vp.load_scaling(0.3), (1,), 1e-10),
        _exactness("load-scaling-nu0.49", "load scaling", "the same at ν 0.49",
                   "u(3.7 f) = 3.7 u(f)", "relative difference",
                   lambda h: vp.load_scaling(0.49), (1,), 1e-10),
        Case("ef-icosphere-force", "EF mesh independence", "EF force of an icosphere "
             "(clipped quadrature) converges to the cap", _CAP, "force at d 0.955 mm",
             (4.0, 2.0, 1.0), (4.0, 2.0, 1.0), _ico("force"), 2.0, (1.8, 2.2), 0.015),
        Case("ef-icosphere-area", "EF mesh independence", "EF area of an icosphere "
             "converges to the cap's", _CAP, "area at d 0.955 mm",
             (4.0, 2.0, 1.0), (4.0, 2.0, 1.0), _ico("area"), 2.0, (1.8, 2.2), 0.01),
        Case("ef-plate-force", "EF mesh independence", "EF force of a flat plate under an "
             "analytic sphere", _CAP, "force at d 0.955 mm (h: element size, mm)",
             (1.0, 0.5, 0.25), (1.0, 0.5), vp.ef_plate, 2.0, (1.8, 2.3), 0.005),
    ]
    for tilt, spin in ((10.0, 0.0), (20.0, 0.0), (20.0, 30.0)):
        out.append(_exactness(f"ef-invariance-tilt{tilt:g}-spin{spin:g}", "invariance",
                              f"EF of sphere and plane tilted {tilt:g}° about x and turned "
                              f"{spin:g}° about z", "the flat answer",
                              "max relative change of |F|, area, p_max",
                              partial(lambda h, t, s: vp.ef_invariance(t, s), t=tilt, s=spin),
                              (4,), 1e-10))
    for tilt, spin in ((10.0, 0.0), (20.0, 30.0)):
        out.append(_exactness(f"fe3d-invariance-tilt{tilt:g}-spin{spin:g}", "invariance",
                              f"3-D FE contact (extruded layer, sphere, load) tilted {tilt:g}° "
                              f"about x and turned {spin:g}° about z, the same mesh turned",
                              "the flat answer", "max relative change of p_max, force, "
                              "approach, contact vertices",
                              partial(lambda h, t, s: vp.fe3d_invariance(t, s), t=tilt,
                                      s=spin), (1,), 1e-9))
    out.append(_exactness("hertz-two-bodies", "Hertz", "Hertz law with the two-body "
                          "modulus (20 MPa layer on a 460 MPa body)",
                          "P = 4/3 E*√R d^1.5, 1/E* = Σ(1 − ν²)/E (Johnson 1985 §4.2)",
                          "relative force error", lambda h: vp.hertz_two_bodies(), (1,),
                          1e-12))
    hertz = "Hertz, rigid sphere on a half-space (Johnson 1985 §4.2)"
    out += [
        Case("hertz-block-pmax", "Hertz", "axisymmetric FE of a 60 mm block (a/h 0.04) vs "
             "Hertz; order from the values (the block's 0.1 % model error does not vanish "
             "with h); contact-edge-limited", hertz, "p_max", (0.2, 0.1, 0.05),
             (0.4, 0.2, 0.1), partial(lambda h, q: vp.axisym_hertz(h, q), q="p_max"),
             2.0, (1.0, 3.0), 0.01, "values"),
        Case("hertz-block-radius", "Hertz", "the same, contact radius: resolved to half "
             "an element (contact-edge-limited, order ~1)", hertz, "contact radius",
             (0.2, 0.1, 0.05), (0.2, 0.1, 0.05),
             partial(lambda h, q: vp.axisym_hertz(h, q), q="radius"), 1.5, (0.8, 2.5), 0.03),
    ]
    axisym = "the axisymmetric FE at 0.05 mm (its own error ~1e-5: axisym-layer-nu0.3)"
    out += [
        Case("fe3d-layer-depth", "3-D FE contact", "the 3-D FE contact path (extruded P2 "
             "layer, exact contact) converges to the axisymmetric answer; indentation "
             "depth (its p_max converges non-monotonically: -1.8, -0.4, +0.3 %)", axisym,
             "depth (h: element under the contact, mm)", (1.6, 0.8, 0.4), (1.6, 0.8),
             partial(lambda h, q: vp.fe3d_layer(h, q), q="depth"), 2.0, (1.7, 3.2), 0.005),
        Case("fe3d-layer-area", "3-D FE contact", "the same, contact area (zero contour "
             "of the recovered pressure)", axisym, "area (h: element under the contact, mm)",
             (1.6, 0.8, 0.4), (1.6, 0.8),
             partial(lambda h, q: vp.fe3d_layer(h, q), q="area"), 2.0, (1.5, 3.5), 0.02),
    ]
    ring = ("the axisymmetric FE of the same ring at 0.1 mm (0.2 → 0.1 mm moves each "
            "< 0.2 %: tests/fe/test_ring_meniscus.py)")
    for quantity, label in (("share", "meniscus load share"), ("p_max_MPa", "layer vertex "
                            "p_max"), ("area_mm2", "layer contact area")):
        out.append(Case(f"ring-meniscus-{quantity.split('_MPa')[0].split('_mm')[0]}",
                        "FE with menisci",
                        "3-D quarter model (Gmsh tetrahedra, multibody contact) of a "
                        "hoop-stiff ring meniscus between a rigid sphere and a bonded layer "
                        "against the axisymmetric FE, within 3 %", ring,
                        f"{label} (h: element size, mm)", (0.8, 0.6), (0.8,),
                        partial(lambda h, q: vp.ring_meniscus(h, q), q=quantity), None,
                        (0.0, 0.0), 0.03))
    for nu in (0.3, 0.45, 0.49, 0.4999):
        known = ("volumetric locking of the displacement-only P2 layer: p_max does not "
                 "converge at ν 0.4999 (a mixed u-p formulation is needed)"
                 if nu > 0.499 else "")
        out.append(Case(f"axisym-layer-nu{nu}", "axisymmetric layer",
                        f"axisymmetric sphere on a 6 mm bonded layer, ν {nu}: self-"
                        "convergence (contact-edge-limited order 1-3)",
                        "its own Richardson extrapolation (Roache 1998)", "p_max",
                        (0.2, 0.1, 0.05), (0.2, 0.1, 0.05),
                        partial(lambda h, n: vp.axisym_layer(h, n), n=nu), 1.5, (1.0, 3.0),
                        0.01, "values", known))
    column = ("column law p = k·d, k = (1−ν)E/((1+ν)(1−2ν)h): the a ≫ h limit of a "
              "bonded compressible layer (Johnson 1985 §5.9; Jaffar 1989)")
    out += [
        Case("thin-layer-pmax", "thin layer", "FE of a thin bonded layer (ν 0.3) tends to "
             "the column law as h/a → 0 (order: of the asymptotic correction, in h/a)",
             column, "p_max (h: h/a)", (0.2, 0.1, 0.05), (0.2, 0.1),
             partial(lambda h, q: vp.thin_layer(h, q), q="p_max"), 2.0, (1.7, 2.4), 0.003),
        Case("thin-layer-depth", "thin layer", "the same, indentation depth", column,
             "depth (h: h/a)", (0.2, 0.1, 0.05), (0.2, 0.1),
             partial(lambda h, q: vp.thin_layer(h, q), q="depth"), 1.5, (1.2, 2.0), 0.002),
    ]
    out += _thin_layer_cases()
    return out


def _thin_layer_cases() -> list[Case]:
    """A rigid flat punch and a rigid sphere on a thin bonded layer against the thin-layer
    asymptotes (`fecheck.reference.thin_layer`), h/a → 0: each asymptote neglects terms
    of relative order h/a (a punch's edge, the sphere's contact radius) or (h/a)² (the
    sphere's p₀ and approach), the order the FE's error must show (its own error at h/8
    elements is far smaller: p₀ moves 0.03 % from h/8 to h/16 at h/a 0.1)."""
    punch = {0.3: "column law P/δ = Mπa²/h, M = (1−ν)E/((1+ν)(1−2ν)): the leading term "
                  "for a compressible layer (Jaffar 1989)",
             0.4999: "thin-layer punch P/δ = (Mπa²/h)(1 − 2I₁(βa)/(βa I₀(βa))), "
                     "β² = 3μ/(Mh²) (Jaffar 1989; → 3πμa⁴/(8h³) as ν → 1/2)"}
    sphere = ("thin-layer sphere (Jaffar 1989; ν → 1/2: p = 3μ(a² − r²)²/(32Rh³), "
              "δ = a²/4R, Chadwick 2002), a 10 mm, R 100 mm")
    out = []
    for nu, levels, quick, tol in ((0.3, (0.2, 0.1, 0.05), (0.1, 0.05), 0.02),
                                   (0.4999, (0.1, 0.05, 0.025), (0.05, 0.025), 0.16)):
        out.append(Case(f"thin-punch-nu{nu}", "thin layer", f"axisymmetric FE of a rigid "
                        f"flat punch (a 10 mm) on a bonded layer, ν {nu}, tends to the "
                        "thin-layer asymptote; edge-limited: error O(h/a)", punch[nu],
                        "stiffness P/δ (h: h/a)", levels, quick,
                        partial(lambda h, n: vp.thin_punch(h, n, n < 0.45), n=nu), 1.0,
                        (0.8, 1.4), tol))
    for nu in (0.49, 0.4999):
        for quantity, expected, band, tol in (("p_max", 2.0, (1.7, 2.6), 0.02),
                                              ("depth", 2.0, (1.6, 3.0), 0.02),
                                              ("radius", 1.0, (0.8, 1.3), 0.08)):
            if nu > 0.49 and quantity != "p_max":
                continue
            out.append(Case(f"thin-sphere-{quantity}-nu{nu}", "thin layer",
                            f"axisymmetric FE of a rigid sphere on a bonded layer, ν {nu} "
                            f"(mixed), tends to the thin-layer asymptote: {quantity}, error "
                            f"O((h/a)^{expected:g})", sphere, f"{quantity} (h: h/a)",
                            (0.1, 0.05, 0.025), (0.1, 0.05),
                            partial(lambda h, n, q: vp.thin_sphere(h, n, q), n=nu,
                                    q=quantity), expected, band, tol))
    return out


# ---------------------------------------------------------------- outputs
HEADER = f"{'case':34s} {'levels':16s} {'error':>10s} {'order':>6s} {'expected':>9s}  status"


def line(row: Row) -> str:
    """One printed table line."""
    c = row.case
    expected = (_no_order(c) if c.expected is None
                else f"{c.expected:g} ({c.band[0]:g}-{c.band[1]:g})")
    order = "" if not math.isfinite(row.order) else f"{row.order:.2f}"
    levels = " ".join(f"{h:g}" for h in row.levels)
    return (f"{c.name:34s} {levels:16s} {row.error:10.2e} {order:>6s} {expected:>9s}  "
            f"{row.status}{' (' + row.note + ')' if row.note else ''}")


def write_csv(rows: Sequence[Row], path) -> None:
    """One CSV row per case (`Row.as_dict`)."""
    import csv
    import io

    from fecheck.io.outputs import write_text

    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(rows[0].as_dict()), lineterminator="\n")
    writer.writeheader()
    writer.writerows(r.as_dict() for r in rows)
    write_text(path, buf.getvalue())


H_LABELS = {"manufactured 3-D P2": "h = 1 / cells per side",
            "EF mesh independence": "relative face size (icosphere) or element (mm)",
            "thin layer": "h / a (layer thickness / contact radius)"}


def plot(rows: Sequence[Row], path) -> None:
    """Error against h on log-log axes, one panel per group with levels and errors (the
    cases judged without an order are left out), with an h^p guide of each expected
    order."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.ticker import NullFormatter

    from fecheck.io.outputs import write_output

    shown = [r for r in rows if r.case.expected is not None and len(r.levels) > 1]
    groups = list(dict.fromkeys(r.case.group for r in shown))
    if not groups:
        return
    cols = min(3, len(groups))
    nrows = math.ceil(len(groups) / cols)
    fig, axes = plt.subplots(nrows, cols, figsize=(4.6 * cols, 3.8 * nrows), squeeze=False)
    for ax, group in zip(axes.ravel(), groups, strict=False):
        for r in (r for r in shown if r.case.group == group):
            h, e = np.array(r.levels), np.array(r.errors)
            label = f"{r.case.name} p={r.order:.2f}"
            if r.case.order_from == "values":                 # what the order measures
                h, e = h[1:], np.abs(np.diff(r.values)) / abs(r.values[-1])
                label += " (Δ)"
            ok = np.isfinite(e) & (e > 0)
            line_, = ax.loglog(h[ok], e[ok], "o-", label=label)
            if ok.any():
                guide = e[ok][-1] * (h[ok] / h[ok][-1]) ** r.case.expected
                ax.loglog(h[ok], guide, ":", color=line_.get_color(), alpha=0.6)
        ax.set_title(group, fontsize=10)
        ax.set_xlabel(H_LABELS.get(group, "element size under the contact h (mm)"), fontsize=8)
        ax.set_ylabel("relative error (Δ: successive change)", fontsize=8)
        ticks = sorted({h for r in shown if r.case.group == group for h in r.levels})
        ax.set_xticks(ticks, [f"{h:.3g}" for h in ticks], fontsize=7)
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=6)
    for ax in axes.ravel()[len(groups):]:
        ax.axis("off")
    fig.suptitle("fecheck verify: error against h (dotted: expected order)", fontsize=11)
    fig.tight_layout()
    write_output(path, lambda tmp: fig.savefig(tmp, dpi=100))
    plt.close(fig)


def report(rows: Sequence[Row], quick: bool, scene_estimate: str = "") -> str:
    """The Markdown page: what was run, the table, the plot, the scene's estimate."""
    failed = sum(r.status == "FAIL" for r in rows)
    known = sum(r.status == "known" for r in rows)
    lines = [
        "# fecheck verification report", "",
        f"Code verification ({'quick' if quick else 'full'} mode): {len(rows)} cases, "
        f"{len(rows) - failed - known} pass, {known} known limitation, {failed} fail. Each "
        "case is solved at the levels h listed (coarse to fine); the error is at the finest "
        "level (relative, or absolute in mm for the patch tests); the observed order is "
        "p = ln(e1/e2)/ln(h1/h2) of the last two levels, or, where marked Richardson, the "
        "order of three values (Celik et al. 2008, J. Fluids Eng. 130:078001). A case "
        "passes when its error is within its tolerance and its order within its band. "
        "Contact quantities (p_max, contact radius) converge at the contact-edge-limited "
        "order (the pressure has a square-root edge), smooth fields (manufactured "
        "solutions) at the P2 orders (L2 3, energy 2).", "",
        "![error against h](verify.png)", "",
        "| case | quantity | reference | levels | error | observed | expected | pass |",
        "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        c = r.case
        exp = _no_order(c) if c.expected is None else \
            f"{c.expected:g} ({c.band[0]:g}-{c.band[1]:g}" \
            + (", Richardson)" if c.order_from == "values" else ")")
        order = "" if not math.isfinite(r.order) else f"{r.order:.2f}"
        lines.append(f"| {c.name} | {c.quantity} | {c.reference} | "
                     f"{' '.join(f'{h:g}' for h in r.levels)} | {r.error:.2e} "
                     f"(tol {c.tolerance:g}) | {order} | {exp} | {r.status} |")
    notes = [f"- **{r.case.name}** ({r.status}): {r.case.known}" for r in rows if r.case.known]
    if notes:
        lines += ["", "Known limitations:", "", *notes]
    if scene_estimate:
        lines += ["", "## Discretization error of the scene's FE answer", "", scene_estimate]
    return "\n".join(lines) + "\n"


def check_levels(refines: Sequence[int]) -> list[int]:
    """`refines` sorted, or a `FecheckError` unless 2 or 3 distinct fe.refine values in
    0..4 (consecutive: the ratio is 2)."""
    levels = sorted(set(refines))
    if len(levels) not in (2, 3) or levels[0] < 0 or levels[-1] > 4 or \
            levels != list(range(levels[0], levels[0] + len(levels))):
        raise FecheckError(f"--scene-levels takes 2 or 3 consecutive fe.refine values in "
                           f"0..4 (e.g. 0 1 2), got {' '.join(map(str, refines))}")
    return levels


def scene_estimate(scene, refines: Sequence[int], label: str,
                   log: Callable[[str], None] | None = None) -> str:
    """Markdown: the FE cross-check of `scene` (named `label`) at surface subdivisions
    `refines` (each halves the edges: ratio 2), and per compartment the GCI of its p_max
    and area (Roache's Fs 1.25 with three levels, 3 with two, the formal order 2 assumed
    then)."""
    from fecheck.fe.knee.crosscheck import cross_check

    refines = check_levels(refines)
    checks = [cross_check(scene, refine=k, log=log) for k in refines]
    lines = [f"Scene `{label}`: FE at fe.refine {', '.join(map(str, refines))} "
             "(each level halves the surface edges, r = 2).", "",
             "| compartment | quantity | values (coarse → fine) | order | extrapolated | "
             "GCI fine | Fs |", "|---|---|---|---|---|---|---|"]
    for name in checks[0].compartments:
        for quantity in ("max_pressure_MPa", "area_mm2"):
            vals = [getattr(c.compartments[name].fe, quantity) for c in checks]
            res = gci(vals[::-1], [2.0] * (len(vals) - 1))
            order = f"{res.order:.2f}" + ("" if len(vals) == 3 else " (assumed)")
            lines.append(f"| {name} | {quantity} | {' → '.join(f'{v:.4g}' for v in vals)} | "
                         f"{order} | {res.extrapolated:.4g} | {100 * res.gci_fine:.2f} % | "
                         f"{res.safety_factor:g} |")
    return "\n".join(lines)
