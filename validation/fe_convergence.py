"""FE mesh convergence and cost of the general FE path on the baseline compartments
(Donahue 2002's 5, 2, 1 mm and finer).

Both compartments of the baseline knee (rigid Table 5.1 loads: medial 323.71 N on R 25.5
mm, lateral 456.67 N on R 31.8 mm; E 20 MPa, ν 0.3, h 6 mm) are solved by the general
path of `fecheck fe` on the flat layer (`fecheck.fe.reference.sphere_layer.sphere_on_flat_layer`:
extruded P2 layer, 2 graded levels, exact contact) at a ladder of element sizes under
the contact, and by the axisymmetric model from 0.4 mm down. The finest axisymmetric
solution is the reference: each run's error on p_max, area and depth, the observed
order between successive sizes, the cost exponent k of time ∝ dofs^k fitted over the 3D
ladder (target k ≤ 1.3; also per phase: mesh and assembly, factorization and
condensation), and the wall time and peak memory (ru_maxrss) of the 0.5 mm
level (targets < 60 s, < 2 GB). Each 3D level runs in a fresh process, so its peak
memory is its own (interpreter and imports included). Times are wall clock on a shared
machine: read the ratios.

    python validation/fe_convergence.py [--quick] [--out DIR]

--quick: the medial compartment only, 3D at 2 and 1 mm, axisymmetric 0.4-0.1 mm against
0.05 mm. Writes DIR/fe_convergence.csv (rewritten after every run) and
DIR/fe_convergence.png.
"""

from __future__ import annotations

import argparse
import csv
import multiprocessing as mp
import resource
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from itertools import pairwise
from pathlib import Path

import numpy as np

from fecheck.fe.reference.axisym import axisym_sphere_on_layer

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.studies.thesis.report import save_figure

COMPARTMENTS = {"medial": (323.71, 25.5), "lateral": (456.67, 31.8)}
E_MPA, NU, H_MM = 20.0, 0.3, 6.0
MODELS = ("3d", "axisym")
COST_LEVEL_MM = 0.5
TARGETS = {"exponent": 1.3, "seconds": 60.0, "gigabytes": 2.0}


def solve_3d(load: float, radius: float, size: float) -> tuple[dict, float, float, float]:
    """`sphere_on_flat_layer` at `size` mm: its metrics and counts, wall and CPU time (s),
    and this process's peak resident memory (bytes, ru_maxrss)."""
    from fecheck.fe.reference.sphere_layer import sphere_on_flat_layer

    t, c = time.perf_counter(), time.process_time()
    res = sphere_on_flat_layer(load, radius, E_MPA, NU, H_MM, refine_size_mm=size)
    wall, cpu = time.perf_counter() - t, time.process_time() - c
    peak = 1024.0 * resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return ({**res.metrics.as_dict(), "n_dofs": res.n_dofs, "build_s": res.timing_s["build"],
             "condense_s": res.timing_s["condense"]}, wall, cpu, peak)


def solve(model: str, load: float, radius: float, size: float) -> tuple[dict, float, float,
                                                                        float]:
    """One run: 3D in a fresh process (its own peak memory), axisymmetric here (NaN
    memory)."""
    if model == "3d":
        with ProcessPoolExecutor(1, mp_context=mp.get_context("spawn")) as pool:
            return pool.submit(solve_3d, load, radius, size).result()
    t, c = time.perf_counter(), time.process_time()
    res = axisym_sphere_on_layer(load, radius, E_MPA, NU, H_MM, size_mm=size)
    return ({**res.metrics.as_dict(), "n_dofs": res.n_dofs, "build_s": float("nan"),
             "condense_s": float("nan")}, time.perf_counter() - t, time.process_time() - c,
            float("nan"))


def observed_order(sizes: list[float], errors: list[float]) -> list[float]:
    """log(e_i / e_{i+1}) / log(h_i / h_{i+1}) between successive sizes (NaN if undefined)."""
    out = [float("nan")]
    for (h0, e0), (h1, e1) in pairwise(zip(sizes, errors, strict=True)):
        ok = e0 > 0 and e1 > 0
        out.append(float(np.log(e0 / e1) / np.log(h0 / h1)) if ok else float("nan"))
    return out


def cost_exponent(dofs: list[float], seconds: list[float]) -> float:
    """k of time ∝ dofs^k, least squares in log-log (NaN below two levels)."""
    if len(dofs) < 2:
        return float("nan")
    return float(np.polyfit(np.log(dofs), np.log(seconds), 1)[0])


