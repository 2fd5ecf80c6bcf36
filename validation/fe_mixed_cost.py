"""The cost of the mixed formulation: FE CPU time per dof of `fecheck fe` on the baseline
scene at ν 0.45 (the default there: mixed) against ν 0.3 (displacement); at ν 0.45 with
the displacement form on the same mesh (the formulation's own cost); and at ν 0.3 on the
ν 0.45 mesh (`SAME_MESH`: the cost of the problem's size, which grows 5x with ν here).

The runs are interleaved (0.3, 0.45 mixed, 0.45 displacement, repeated) so that the load
of a shared machine falls on all three alike; each row is one run, the summary the
median and range of the per-dof ratios. The FE's CPU time is the run's CPU time
(`time.process_time`, one BLAS thread) times the FE's share of its wall time (build,
condensation, contact). A benchmark, not a test.

    python validation/fe_mixed_cost.py [--repeats 3] [--quick] [--out DIR]

Writes DIR/fe_mixed_cost.csv (default: the current directory).
"""

from __future__ import annotations

import argparse
import csv
import os
import statistics
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

SAME_MESH = ("mesh.plateau_refine_mm=0.4", "fe.layers=3")
"""The ν 0.45 default mesh (the plateau refined to 0.4 mm, where the smaller expected
contact of the stiffer foundation puts it: `fecheck.model.meshing.plateau_mesh_sizes`;
3 levels through the thickness) for a ν 0.3 run."""
VARIANTS = (("0.3 default", 0.3, "auto", ()), ("0.45 default", 0.45, "auto", ()),
            ("0.45 displacement", 0.45, "displacement", ()),
            ("0.3 on the 0.45 mesh", 0.3, "auto", SAME_MESH))
QUICK_MESH = ("mesh.plateau_refine_mm=1.4", "fe.axisym_size_mm=0.2")
"""--quick: the ν 0.3 mesh coarser (under half its dofs) and a coarser axisymmetric reference."""
QUICK = (("0.3 default", 0.3, "auto", QUICK_MESH), ("0.3 mixed", 0.3, "mixed", QUICK_MESH))
"""--quick: one repeat on the coarser ν 0.3 mesh only, displacement and mixed."""


def run_once(nu: float, formulation: str, keys: tuple[str, ...] = ()) -> dict:
    """One `fecheck fe` solve (joint mode, no error estimate) of the baseline scene with
    the scene `keys` set."""
    import fecheck.fe.knee.crosscheck as cc
    from fecheck.scene import load_scene

    scene = load_scene(None, [f"contact.poisson={nu}", f"fe.formulation={formulation}",
                              *keys])
    t = time.process_time()
    res = cc.cross_check(scene, log=None)
    cpu = time.process_time() - t
    dofs = sum(c.layer.solid.n_dofs for c in res.compartments.values())
    fe_cpu = cpu * res.timing_s["fe"] / res.timing_s["total"]
    return {"nu": nu, "formulation": res.settings.formulation_for(nu), "n_dofs": dofs,
            "fe_cpu_s": fe_cpu, "build_s": res.timing_s["fe_build"],
            "condense_s": res.timing_s["fe_condense"], "contact_s": res.timing_s["fe_contact"],
            "us_per_dof": 1e6 * fe_cpu / dofs}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--quick", action="store_true",
                        help="one repeat, ν 0.3 only on a coarser mesh: displacement and mixed")
    parser.add_argument("--out", type=Path, default=Path("."))
    args = parser.parse_args()
    variants = QUICK if args.quick else VARIANTS
    run_once(*variants[0][1:])                          # warm: imports, numba kernels
    rows = []
    for k in range(1 if args.quick else args.repeats):
        for label, nu, form, keys in variants:
            row = {"repeat": k, "variant": label, **run_once(nu, form, keys)}
            rows.append(row)
            print(f"{k} {label:18s} {row['n_dofs']:7d} dofs  FE {row['fe_cpu_s']:6.1f} s CPU "
                  f"(build {row['build_s']:.1f}, condense {row['condense_s']:.1f}, contact "
                  f"{row['contact_s']:.1f} s wall)  {row['us_per_dof']:.0f} µs/dof", flush=True)
    per = {v[0]: [r["us_per_dof"] for r in rows if r["variant"] == v[0]] for v in variants}
    pairs = [("0.3 mixed", "0.3 default")] if args.quick else [
        ("0.45 default", "0.3 default"), ("0.45 default", "0.45 displacement"),
        ("0.45 default", "0.3 on the 0.45 mesh"), ("0.3 on the 0.45 mesh", "0.3 default")]
    for top, bottom in pairs:
        ratios = [b / a for a, b in zip(per[bottom], per[top], strict=True)]
        print(f"time per dof, {top} / {bottom}: median {statistics.median(ratios):.2f} "
              f"(range {min(ratios):.2f}-{max(ratios):.2f})")
    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / "fe_mixed_cost.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


if __name__ == "__main__":
    main()
