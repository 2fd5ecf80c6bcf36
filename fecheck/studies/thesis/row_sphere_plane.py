"""Meshed models at the reference load point (thesis §5.2): Tables 5.3-5.6 and 5.9-5.12.

Every quantity is given twice beside the thesis's number: fecheck's exact value
(`contact.area = "clipped"`, analytic condyle sphere over a refined plateau: within
0.05 % of the closed form) and fecheck's whole-face value, which repeats the thesis's
counting (icosphere slave of ≈5,000 faces on an analytic plateau, every face touching
the plateau counted whole: its Fig. 3.20).

    python validation/row_sphere_plane.py [--quick] [--out DIR]
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np

from fecheck.reference.closed_forms import hertz_sphere_on_plane
from fecheck.scene.constants import COMPARTMENTS
from fecheck.scene.knee import BASELINE_RIGHT as knee
from fecheck.studies.thesis import thesis_values as tv
from fecheck.studies.thesis.report import (
    DEVIATES,
    Line,
    Missing,
    Row,
    figure,
    guarded,
    knee_scene,
    save_figure,
    table_row,
)
from fecheck.studies.thesis.row_rigid import run

#: icosphere levels standing for the thesis's ≈5,000 and ≈13,700 faces per sphere
LEVEL_OF_FACES = {5000: 4, 13700: 5}
WHOLE_FACE = ("contact.master=plateau", "contact.area=whole-face")

BIAS_NOTE = ("The thesis counted the whole area of every face touching the plateau (its "
             "Fig. 3.20): area overestimated, depth and p_max underestimated. fecheck's "
             "exact values clip each face at its zero-depth line; fecheck's whole-face "
             "column repeats the thesis's counting on a 5,120-face icosphere.")


def tally(lines: list[Line]) -> str:
    """Mean |deviation| of the exact and the whole-face columns, as a sentence."""
    def mean(vals):
        vals = [abs(v) for v in vals if v is not None]
        return sum(vals) / len(vals) if vals else None

    ex = mean(ln.deviation_pct for ln in lines)
    wf = mean(ln.whole_face_deviation_pct for ln in lines)
    out = f" Mean |deviation| from the thesis: exact {ex:.1f} %" if ex is not None else ""
    return out + (f", whole-face {wf:.1f} %." if wf is not None else ".")


@cache
def solved(name: str | None, overrides: tuple[str, ...]):
    """`run_scene` result of a validation scene with overrides (memoised)."""
    r = run(name, *overrides)
    if not r.converged:
        raise RuntimeError(f"scene {name or 'baseline'} {list(overrides)} did not converge")
    return r


def metric(result, compartment: str, key: str) -> float:
    """One metric (``thesis_values.METRICS``) of a compartment of a `RunResult`."""
    return float(getattr(result.compartments[compartment], key))


def case_lines(thesis: dict, exact, whole, prefix: str = "",
               keys: tuple[str, ...] = tv.METRICS) -> list[Line]:
    """Lines for one thesis case (compartment → metric → value), exact and whole-face."""
    lines = []
    for c in COMPARTMENTS:
        for key in keys:
            lines.append(Line(f"{prefix}{c} {tv.METRIC_LABELS[key]}", thesis[c][key],
                              metric(exact, c, key),
                              whole_face=None if whole is None else metric(whole, c, key)))
    return lines


def closed_form_note(result) -> str:
    """How far fecheck's exact values are from the closed-form EF sphere on a plane."""
    devs = [abs(v) for ref in result.exact.values() if isinstance(ref, dict)
            for v in ref.get("deviation_percent", {}).values()]
    if not devs:
        return ""
    return (f" fecheck's exact values are within {max(devs):.2f} % of the closed-form EF "
            "sphere on a plane at the same force: F = kπd²(R − d/3), A = π(2Rd − d²), "
            "p_max = k·d (`fecheck.reference.closed_forms.ef_sphere_plane`).")


def whole_face(level: int = 4) -> tuple[str, ...]:
    """Overrides for the thesis's whole-face counting on an icosphere of `level`."""
    return (*WHOLE_FACE, f"mesh.sphere_subdivisions={level}")


def table_5_3(out: Path) -> Row:
    exact = solved(None, ())
    whole = solved(None, whole_face())
    lines = case_lines(tv.TABLE_5_3, exact, whole)
    return table_row("table_5_3", "EF sphere-plane baseline", "Table 5.3", lines, out,
                     DEVIATES, BIAS_NOTE + closed_form_note(exact) + tally(lines))


