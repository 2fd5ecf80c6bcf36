"""Literature comparison (thesis Tables 5.7, 5.8): Donahue et al. 2002 against EF and FE.

At the load point where the EF compartment forces are equal (as the thesis did, to
match Donahue's loading), each compartment's force presses its condyle sphere on a 6 mm
cartilage layer: fecheck's EF (exact and whole-face) beside the thesis's EF, and
fecheck's FE (the general path of `fecheck fe` on the flat layer, P2 tetrahedra, element
size 5, 2, 1 mm under the contact) beside Donahue's FE (5, 2, 1 mm elements, real
geometry with menisci).

    python validation/row_donahue.py [--quick] [--out DIR]
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fecheck.fe.reference.sphere_layer import sphere_on_flat_layer
from fecheck.reference import closed_forms as refs
from fecheck.scene.knee import BASELINE_RIGHT as knee
from fecheck.studies.thesis import thesis_values as tv
from fecheck.studies.thesis.report import (
    DEVIATES,
    Line,
    Row,
    figure,
    guarded,
    save_figure,
    table_row,
)
from fecheck.studies.thesis.row_rigid import run
from fecheck.studies.thesis.row_sphere_plane import WHOLE_FACE

#: icosphere level whose edge (≈ 1.05·R/2ⁿ: 3.3, 1.7, 0.8 mm at R = 25.5) stands for the
#: thesis's 5, 2 and 1 mm element sizes
LEVEL_OF_SIZE = {5.0: 3, 2.0: 4, 1.0: 5}
LABELS = {"max_pressure_MPa": "max pressure MPa", "mean_pressure_MPa": "mean pressure MPa",
          "force_N": "force N", "area_mm2": "contact area mm²"}


def equal_force_point(*overrides: str) -> tuple[float, object]:
    """Load-point x (mm) with equal EF compartment forces (secant), and its result."""
    def gap(x):
        r = run(None, *overrides, f"load.point_mm=[{x}, 12.8, -380.0]")
        return r.compartments["medial"].force_N - r.compartments["lateral"].force_N, r

    x0, x1 = 3.9, 3.8
    g0, _ = gap(x0)
    for _ in range(8):
        g1, r1 = gap(x1)
        if abs(g1) < 1e-3:
            break
        x0, x1, g0 = x1, x1 - g1 * (x1 - x0) / (g1 - g0), g1
    return x1, r1


def _metrics(result, c: str) -> dict[str, float]:
    comp = result.compartments[c]
    return {"max_pressure_MPa": comp.max_pressure_MPa, "mean_pressure_MPa":
            comp.mean_pressure_MPa, "force_N": comp.force_N, "area_mm2": comp.area_mm2}


def _compute(quick: bool) -> dict:
    x_eq, exact = equal_force_point()
    sizes = (2.0,) if quick else (5.0, 2.0, 1.0)
    whole = {s: run(None, *WHOLE_FACE, f"mesh.sphere_subdivisions={LEVEL_OF_SIZE[s]}",
                    f"load.point_mm=[{x_eq}, 12.8, -380.0]") for s in sizes}

    fe = {}
    for c in ("medial", "lateral"):
        load = exact.compartments[c].force_N
        for s in sizes:
            fe[c, s] = sphere_on_flat_layer(load, knee.radius_mm(c), 20.0, 0.3, 6.0,
                                            refine_size_mm=s).metrics
    return {"x_eq": x_eq, "exact": exact, "whole": whole, "fe": fe, "sizes": sizes,
            "donahue": refs.DONAHUE_2002}


def _row(name: str, ref: str, c: str, thesis_ef: dict, data: dict, out: Path) -> Row:
    sizes, exact = data["sizes"], _metrics(data["exact"], c)
    lines = []
    for s in sizes:
        wf = _metrics(data["whole"][s], c)
        for i, key in enumerate(tv.DONAHUE_KEYS):
            lines.append(Line(f"EF {s:g} mm: {LABELS[key]}", thesis_ef[s][i], exact[key],
                              whole_face=wf[key]))
    for s in sizes:
        don = data["donahue"][c][s]
        fe = data["fe"][c, s]
        for key in tv.DONAHUE_KEYS:
            note = "Donahue 2002 (thesis Table a) vs fecheck FE"
            lines.append(Line(f"FE {s:g} mm: {LABELS[key]}", getattr(don, key),
                              getattr(fe, key), note))
    from matplotlib.ticker import NullFormatter

    fig, axes = figure(ncols=2, width=5.2)
    xs = np.array(sizes)
    for ax, key in zip(axes, ("max_pressure_MPa", "area_mm2"), strict=True):
        i = tv.DONAHUE_KEYS.index(key)
        ax.plot(list(data["donahue"][c]), [getattr(m, key) for m in data["donahue"][c].values()],
                "k^-", label="Donahue 2002 FE (menisci, CT geometry)")
        ax.plot(list(thesis_ef), [v[i] for v in thesis_ef.values()], "s--", color="tab:gray",
                label="thesis EF (whole faces)")
        ax.plot(xs, [getattr(data["fe"][c, s], key) for s in sizes], "o-",
                color="tab:red", label="fecheck FE 3D (P2 tets)")
        ax.plot(xs, [_metrics(data["whole"][s], c)[key] for s in sizes], "D:", mfc="none",
                color="tab:blue", label="fecheck EF whole-face")
        ax.axhline(exact[key], color="tab:blue", label="fecheck EF exact")
        ax.set_xscale("log")
        ax.set_xticks([1, 2, 5], ["1", "2", "5"])
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("element size under the contact, mm")
        ax.set_ylabel(LABELS[key].replace(" MPa", ", MPa").replace(" mm²", ", mm²"))
        ax.grid(alpha=0.3, which="both")
    axes[0].set_title(f"{ref} ({c}): maximum pressure")
    axes[1].set_title(f"{ref} ({c}): contact area")
    axes[1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    png = save_figure(fig, out / f"{name}.png")
    fe_pmax = [data["fe"][c, s].max_pressure_MPa for s in sizes]
    note = (f"Load point x = {data['x_eq']:.3f} mm (equal EF forces, "
            f"{exact['force_N']:.1f} N per compartment; the thesis moved it likewise). "
            "EF lines: the thesis's own EF results (its Table b) against fecheck's EF, exact "
            "(mesh-independent) and whole-face on icospheres with edges near each size. FE "
            "lines: Donahue's FE (Table a) against fecheck's FE (the general path of fecheck fe) "
            "of a rigid sphere on a bonded 6 mm layer (P2 tetrahedra, exact frictionless "
            "contact) under the same force. Donahue's model has menisci and real condyles, "
            "which spread the load over 2-3 times the area: compare orders of magnitude and "
            "convergence trends, "
            f"not digits. fecheck's FE p_max over the sizes: "
            f"{', '.join(f'{p:.2f}' for p in fe_pmax)} MPa.")
    return table_row(name, f"Donahue 2002 comparison, {c} condyle", ref, lines, out, DEVIATES,
                     note, (png,))


def rows(quick: bool, out: Path) -> list[Row]:
    """Tables 5.7 (lateral) and 5.8 (medial)."""
    cache: dict = {}

    def data():
        if "d" not in cache:
            cache["d"] = _compute(quick)
        return cache["d"]

    return [guarded("table_5_7", "Donahue 2002 comparison, lateral condyle", "Table 5.7", out,
                    lambda: _row("table_5_7", "Table 5.7", "lateral", tv.TABLE_5_7B_LATERAL,
                                 data(), out)),
            guarded("table_5_8", "Donahue 2002 comparison, medial condyle", "Table 5.8", out,
                    lambda: _row("table_5_8", "Table 5.8", "medial", tv.TABLE_5_8B_MEDIAL,
                                 data(), out))]
