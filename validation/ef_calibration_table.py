"""Calibration table of a local power-law foundation against the axisymmetric FE.

A rigid sphere (radius R) on a bonded layer (h, E, ν) is solved by the axisymmetric FE
(`fecheck.fe.reference.axisym.axisym_sphere_on_layer`) at E = 1 MPa and loads F/E = `FORCE_OVER_E`
(2-100 mm², log-spaced: 2, 5.3, 14.1, 37.6, 100; 50-1500 N at E 5-50 MPa), over a grid
of ν, h and R. Linear elasticity: the FE answer at E is the one at E = 1 with F/E,
areas and p/E equal. Per (ν, h, R) the FE's force-area curve is fitted by least squares
as log F = log c + m log A; the local law

    p(d) = C·d·(d + d_s)^(n−1),  n = m − 1,  C = E·c·m·(2πR)^(m−1)   (d_s → 0)

then gives a sphere the FE's area at every load (the EF area is the overlap area 2πRδ,
F = 2πR ∫_0^δ p, so dF/dA = p(δ)), and a p_max of m·F/A, which is the FE's p_max only
insofar as the FE has p_max = m·p_mean. Recorded per (ν, h, R): m, log c, the fit's
largest relative error on F at the grid loads, and the error of the implied p_max m·F/A
against the FE p_max (signed, at the load where |error| is largest). The CSV also holds,
per load: the contact radius over h, a local slope (3-point window) and a quadratic
log F(log A) fit's slope with their p_max errors (does a load-dependent m help?), the
pair-window fit's p_max errors, and the EF with d_s = 0.01 mm solved exactly (its area
and p_max errors against the FE).

Element size under the contact: min(0.1 mm, a/60), a the Hertz contact radius (the
solve is repeated at a/60 of the FE's own radius when that is smaller than 40 elements):
the area is measured to half an element of radius (`axisym._node_area`), so 0.1 mm at a
2.5 mm contact would be ±2 % of area; a/60 keeps it within ~0.3 % (fe_convergence.py:
0.1 mm is within 0.3 % on area at the compartments' ~5-10 mm radii). The layer's disc
radius is max(30, 3·a_Hertz + h) mm.

    python validation/ef_calibration_table.py [--quick] [--out DIR] [--jobs N] [--write]

--quick: ν 0.3, 0.49; h 1.5, 12 mm; R 25 mm (20 solves). --jobs: worker processes
(default 2, one BLAS thread each). Writes DIR/ef_calibration_table.csv (one row per
solve, rewritten after each geometry), DIR/ef_calibration_table.json and
DIR/ef_calibration_table.png; --write (full grid only) also writes the table to
fecheck/laws/ef_calibration_table.json.

JSON layout (nested lists indexed [ν][h][R], in the order of "axes"):

    {"law": "p = C d (d + d_s)^(n-1)", "soft_depth_mm": 0.01, "E_reference_MPa": 1.0,
     "force_over_E_mm2": [lo, hi],        # load range of the fit, F/E in mm²
     "axes": {"poisson": [...], "thickness_mm": [...], "radius_mm": [...]},
     "m": [[[...]]],                      # exponent of F = c·A^m; n = m − 1
     "log_c": [[[...]]],                  # ln c, c in N/mm^(2m) at E = 1 MPa
     "fit_force_error": [[[...]]],        # max |c·A^m / F − 1| over the loads
     "pmax_error": [[[...]]],             # m·F/A / p_max(FE) − 1, signed, max |·| over loads
     "element_size_mm": 0.1,              # largest element size under the contact
     "source": "validation/ef_calibration_table.py"}

At modulus E: F = E·c·A^m, C = E·c·m·(2πR)^(m−1) (MPa/mm^n), n = m − 1.
"""

from __future__ import annotations

import argparse
import csv
import json
import multiprocessing as mp
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from itertools import product
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

from fecheck.laws.calibrated import SOFT_DEPTH_MM

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.studies.thesis.report import save_figure

