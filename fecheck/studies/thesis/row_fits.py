"""Surface fits on the scanned knee (thesis §2.2): Tables 2.1, 2.4 and 2.5.

The fits themselves are `fecheck.studies.thesis.knee_fits` (lenhart2015 cartilage, packaged
with fecheck); these rows lay them beside the thesis's numbers. Skipped when the
scanned data are absent.

    python validation/row_fits.py [--quick] [--out DIR]
"""

from __future__ import annotations

from itertools import pairwise
from pathlib import Path

import numpy as np

from fecheck.studies.thesis import knee_fits
from fecheck.studies.thesis.report import (
    CANNOT,
    DEVIATES,
    Line,
    Row,
    figure,
    guarded,
    require_knee_data,
    save_figure,
    table_row,
)

SUBJECT_NOTE = ("The thesis fitted its own subject's scan (not published); fecheck fits the "
                "lenhart2015 MRI knee (another subject, cartilage surfaces rather than bone), "
                "so the numbers compare two knees: expect the trends, not the digits.")


def _fits():
    require_knee_data()

    return knee_fits


def table_2_1(out: Path) -> Row:
    rows = _fits().table_2_1()
    lines = []
    for r in rows:
        tag = f"{r['case']}, {r['side']}: "
        for key, label in (("lambda_deg", "λ deg"), ("gamma_deg", "γ deg"),
                           ("me_free_mm", "mean error free plane mm"),
                           ("me_transverse_mm", "mean error transverse plane mm")):
            angle = key.endswith("_deg")
            lines.append(Line(tag + label, r[f"thesis_{key}"], r[key],
                              f"Δ {r[key] - r[f'thesis_{key}']:+.1f}°" if angle else "",
                              compare=not angle))
    free_better = all(r["me_free_mm"] < r["me_transverse_mm"] for r in rows)
    outliers_help = all(
        b["me_free_mm"] <= a["me_free_mm"] for a, b in zip(rows[0::2], rows[1::2], strict=True))
    note = (f"{SUBJECT_NOTE} Trends of the thesis: the free plane fits better than the "
            f"transverse one ({'reproduced' if free_better else 'not reproduced'}); removing "
            f"outliers (2σ, robust MAD scale) lowers the mean error "
            f"({'reproduced' if outliers_help else 'not reproduced'}). Angles are compared "
            f"in degrees (a % of an angle near 0° means nothing): the lenhart2015 cartilage "
            f"planes are tilted by 7-13° where the thesis's bone planes are within ±10° and "
            f"the frontal angles γ have opposite signs, a difference of subjects and of the "
            f"surface fitted (cartilage sheets, `fecheck.scene.scanned`), not of the method, "
            f"which `tests/geometry/test_fits.py` checks on synthetic planes.")
    png = _table_2_1_png(lines, out / "table_2_1.png")
    return table_row("table_2_1", "plateau planes with and without outliers", "Table 2.1",
                     lines, out, DEVIATES, note, (png,))


def _table_2_1_png(lines: list[Line], path: Path) -> Path:
    """Grouped bars, thesis against fecheck: plane angles (deg) and mean errors (mm)."""
    fig, axes = figure(ncols=2, width=5.6, height=5.0)
    for ax, unit, title in ((axes[0], "deg", "plane angles λ, γ"),
                            (axes[1], "mm", "mean distance to the plane")):
        sel = [ln for ln in lines if ln.quantity.endswith(unit)]
        y = np.arange(len(sel))
        ax.barh(y - 0.2, [ln.thesis for ln in sel], height=0.4, color="tab:gray",
                label="thesis (its scan)")
        ax.barh(y + 0.2, [ln.fecheck for ln in sel], height=0.4, color="tab:blue",
                label="fecheck (lenhart2015)")
        ax.set_yticks(y, [ln.quantity.removesuffix(f" {unit}") for ln in sel], fontsize=7)
        ax.invert_yaxis()
        ax.axvline(0.0, color="k", lw=0.6)
        ax.set_xlabel(f"{title}, {unit}")
        ax.grid(axis="x", alpha=0.3)
        ax.set_title(f"Table 2.1: {title}")
    fig.legend(*axes[0].get_legend_handles_labels(), loc="lower center", ncol=2, fontsize=8,
               bbox_to_anchor=(0.5, -0.04))
    return save_figure(fig, path)


def _degree_table(name: str, ref: str, title: str, rows: list[dict], out: Path,
                  xlabel: str) -> Row:
    lines, curves = [], {}
    for r in rows:
        if r["degree"] == "sphere":
            continue
        rd = " (RD)" if r["rank_deficient"] else ""
        lines.append(Line(f"{r['side']} degree {r['degree']}{rd} mean error mm",
                          r["thesis_mean_error_mm"], r["mean_error_mm"]))
        curves.setdefault(r["side"], []).append((r["degree"], r["mean_error_mm"],
                                                 r["thesis_mean_error_mm"]))
    fig, (ax,) = figure()
    for side, color in zip(curves, ("tab:blue", "tab:orange"), strict=True):
        deg, ours, thesis = zip(*curves[side], strict=True)
        ax.plot(deg, ours, "o-", color=color, label=f"{side}, fecheck (lenhart2015)")
        th = np.array([np.nan if t is None else t for t in thesis])
        ax.plot(deg, th, "s--", color=color, alpha=0.6, label=f"{side}, thesis")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("mean fit error, mm")
    ax.set_title(f"{ref}: {title}")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    png = save_figure(fig, out / f"{name}.png")
    decreasing = all(all(b[1] <= a[1] + 1e-9 for a, b in pairwise(c))
                     for c in curves.values())
    note = (f"{SUBJECT_NOTE} The thesis's trend, the mean error falling with the degree, is "
            f"{'reproduced' if decreasing else 'not reproduced'}. RD = rank deficient "
            f"(fewer independent monomials than coefficients on this point set).")
    return table_row(name, title, ref, lines, out, CANNOT if not decreasing else DEVIATES,
                     note, (png,))


def table_2_4(quick: bool, out: Path) -> Row:
    rows = _fits().table_2_4(3 if quick else 4)
    return _degree_table("table_2_4", "Table 2.4", "tibial polynomials z = f(x, y)", rows,
                         out, "polynomial degree k = m")


def table_2_5(quick: bool, out: Path) -> Row:
    rows = _fits().table_2_5(3 if quick else 6)
    return _degree_table("table_2_5", "Table 2.5", "femoral polynomials r = f(θ, φ)", rows,
                         out, "polynomial degree in θ and φ")


def rows(quick: bool, out: Path) -> list[Row]:
    """Tables 2.1, 2.4, 2.5 (need the scanned knee data)."""
    return [guarded("table_2_1", "plateau planes with and without outliers", "Table 2.1", out,
                    lambda: table_2_1(out)),
            guarded("table_2_4", "tibial polynomials z = f(x, y)", "Table 2.4", out,
                    lambda: table_2_4(quick, out)),
            guarded("table_2_5", "femoral polynomials r = f(θ, φ)", "Table 2.5", out,
                    lambda: table_2_5(quick, out))]
