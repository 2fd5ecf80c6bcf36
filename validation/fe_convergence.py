"""FE mesh convergence on the baseline compartments (issue 5; Donahue 2002's 5, 2, 1 mm
and finer).

Both compartments of the baseline knee (rigid Table 5.1 loads, load at x = +7.9 mm: medial
323.71 N on R 25.5 mm, lateral 456.67 N on R 31.8 mm; E 20 MPa, ν 0.3, h 6 mm) are solved by
the 3D quadratic-tetrahedron model at 5, 2, 1.5, 1 and 0.5 mm under the contact ("3d":
uniform, no edge band), by the default 3D model at 1.5 mm (and 1 mm) with its 0.9 mm
band around the expected contact edge ("3d+band"), and by the axisymmetric model from 2
mm down to 0.025 mm. The finest axisymmetric solution is the reference; the script
reports each run's error on p_max, area and depth, the observed order of convergence
between successive sizes, and the estimated error of the defaults (3D 1.5 mm + band,
axisymmetric 0.1 mm). Times are wall clock on a shared machine: read the ratios.

    python validation/fe_convergence.py [--quick] [--out DIR]

--quick: the medial compartment only, 3D at 5 and 2 mm, 3D+band at 1.5 mm, axisymmetric
0.4-0.1 mm against 0.05 mm.
Writes DIR/fe_convergence.csv (rewritten after every run) and DIR/fe_convergence.png.
The 0.5 mm 3D runs take minutes and several GB (about 150k dofs).
"""

from __future__ import annotations

import argparse
import csv
import time
from itertools import pairwise
from pathlib import Path

import numpy as np
from report import save_figure

from fecheck.fe.axisym import axisym_sphere_on_layer
from fecheck.fe.layer3d import sphere_on_layer_3d

COMPARTMENTS = {"medial": (323.71, 25.5), "lateral": (456.67, 31.8)}
E_MPA, NU, H_MM = 20.0, 0.3, 6.0
DEFAULTS = {"3d+band": 1.5, "axisym": 0.1}
MODELS = ("3d", "3d+band", "axisym")


def solve(model: str, load: float, radius: float, size: float):
    t = time.perf_counter()
    if model in ("3d", "3d+band"):
        band = {} if model == "3d+band" else {"edge_size_mm": None}
        res = sphere_on_layer_3d(load, radius, E_MPA, NU, H_MM, size_mm=size,
                                 far_size_mm=max(5.0, size), **band)
    else:
        res = axisym_sphere_on_layer(load, radius, E_MPA, NU, H_MM, size_mm=size)
    return res, time.perf_counter() - t


def observed_order(sizes: list[float], errors: list[float]) -> list[float]:
    """log(e_i / e_{i+1}) / log(h_i / h_{i+1}) between successive sizes (NaN if undefined)."""
    out = [float("nan")]
    for (h0, e0), (h1, e1) in pairwise(zip(sizes, errors, strict=True)):
        ok = e0 > 0 and e1 > 0
        out.append(float(np.log(e0 / e1) / np.log(h0 / h1)) if ok else float("nan"))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--out", type=Path, default=Path("out/fe"))
    args = parser.parse_args()
    sizes = {"3d": [5.0, 2.0] if args.quick else [5.0, 2.0, 1.5, 1.0, 0.5],
             "3d+band": [1.5] if args.quick else [1.5, 1.0],
             "axisym": [0.4, 0.2, 0.1] if args.quick else [2.0, 1.0, 0.5, 0.2, 0.1, 0.05]}
    ref_size = 0.05 if args.quick else 0.025
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "fe_convergence.csv"
    rows = []
    compartments = ("medial",) if args.quick else tuple(COMPARTMENTS)
    for comp in compartments:
        load, radius = COMPARTMENTS[comp]
        ref, ref_time = solve("axisym", load, radius, ref_size)
        r = ref.metrics
        print(f"{comp}: reference axisymmetric {ref_size} mm ({ref.n_dofs} dofs, "
              f"{ref_time:.1f} s): p_max {r.max_pressure_MPa:.4f} MPa, area "
              f"{r.area_mm2:.2f} mm², depth {r.depth_mm:.4f} mm", flush=True)
        for model, model_sizes in sizes.items():
            errs: dict[str, list[float]] = {"max_pressure_MPa": [], "area_mm2": []}
            for s in model_sizes:
                res, sec = solve(model, load, radius, s)
                m = res.metrics
                for key, e in errs.items():
                    e.append(abs(getattr(m, key) / getattr(r, key) - 1))
                order = {key: observed_order(model_sizes[:len(e)], e)[-1]
                         for key, e in errs.items()}
                rows.append({"compartment": comp, "model": model, "size_mm": s,
                             "n_dofs": res.n_dofs, "time_s": round(sec, 3),
                             "max_pressure_MPa": m.max_pressure_MPa, "area_mm2": m.area_mm2,
                             "depth_mm": m.depth_mm,
                             "err_max_pressure": m.max_pressure_MPa / r.max_pressure_MPa - 1,
                             "err_area": m.area_mm2 / r.area_mm2 - 1,
                             "err_depth": m.depth_mm / r.depth_mm - 1,
                             "order_max_pressure": order["max_pressure_MPa"],
                             "order_area": order["area_mm2"],
                             "time_over_reference": sec / ref_time})
                print(f"  {model:7s} {s:5.3g} mm {res.n_dofs:7d} dofs {sec:7.2f} s  "
                      f"p_max {100 * rows[-1]['err_max_pressure']:+6.2f}%  area "
                      f"{100 * rows[-1]['err_area']:+6.2f}%  depth "
                      f"{100 * rows[-1]['err_depth']:+6.2f}%  order p/A "
                      f"{order['max_pressure_MPa']:5.2f}/{order['area_mm2']:5.2f}", flush=True)
                with path.open("w", newline="") as fh:
                    writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
                    writer.writeheader()
                    writer.writerows(rows)
    print(f"wrote {path}")
    for model, size in DEFAULTS.items():
        hits = [row for row in rows if row["model"] == model and row["size_mm"] == size]
        for row in hits:
            print(f"default {model} ({size} mm), {row['compartment']}: estimated error "
                  f"p_max {100 * row['err_max_pressure']:+.2f}%, area "
                  f"{100 * row['err_area']:+.2f}%, {row['time_s']:.2f} s")
    plot(rows, args.out / "fe_convergence.png")


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, key, label in ((axes[0], "err_max_pressure", "p_max"), (axes[1], "err_area", "area")):
        for (comp, model), style in zip([(c, m) for c in COMPARTMENTS for m in MODELS],
                                        ("o-", "^:", "s--") * 2, strict=True):
            pts = [(r["size_mm"], abs(r[key])) for r in rows
                   if r["compartment"] == comp and r["model"] == model and abs(r[key]) > 0]
            if pts:
                x, y = zip(*pts, strict=True)
                ax.loglog(x, y, style, label=f"{comp} {model}")
        ax.set_xlabel("element size under the contact (mm)")
        ax.set_ylabel(f"|relative error| of {label} vs finest axisymmetric")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    print(f"wrote {save_figure(fig, path)}")


if __name__ == "__main__":
    main()