def write(rows: list[dict], path: Path) -> None:
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def run_ladder(comp: str, model: str, sizes: list[float], ref: dict, rows: list[dict],
               path: Path) -> None:
    """Solve `model` at each size of `comp`, append the rows and rewrite the CSV."""
    load, radius = COMPARTMENTS[comp]
    errs: dict[str, list[float]] = {"max_pressure_MPa": [], "area_mm2": []}
    for s in sizes:
        m, wall, cpu, peak = solve(model, load, radius, s)
        for key, e in errs.items():
            e.append(abs(m[key] / ref[key] - 1))
        order = {key: observed_order(sizes[:len(e)], e)[-1] for key, e in errs.items()}
        rows.append({"compartment": comp, "model": model, "size_mm": s, "n_dofs": m["n_dofs"],
                     "time_s": round(wall, 3), "cpu_s": round(cpu, 3),
                     "build_s": m["build_s"], "condense_s": m["condense_s"],
                     "peak_memory_GB": peak / 1e9,
                     "max_pressure_MPa": m["max_pressure_MPa"], "area_mm2": m["area_mm2"],
                     "depth_mm": m["depth_mm"],
                     "err_max_pressure": m["max_pressure_MPa"] / ref["max_pressure_MPa"] - 1,
                     "err_area": m["area_mm2"] / ref["area_mm2"] - 1,
                     "err_depth": m["depth_mm"] / ref["depth_mm"] - 1,
                     "order_max_pressure": order["max_pressure_MPa"],
                     "order_area": order["area_mm2"]})
        r = rows[-1]
        memory = "" if np.isnan(peak) else f" {peak / 1e9:5.2f} GB"
        print(f"  {model:6s} {s:5.3g} mm {r['n_dofs']:7d} dofs {wall:7.2f} s{memory}  p_max "
              f"{100 * r['err_max_pressure']:+6.2f}%  area {100 * r['err_area']:+6.2f}%  "
              f"depth {100 * r['err_depth']:+6.2f}%  order p/A "
              f"{order['max_pressure_MPa']:5.2f}/{order['area_mm2']:5.2f}", flush=True)
        write(rows, path)


def cost_summary(rows: list[dict]) -> None:
    """The fitted cost exponent per compartment and the cost of the 0.5 mm level."""
    for comp in dict.fromkeys(r["compartment"] for r in rows):
        ladder = [r for r in rows if r["compartment"] == comp and r["model"] == "3d"]
        dofs = [r["n_dofs"] for r in ladder]
        k = {key: cost_exponent(dofs, [r[key] for r in ladder])
             for key in ("time_s", "cpu_s", "build_s", "condense_s")}
        verdict = "within" if k["time_s"] <= TARGETS["exponent"] else "above"
        print(f"{comp}: time ∝ dofs^k over {len(ladder)} 3D levels ({dofs[0]}-{dofs[-1]} "
              f"dofs): k = {k['time_s']:.2f} wall ({verdict} the target k ≤ "
              f"{TARGETS['exponent']}), {k['cpu_s']:.2f} CPU; mesh and assembly "
              f"{k['build_s']:.2f}, factorization and condensation {k['condense_s']:.2f}")
        for r in ladder:
            if r["size_mm"] == COST_LEVEL_MM:
                ok = (r["time_s"] < TARGETS["seconds"]
                      and r["peak_memory_GB"] < TARGETS["gigabytes"])
                print(f"{comp}: {COST_LEVEL_MM} mm level {r['n_dofs']} dofs, {r['time_s']:.1f} "
                      f"s wall ({r['cpu_s']:.1f} s CPU), peak memory "
                      f"{r['peak_memory_GB']:.2f} GB -> {'within' if ok else 'beyond'} the "
                      f"targets (< {TARGETS['seconds']:g} s, < {TARGETS['gigabytes']:g} GB)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--out", type=Path, default=Path("out/fe"))
    args = parser.parse_args()
    sizes = {"3d": [2.0, 1.0] if args.quick else [2.0, 1.4, 1.0, 0.7, 0.5],
             "axisym": [0.4, 0.2, 0.1] if args.quick else [0.4, 0.2, 0.1, 0.05]}
    ref_size = 0.05 if args.quick else 0.025
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "fe_convergence.csv"
    rows: list[dict] = []
    for comp in ("medial",) if args.quick else tuple(COMPARTMENTS):
        ref, ref_time, _, _ = solve("axisym", *COMPARTMENTS[comp], ref_size)
        print(f"{comp}: reference axisymmetric {ref_size} mm ({ref['n_dofs']} dofs, "
              f"{ref_time:.1f} s): p_max {ref['max_pressure_MPa']:.4f} MPa, area "
              f"{ref['area_mm2']:.2f} mm², depth {ref['depth_mm']:.4f} mm", flush=True)
        for model, model_sizes in sizes.items():
            run_ladder(comp, model, model_sizes, ref, rows, path)
    print(f"wrote {path}")
    cost_summary(rows)
    plot(rows, args.out / "fe_convergence.png")


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    styles = dict(zip([(c, m) for c in COMPARTMENTS for m in MODELS],
                      ("o-", "s--", "^-", "d--"), strict=True))
    for ax, key, label in ((axes[0], "err_max_pressure", "p_max"), (axes[1], "err_area", "area")):
        for (comp, model), style in styles.items():
            pts = [(r["size_mm"], abs(r[key])) for r in rows
                   if r["compartment"] == comp and r["model"] == model and abs(r[key]) > 0]
            if pts:
                x, y = zip(*pts, strict=True)
                ax.loglog(x, y, style, label=f"{comp} {model}")
        ax.set_xlabel("element size under the contact (mm)")
        ax.set_ylabel(f"|relative error| of {label} vs finest axisymmetric")
    for comp in COMPARTMENTS:
        ladder = [r for r in rows if r["compartment"] == comp and r["model"] == "3d"]
        if ladder:
            n = np.array([r["n_dofs"] for r in ladder], dtype=float)
            t = np.array([r["time_s"] for r in ladder])
            k = cost_exponent(list(n), list(t))
            axes[2].loglog(n, t, styles[comp, "3d"], label=f"{comp} 3D (k = {k:.2f})")
    axes[2].set_xlabel("dofs")
    axes[2].set_ylabel("wall time per solve (s)")
    for ax in axes:
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    print(f"wrote {save_figure(fig, path)}")


if __name__ == "__main__":
    main()