POISSON = (0.3, 0.4, 0.45, 0.49)
THICKNESS_MM = (1.5, 2.0, 3.0, 4.5, 6.0, 9.0, 12.0)
RADIUS_MM = (15.0, 20.0, 25.0, 32.0, 40.0, 60.0)
QUICK = {"poisson": (0.3, 0.49), "thickness_mm": (1.5, 12.0), "radius_mm": (25.0,)}
FORCE_OVER_E = tuple(float(v) for v in np.geomspace(2.0, 100.0, 5))   # mm² (N at E = 1 MPa)
MAX_SIZE_MM = 0.1
RADIUS_PER_SIZE = 60            # elements across the contact radius (at least 40)
TOLERANCE = 0.05                # the p_max target of the summary
TABLE = Path(__file__).resolve().parents[1] / "fecheck" / "laws" / "ef_calibration_table.json"


def solve_load(load: float, nu: float, h: float, radius: float) -> dict:
    """Axisymmetric FE at E = 1 MPa, element size from the contact radius; its metrics."""
    from fecheck.fe.reference.axisym import axisym_sphere_on_layer
    from fecheck.reference.closed_forms import hertz_sphere_on_plane

    a_hertz = float(np.sqrt(hertz_sphere_on_plane(load, radius, 1.0, nu).area_mm2 / np.pi))
    layer = max(30.0, 3 * a_hertz + h)
    size = min(MAX_SIZE_MM, a_hertz / RADIUS_PER_SIZE)
    t = time.perf_counter()
    while True:
        res = axisym_sphere_on_layer(load, radius, 1.0, nu, h, size_mm=size,
                                     layer_radius_mm=layer)
        a = float(np.sqrt(res.metrics.area_mm2 / np.pi))
        if a / size >= 40 or size <= 0.01:
            break
        size = max(0.01, a / RADIUS_PER_SIZE)
    m = res.metrics
    return {"force_over_E_mm2": load, "size_mm": size, "n_dofs": res.n_dofs,
            "time_s": time.perf_counter() - t, "force_N": m.force_N, "area_mm2": m.area_mm2,
            "max_pressure_MPa": m.max_pressure_MPa, "mean_pressure_MPa": m.mean_pressure_MPa,
            "depth_mm": m.depth_mm, "a_over_h": a / h}


def solve_geometry(nu: float, h: float, radius: float) -> list[dict]:
    """The FE at every load of one (ν, h, R)."""
    return [{"poisson": nu, "thickness_mm": h, "radius_mm": radius,
             **solve_load(load, nu, h, radius)} for load in FORCE_OVER_E]


def power_fit(area: np.ndarray, force: np.ndarray) -> tuple[float, float]:
    """m and ln c of F = c·A^m, least squares in log-log."""
    m, log_c = np.polyfit(np.log(area), np.log(force), 1)
    return float(m), float(log_c)