def _sweep_table(name: str, title: str, reference: str, thesis: dict, key: str,
                 values: tuple[float, ...], levels: dict[int, int], out: Path,
                 axis_label: str) -> Row:
    lines, series = [], {"exact": {}, **{f: {} for f in levels}}
    for v in values:
        exact = solved(None, (f"contact.{key}={v}",))
        series["exact"][v] = exact
        for faces, level in levels.items():
            whole = solved(None, (f"contact.{key}={v}", *whole_face(level)))
            series[faces][v] = whole
            case = thesis[v][faces] if faces in thesis.get(v, {}) else thesis[v]
            tag = f"{axis_label.split()[0]}={v:g} ≈{faces} faces: "
            lines += case_lines(case, exact, whole, tag)
    png = _sweep_png(reference, thesis, values, levels, series, axis_label,
                     out / f"{name}.png")
    note = (f"{BIAS_NOTE} The thesis's ≈5,000 and ≈13,700 faces are stood for by icospheres "
            f"of 5,120 and 20,480 faces (20·4ⁿ). fecheck's exact values do not depend on "
            f"the sphere mesh (analytic condyle).{tally(lines)}")
    return table_row(name, title, reference, lines, out, DEVIATES, note, (png,))


def _sweep_png(reference, thesis, values, levels, series, axis_label, path) -> Path:
    fig, axes = figure(ncols=2, width=5.6)
    xs = np.array(values, dtype=float)
    order = np.argsort(xs)
    for ax, key in zip(axes, ("max_pressure_MPa", "area_mm2"), strict=True):
        for c, color in zip(COMPARTMENTS, ("tab:blue", "tab:orange"), strict=True):
            exact = np.array([metric(series["exact"][v], c, key) for v in values])
            ax.plot(xs[order], exact[order], "-", color=color, label=f"{c}: fecheck exact")
            for faces, marker in zip(levels, ("s", "D"), strict=False):
                wf = np.array([metric(series[faces][v], c, key) for v in values])
                ax.plot(xs[order], wf[order], marker, mfc="none", color=color,
                        label=f"{c}: fecheck whole-face ≈{faces}")
                th = [(thesis[v][faces] if faces in thesis.get(v, {}) else thesis[v])[c][key]
                      for v in values]
                ax.plot(xs[order], np.array(th)[order], marker, color=color, alpha=0.6,
                        label=f"{c}: thesis ≈{faces}")
        ax.set_xlabel(axis_label)
        ax.set_ylabel(tv.METRIC_LABELS[key].replace(" MPa", ", MPa").replace(" mm²", ", mm²"))
        ax.grid(alpha=0.3)
    axes[0].set_title(f"{reference}: max pressure")
    axes[1].set_title(f"{reference}: contact area")
    axes[1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    return save_figure(fig, path)


def table_5_4(quick: bool, out: Path) -> Row:
    levels = {5000: 4} if quick else dict(LEVEL_OF_FACES)
    return _sweep_table("table_5_4", "Young's modulus E and mesh size", "Table 5.4",
                        tv.TABLE_5_4, "youngs_MPa", (9.0, 15.0, 20.0, 30.0), levels, out,
                        "E MPa")


def table_5_5(quick: bool, out: Path) -> Row:
    return _sweep_table("table_5_5", "Poisson's ratio ν", "Table 5.5", tv.TABLE_5_5,
                        "poisson", (0.15, 0.3, 0.4, 0.45), {5000: 4}, out, "ν (-)")


def hertz_check(force_N: float, radius_mm: float, E_MPa: float, nu: float) -> dict:
    """Hertz depth (mm) and p0 (MPa) at a force for a rigid indenter, and for two equal
    deformable layers (E* halved: the rigid-indenter closed form with E/2)."""
    out = {}
    for label, youngs in (("rigid indenter", E_MPa), ("two layers", E_MPa / 2)):
        m = hertz_sphere_on_plane(force_N, radius_mm, youngs, nu)
        out[label] = (m.depth_mm, m.max_pressure_MPa)
    return out


def table_5_6(out: Path) -> Row:
    exact = solved("hertz", ())
    whole = solved("hertz", whole_face())
    lines = case_lines(tv.TABLE_5_6_HERTZ, exact, whole)

    c = "medial"
    th = tv.TABLE_5_6_HERTZ[c]
    check = hertz_check(th["force_N"], knee.radius_mm(c), 20.0, 0.3)
    rigid, layers = check["rigid indenter"], check["two layers"]
    note = ("fecheck's Hertz law uses eq. 4.5-4.8 at the deepest point with E* = E/(1−ν²) "
            "(rigid condyle on the cartilage). The thesis's Hertz row is not consistent with "
            f"those equations: at its own medial force {th['force_N']} N (R = "
            f"{knee.radius_mm(c):.1f} mm) they give d = {rigid[0]:.2f} mm, p0 = "
            f"{rigid[1]:.2f} MPa (rigid indenter) or d = {layers[0]:.2f} mm, p0 = "
            f"{layers[1]:.2f} MPa (two equal layers), against its d = {th['max_depth_mm']} "
            f"mm, p_max = {th['max_pressure_MPa']} MPa; its area {th['area_mm2']} mm² is "
            f"not πa² either (it matches a whole-face count on the mesh). The forces agree "
            f"within a few % (the split is set by statics). The whole-face column runs the "
            f"Hertz law on the thesis's mesh setup (5,120-face icosphere on the plane, whole "
            f"faces counted for the reported area).{tally(lines)}")
    return table_row("table_5_6", "Hertz law sphere-plane", "Table 5.6", lines, out, DEVIATES,
                     note)


def table_5_9(out: Path) -> Row:
    exact = solved(None, ("plateau.kind=inclined",))
    whole = solved(None, ("plateau.kind=inclined", *whole_face()))
    lines = case_lines(tv.TABLE_5_9_INCLINED, exact, whole)
    note = ("Baseline knee (Table B.1) on planes inclined by the thesis's Table 2.1 angles "
            "(without outliers: medial λ −0.36°, γ −5.93°; lateral λ −0.34°, γ 9.82°), each "
            "touching its condyle sphere at the reference pose. " + BIAS_NOTE
            + closed_form_note(exact) + tally(lines))
    return table_row("table_5_9", "inclined plateau planes", "Table 5.9", lines, out, DEVIATES,
                     note)


def table_5_10(out: Path) -> Row:
    name = knee_scene("polynomial")
    exact = solved(name, ())
    whole = solved(name, whole_face())
    lines = case_lines(tv.TABLE_5_10_POLYNOMIAL, exact, whole)
    note = ("Degree-3 polynomial plateaus z = f(x, y) fitted to the lenhart2015 tibial "
            "cartilage (thesis §2.2.2 method, `validation/scenes/polynomial.toml`) under "
            "condyle spheres fitted to the same subject's femur: the thesis fitted its own "
            "subject's scan, which is not published, so this row compares two knees; expect "
            "the order of magnitude, not the digits. " + BIAS_NOTE + tally(lines))
    return table_row("table_5_10", "degree-3 polynomial plateaus", "Table 5.10", lines, out,
                     DEVIATES, note)


def table_5_11(out: Path) -> Row:
    name = knee_scene("femur_tibia")
    exact = solved(name, ())
    lines = case_lines(tv.TABLE_5_11_SCANNED, exact, None)
    note = ("Scanned femoral cartilage on scanned tibial cartilage (lenhart2015, MRI of one "
            "young woman; `validation/scenes/femur_tibia.toml`), EF with the local cartilage "
            "thickness. The thesis scanned another subject (not published) and detected "
            "contact by ray parity and whole faces; fecheck uses a BVH closest-point depth "
            "with clipped faces. Different knees: compare orders of magnitude." + tally(lines))
    return table_row("table_5_11", "scanned femur on scanned tibia", "Table 5.11", lines, out,
                     DEVIATES, note)


def table_5_12(out: Path) -> Row:
    cases = {"baseline": (None, ()), "hertz": ("hertz", ()),
             "inclined": (None, ("plateau.kind=inclined",))}
    for name in ("polynomial", "femur_tibia"):
        try:
            cases["scanned" if name == "femur_tibia" else name] = (knee_scene(name), ())
        except Missing:
            pass
    lines, missing = [], [k for k in tv.TABLE_5_12 if k not in cases]
    for case, (name, ov) in cases.items():
        exact = solved(name, ov)
        whole = None
        if case != "scanned":
            whole = solved(name, (*ov, *whole_face()))
        lines += case_lines(tv.TABLE_5_12[case], exact, whole, f"{case}: ")
    note = ("Summary of Tables 5.3, 5.6, 5.9, 5.10 and 5.11 (see those rows for the "
            "reasons). No whole-face value for the scanned case (mesh on mesh: the thesis's "
            "icosphere setup does not apply)." + tally(lines))
    if missing:
        note += (f" Cases not run: {', '.join(missing)} (scene file or scanned knee data "
                 "missing).")
    return table_row("table_5_12", "summary of the meshed models", "Table 5.12", lines, out,
                     DEVIATES, note)


def rows(quick: bool, out: Path) -> list[Row]:
    """Tables 5.3, 5.4, 5.5, 5.6, 5.9, 5.10, 5.11, 5.12."""
    spec = [("table_5_3", "EF sphere-plane baseline", "Table 5.3", lambda: table_5_3(out)),
            ("table_5_4", "Young's modulus E and mesh size", "Table 5.4",
             lambda: table_5_4(quick, out)),
            ("table_5_5", "Poisson's ratio ν", "Table 5.5", lambda: table_5_5(quick, out)),
            ("table_5_6", "Hertz law sphere-plane", "Table 5.6", lambda: table_5_6(out)),
            ("table_5_9", "inclined plateau planes", "Table 5.9", lambda: table_5_9(out)),
            ("table_5_10", "degree-3 polynomial plateaus", "Table 5.10",
             lambda: table_5_10(out)),
            ("table_5_11", "scanned femur on scanned tibia", "Table 5.11",
             lambda: table_5_11(out)),
            ("table_5_12", "summary of the meshed models", "Table 5.12",
             lambda: table_5_12(out))]
    return [guarded(n, t, r, out, fn) for n, t, r, fn in spec]