def local_slopes(area: np.ndarray, force: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """d log F / d log A at each load: from a 3-point window (2 at the ends), and from a
    quadratic fit of log F in log A over all loads."""
    x, y = np.log(area), np.log(force)
    window = np.array([np.polyfit(x[max(k - 1, 0):k + 2], y[max(k - 1, 0):k + 2], 1)[0]
                       for k in range(len(x))])
    b2, b1, _ = np.polyfit(x, y, 2)
    return window, b1 + 2 * b2 * x


def pair_errors(area: np.ndarray, force: np.ndarray, pmax: np.ndarray) -> np.ndarray:
    """p_max error of the law fitted to each pair of neighbouring loads, at both loads of
    the pair: (n_loads − 1, 2)."""
    out = []
    for k in range(len(area) - 1):
        m = np.log(force[k + 1] / force[k]) / np.log(area[k + 1] / area[k])
        out.append(m * force[k:k + 2] / area[k:k + 2] / pmax[k:k + 2] - 1)
    return np.array(out)


def soft_ef(m: float, log_c: float, radius: float, load: float) -> tuple[float, float]:
    """Area (mm²) and p_max (MPa) of the law with d_s = SOFT_DEPTH_MM on a sphere at E = 1:
    F = 2πR C [u^(n+1)/(n+1) − d_s u^n/n] between u = d_s and δ + d_s."""
    n, ds = m - 1, SOFT_DEPTH_MM
    C = np.exp(log_c) * m * (2 * np.pi * radius) ** (m - 1)

    def prim(u: float) -> float:
        return u ** (n + 1) / (n + 1) - ds * u ** n / n

    def residual(delta: float) -> float:
        return 2 * np.pi * radius * C * (prim(delta + ds) - prim(ds)) - load

    hi = 1.0
    while residual(hi) < 0:
        hi *= 2
    delta = brentq(residual, 0.0, hi, xtol=1e-12, rtol=1e-12)
    return 2 * np.pi * radius * delta, C * delta * (delta + ds) ** (n - 1)


def analyse(rows: list[dict]) -> dict:
    """Fit one geometry's rows (in load order); add the per-load columns; the table entry."""
    area = np.array([r["area_mm2"] for r in rows])
    force = np.array([r["force_N"] for r in rows])
    pmax = np.array([r["max_pressure_MPa"] for r in rows])
    m, log_c = power_fit(area, force)
    fit_err = np.exp(log_c) * area ** m / force - 1
    pm_err = m * force / area / pmax - 1
    window, quad = local_slopes(area, force)
    pairs = pair_errors(area, force, pmax)
    for k, r in enumerate(rows):
        ef_area, ef_pmax = soft_ef(m, log_c, r["radius_mm"], r["force_N"])
        pair = [pairs[j, k - j] for j in (k - 1, k) if 0 <= j < len(pairs)]
        r.update({"m": m, "log_c": log_c, "fit_force_error": fit_err[k],
                  "pmax_ratio_fe": pmax[k] / (force[k] / area[k]),
                  "pmax_error": pm_err[k], "m_window": window[k],
                  "pmax_error_window": window[k] * force[k] / area[k] / pmax[k] - 1,
                  "m_quadratic": quad[k],
                  "pmax_error_quadratic": quad[k] * force[k] / area[k] / pmax[k] - 1,
                  "pmax_error_pair": max(pair, key=abs),
                  "soft_ef_area_error": ef_area / area[k] - 1,
                  "soft_ef_pmax_error": ef_pmax / pmax[k] - 1})
    worst = int(np.argmax(np.abs(pm_err)))
    return {"m": m, "log_c": log_c, "fit_force_error": float(np.max(np.abs(fit_err))),
            "pmax_error": float(pm_err[worst])}


def write_csv(rows: list[dict], path: Path) -> None:
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def table_json(axes: dict, entries: dict, size: float) -> dict:
    """The JSON table (module docstring) from the per-geometry entries."""
    def nested(key: str) -> list:
        return [[[round(entries[nu, h, r][key], 6) for r in axes["radius_mm"]]
                 for h in axes["thickness_mm"]] for nu in axes["poisson"]]

    return {"law": "p = C d (d + d_s)^(n-1)", "soft_depth_mm": SOFT_DEPTH_MM,
            "E_reference_MPa": 1.0,
            "force_over_E_mm2": [round(FORCE_OVER_E[0], 6), round(FORCE_OVER_E[-1], 6)],
            "axes": {k: list(v) for k, v in axes.items()},
            "m": nested("m"), "log_c": nested("log_c"),
            "fit_force_error": nested("fit_force_error"), "pmax_error": nested("pmax_error"),
            "element_size_mm": size, "source": "validation/ef_calibration_table.py"}


def run(axes: dict, jobs: int, path: Path) -> tuple[list[dict], dict]:
    """Solve and fit every geometry (in `jobs` spawned processes); the rows and entries."""
    geometries = list(product(*axes.values()))
    rows: list[dict] = []
    entries: dict = {}
    os.environ.update({"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"})
    with ProcessPoolExecutor(jobs, mp_context=mp.get_context("spawn")) as pool:
        futures = {pool.submit(solve_geometry, *g): g for g in geometries}
        for done, fut in enumerate(as_completed(futures), 1):
            g, geo_rows = futures[fut], fut.result()
            entries[g] = analyse(geo_rows)
            rows.extend(geo_rows)
            e = entries[g]
            print(f"[{done:3d}/{len(geometries)}] ν {g[0]:4.2f} h {g[1]:4.1f} R {g[2]:4.0f}: "
                  f"m {e['m']:.3f}  fit F {100 * e['fit_force_error']:5.2f}%  p_max "
                  f"{100 * e['pmax_error']:+6.2f}%  ({sum(r['time_s'] for r in geo_rows):5.1f} s)",
                  flush=True)
            rows.sort(key=lambda r: tuple(r[k] for k in (*axes, "force_over_E_mm2")))
            write_csv(rows, path)
    return rows, entries


def share(values: np.ndarray, tol: float = TOLERANCE) -> str:
    """'k/n (p %)' of values within ±tol."""
    ok = int(np.sum(np.abs(values) <= tol))
    return f"{ok}/{len(values)} ({100 * ok / len(values):.0f} %)"


def summary(rows: list[dict], axes: dict) -> None:
    """Distribution of the p_max and force-fit errors, by ν, h, R and load."""
    col = {k: np.array([r[k] for r in rows]) for k in rows[0]}
    pe = col["pmax_error"]
    print(f"\nm over the grid: {col['m'].min():.3f} - {col['m'].max():.3f}; force fit error: "
          f"median {100 * np.median(np.abs(col['fit_force_error'])):.2f} %, max "
          f"{100 * np.abs(col['fit_force_error']).max():.2f} %")
    print(f"p_max error m·F/A vs FE over {len(pe)} loads: percentiles 0/10/50/90/100 = "
          + " / ".join(f"{100 * q:+.1f}" for q in np.percentile(pe, [0, 10, 50, 90, 100]))
          + f" %; within ±{100 * TOLERANCE:.0f} %: {share(pe)}")
    for key in (*axes, "force_over_E_mm2"):
        parts = []
        for v in sorted(set(col[key])):
            sel = pe[col[key] == v]
            parts.append(f"{v:g}: {share(sel)} [{100 * sel.min():+.0f}, {100 * sel.max():+.0f}]")
        print(f"  by {key}: " + "; ".join(parts))
    bins = [0, 0.5, 1, 2, 4, np.inf]
    parts = []
    for lo, hi in zip(bins[:-1], bins[1:], strict=True):
        sel = pe[(col["a_over_h"] >= lo) & (col["a_over_h"] < hi)]
        if len(sel):
            parts.append(f"[{lo:g}, {hi:g}): {share(sel)} [{100 * sel.min():+.0f}, "
                         f"{100 * sel.max():+.0f}]")
    print("  by a/h: " + "; ".join(parts))
    for key, label in (("pmax_error_pair", "law fitted per pair of neighbouring loads"),
                       ("pmax_error_window", "local slope, 3-load window"),
                       ("pmax_error_quadratic", "slope of a quadratic log F(log A) fit"),
                       ("soft_ef_pmax_error", "global m, EF solved with d_s = 0.01 mm")):
        v = col[key]
        print(f"p_max error, {label}: max |·| {100 * np.abs(v).max():.1f} %, median |·| "
              f"{100 * np.median(np.abs(v)):.1f} %, within ±{100 * TOLERANCE:.0f} %: {share(v)}")
    grid_table(col, axes)
    v = col["soft_ef_area_error"]
    print(f"area error of the EF with d_s = 0.01 mm: {100 * v.min():+.2f} to {100 * v.max():+.2f}"
          f" %; FE p_max/p_mean {col['pmax_ratio_fe'].min():.2f} - "
          f"{col['pmax_ratio_fe'].max():.2f}, m {col['m'].min():.2f} - {col['m'].max():.2f}")


def grid_table(col: dict, axes: dict) -> None:
    """Max |p_max error| (%) over R and loads per (ν, h), and the number of R (of all)
    within ±TOLERANCE at every load."""
    print(f"max |p_max error| % over R and loads, [R within ±{100 * TOLERANCE:.0f} % at every "
          "load]; rows ν, columns h (mm):")
    print("        " + "".join(f"{h:>11g}" for h in axes["thickness_mm"]))
    for nu in axes["poisson"]:
        cells = []
        for h in axes["thickness_mm"]:
            sel = (col["poisson"] == nu) & (col["thickness_mm"] == h)
            worst = {r: np.abs(col["pmax_error"][sel & (col["radius_mm"] == r)]).max()
                     for r in axes["radius_mm"]}
            ok = sum(w <= TOLERANCE for w in worst.values())
            cells.append(f"{100 * max(worst.values()):5.1f} [{ok}/{len(worst)}]")
        print(f"  ν {nu:4g}" + "".join(f"{c:>11s}" for c in cells))


def plot(rows: list[dict], path: Path) -> None:
    """m against h/R; p_max error against a/h (global and local m); p_max/p_mean vs m."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    col = {k: np.array([r[k] for r in rows]) for k in rows[0]}
    fig, axes = plt.subplots(1, 3, figsize=(16, 4.6))
    for nu, color in zip(sorted(set(col["poisson"])), ("C0", "C1", "C2", "C3"), strict=False):
        sel = col["poisson"] == nu
        axes[0].semilogx(col["thickness_mm"][sel] / col["radius_mm"][sel], col["m"][sel], "o",
                         color=color, ms=3, label=f"ν {nu:g}")
        axes[1].semilogx(col["a_over_h"][sel], 100 * col["pmax_error"][sel], "o", color=color,
                         ms=3, label=f"ν {nu:g}, global m")
        axes[1].semilogx(col["a_over_h"][sel], 100 * col["pmax_error_quadratic"][sel], "x",
                         color=color, ms=4, label=f"ν {nu:g}, m(A)")
        axes[2].plot(col["m_quadratic"][sel], col["pmax_ratio_fe"][sel], "o", color=color, ms=3,
                     label=f"ν {nu:g}")
    axes[0].set_xlabel("h / R")
    axes[0].set_ylabel("m of F = c·A^m")
    axes[1].axhspan(-100 * TOLERANCE, 100 * TOLERANCE, color="0.9")
    axes[1].set_xlabel("FE contact radius a / h")
    axes[1].set_ylabel("p_max error m·F/A vs FE, %")
    lim = [min(col["m_quadratic"].min(), col["pmax_ratio_fe"].min()),
           max(col["m_quadratic"].max(), col["pmax_ratio_fe"].max())]
    axes[2].plot(lim, lim, "k-", lw=0.8, label="p_max = m·p_mean")
    axes[2].set_xlabel("local m = d log F / d log A (quadratic fit)")
    axes[2].set_ylabel("FE p_max / p_mean")
    for ax in axes:
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
    for ax in axes[:2]:
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    save_figure(fig, path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--out", type=Path, default=Path("out/ef_calibration"))
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--write", action="store_true",
                        help=f"write the table to {TABLE.relative_to(TABLE.parents[2])}")
    args = parser.parse_args()
    if args.quick and args.write:
        parser.error("--write needs the full grid (no --quick)")
    axes = QUICK if args.quick else {"poisson": POISSON, "thickness_mm": THICKNESS_MM,
                                     "radius_mm": RADIUS_MM}
    args.out.mkdir(parents=True, exist_ok=True)
    t = time.perf_counter()
    rows, entries = run(axes, args.jobs, args.out / "ef_calibration_table.csv")
    wall = time.perf_counter() - t
    print(f"{len(rows)} solves in {wall:.0f} s wall ({sum(r['time_s'] for r in rows):.0f} s "
          f"of solves, {args.jobs} processes); F/E = "
          + ", ".join(f"{v:.3g}" for v in FORCE_OVER_E) + " mm²; element size "
          f"{min(r['size_mm'] for r in rows):.3f}-{max(r['size_mm'] for r in rows):.3f} mm")
    summary(rows, axes)
    table = table_json(axes, entries, MAX_SIZE_MM)
    text = json.dumps(table, indent=1) + "\n"
    (args.out / "ef_calibration_table.json").write_text(text)
    if args.write:
        TABLE.write_text(text)
        print(f"wrote {TABLE}")
    plot(rows, args.out / "ef_calibration_table.png")
    print(f"wrote {args.out}/ef_calibration_table.csv, .json, .png")


if __name__ == "__main__":
    main()
