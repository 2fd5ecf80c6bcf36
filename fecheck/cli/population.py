"""`fecheck population [SCENE] --vary KEY=DIST [--vary ...] --samples N`: the EF over a
population of scenes drawn from distributions of some keys, with Sobol sensitivity indices.

Only the standard library is imported here; the study inside `run`.

Exit codes: 0 every sample solved and converged, 1 a sample failed or did not converge
(recorded in the CSV and counted), 2 a user error before the first sample, 130
interrupted (Ctrl-C or SIGTERM: the finished samples are kept in the CSV; the same
command resumes from it).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import sys
import time
from pathlib import Path

from fecheck.cli import add_scene_arguments

CHECKPOINT_S = 2.0
"""The CSV is rewritten after a finished sample once this long has passed since the last
write, or ten times that write's duration if longer (s)."""


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "population", help="the EF over samples of some scene keys, with Sobol indices",
        description="Draw samples of the --vary keys from their distributions (a scrambled "
                    "Sobol sequence, a Latin hypercube or random points of scipy.stats.qmc "
                    "in Saltelli's design), run the scene's EF at each, and report the "
                    "outputs' statistics and their first-order and total Sobol indices "
                    "(SALib, bootstrap intervals). Example: fecheck population --vary "
                    "contact.youngs_MPa=uniform:10:30 --vary load.force_N=normal:800:80 "
                    "--samples 2000 --csv pop.csv --plot pop/")
    add_scene_arguments(p, "override a scene key for every sample (TOML literal)")
    p.add_argument("--vary", action="append", required=True, metavar="KEY=DIST",
                   help="a key and its distribution: uniform:LO:HI, normal:MEAN:SD, "
                        "lognormal:MEAN:SD (of the value) or scale:LO:HI (a factor on the "
                        "scene's value; a vector key scaled by one factor); KEY[i] varies "
                        "one component of a vector key")
    p.add_argument("--samples", type=int, required=True, metavar="N",
                   help="number of EF runs (with indices: rounded down to a multiple of "
                        "the number of keys + 2)")
    p.add_argument("--seed", type=int, default=0, help="seed of the design (default 0)")
    p.add_argument("--method", choices=("sobol", "lhs", "random"), default="sobol",
                   help="base points: scrambled Sobol sequence (default), Latin hypercube "
                        "or pseudo-random")
    p.add_argument("--indices", choices=("sobol", "none"), default="sobol",
                   help="sobol: Saltelli's design and Sobol indices (default); none: plain "
                        "samples, statistics only")
    p.add_argument("--outputs", nargs="+", metavar="NAME",
                   help="outputs to report (default: max_pressure_MPa medial_share "
                        "medial_max_pressure_MPa lateral_max_pressure_MPa; any column of "
                        "`fecheck run --csv`, or area_mm2)")
    p.add_argument("--json", metavar="PATH", help="write the study's summary as JSON")
    p.add_argument("--csv", metavar="PATH",
                   help="one row per finished sample, kept up to date while the study runs; "
                        "an existing file of the same study is resumed")
    p.add_argument("--plot", type=Path, metavar="DIR",
                   help="write histograms, a tornado chart and scatter plots (PNG)")
    p.add_argument("--fe-spot", type=int, default=0, metavar="K",
                   help="run `fecheck fe` at the K samples with the most extreme first "
                        "output, as spot checks of the EF (minutes each on scanned knees)")
    p.add_argument("--allow-rebuild", action="store_true",
                   help="accept keys that rebuild the model's meshes at every sample")
    p.add_argument("--workers", type=int, default=1, metavar="N",
                   help="run samples in N local processes (default 1: serial)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run samples on a Dask distributed scheduler (needs fecheck[dask])")
    p.set_defaults(run=run)


class _Checkpoint:
    """`run_population`'s ``on_sample``: rewrites the CSV at the pace of `CHECKPOINT_S`."""

    def __init__(self, path: str | None, plan):
        from fecheck.io.outputs import writes_in_place

        self.path = None if not path or path == "-" or writes_in_place(path) else path
        self.plan = plan
        self.written_at, self.took = -math.inf, 0.0

    def __call__(self, samples) -> None:
        from fecheck.studies.population import write_csv

        if self.path is None:
            return
        start = time.monotonic()
        if start - self.written_at < max(CHECKPOINT_S, 10.0 * self.took):
            return
        write_csv(self.plan, samples, self.path)
        self.written_at = time.monotonic()
        self.took = self.written_at - start


def _prepare(args: argparse.Namespace):
    """Every check that can fail before a sample runs: keys, distributions, ranges,
    sample count, output paths, a resumable CSV, the rebuild cost; → (scene, plan, done,
    notes, the baseline pose every sample starts from)."""
    from fecheck.errors import FecheckError
    from fecheck.io.outputs import check_output
    from fecheck.scene import load_scene
    from fecheck.studies.population import check_rebuilds, make_plan, probe, read_done
    from fecheck.studies.population_inputs import check_ranges, parse_varied

    if args.workers < 1:
        raise FecheckError("--workers must be at least 1")
    if args.fe_spot < 0:
        raise FecheckError("--fe-spot must be 0 or more")
    scene = load_scene(args.scene, args.overrides)
    varied = parse_varied(args.vary, scene)
    check_ranges(varied, scene)
    plan = make_plan(scene, varied, args.samples, args.method, args.seed,
                     args.indices == "sobol")
    for path in (args.json, args.csv):
        check_output(path)
    check_output(args.plot, directory=True)
    done = read_done(args.csv, plan) if args.csv and args.csv != "-" else {}
    notes = []
    if plan.runs != args.samples:
        notes.append(f"{plan.runs} samples: {plan.base_rows} base rows of {len(varied)} + 2 "
                     f"runs each (Saltelli's design)")
    found = probe(scene, plan)
    if args.allow_rebuild:
        notes += [f"{k} rebuilds the model's parts at every sample: {v:.2g} s each"
                  for k, v in found.rebuild_s.items()]
    else:
        notes += check_rebuilds(found, plan)
    return scene, plan, done, notes, found.start


def _outputs(args, samples) -> list[str]:
    from fecheck.studies.population import DEFAULT_OUTPUTS, check_outputs, output_columns

    available = [c for c in output_columns(samples) if c != "converged"]
    if args.outputs:
        check_outputs(args.outputs, available)
        return list(args.outputs)
    return [o for o in DEFAULT_OUTPUTS if o in available]


def _print_summary(plan, samples, outputs, indices, stream) -> None:
    from fecheck.studies.population import describe, output_matrix

    print(f"{'output':28s} {'n':>6s} {'mean':>11s} {'sd':>10s} {'p5':>10s} {'median':>10s} "
          f"{'p95':>10s}", file=stream)
    for name in outputs:
        s = describe(output_matrix(plan, samples, name))
        if s["n"] == 0:
            print(f"{name:28s} {0:6d}  (no converged sample)", file=stream)
            continue
        print(f"{name:28s} {s['n']:6d} {s['mean']:11.5g} {s['sd']:10.4g} {s['p5']:10.5g} "
              f"{s['median']:10.5g} {s['p95']:10.5g}", file=stream)
    for name, idx in indices.items():
        if isinstance(idx, str):
            print(f"Sobol indices of {name}: {idx}", file=stream)
            continue
        print(f"Sobol indices of {name} ({idx.groups} base rows; ± 95 % bootstrap):",
              file=stream)
        for i in sorted(range(len(idx.names)), key=lambda i: -idx.st[i]):
            print(f"  {idx.names[i]:32s} S1 {idx.s1[i]:6.3f} ± {idx.s1_conf[i]:5.3f}   "
                  f"ST {idx.st[i]:6.3f} ± {idx.st_conf[i]:5.3f}", file=stream)


def _indices(plan, samples, outputs) -> dict:
    """{output: Indices, or the one-line reason it has none}."""
    from fecheck.errors import FecheckError
    from fecheck.studies.population import indices_of

    if not plan.indices or len(samples) < plan.runs:
        return {}
    out = {}
    for name in outputs:
        try:
            out[name] = indices_of(plan, samples, name)
        except FecheckError as err:
            out[name] = str(err)
    return out


def _spot_checks(args, scene, plan, samples, outputs, stream) -> list[dict]:
    """`fecheck fe` at the most extreme samples of the first output."""
    from fecheck.errors import FecheckError
    from fecheck.fe.knee.crosscheck import cross_check
    from fecheck.scene import apply_overrides
    from fecheck.studies.population import extreme_samples

    out = []
    for i in extreme_samples(plan, samples, outputs[0], args.fe_spot):
        try:
            check = cross_check(apply_overrides(scene, list(plan.overrides[i])), log=None)
            entry = {"sample": i, "overrides": list(plan.overrides[i]),
                     "fe": check.as_dict()}
            peaks = ", ".join(f"{c} p_max EF {k.ef_model.max_pressure_MPa:.3f} FE "
                              f"{k.fe.max_pressure_MPa:.3f} MPa"
                              for c, k in check.compartments.items())
            print(f"FE spot check at sample {i} ({' '.join(plan.overrides[i])}): {peaks}",
                  file=stream)
        except FecheckError as err:
            entry = {"sample": i, "error": str(err)}
            print(f"FE spot check at sample {i}: {err}", file=stream)
        out.append(entry)
    return out


def _report(args, scene, plan, samples, notes, interrupted: bool) -> int:
    from fecheck.io.outputs import write_text
    from fecheck.scene.provenance import with_provenance
    from fecheck.studies.population import report_dict, write_csv

    stream = sys.stdout
    outputs = _outputs(args, samples)
    indices = _indices(plan, samples, outputs) if not interrupted else {}
    if args.csv:
        write_csv(plan, samples, args.csv)
    _print_summary(plan, samples, outputs, indices, stream)
    spots = (_spot_checks(args, scene, plan, samples, outputs, stream)
             if args.fe_spot and outputs and not interrupted else [])
    if args.plot and outputs:
        from fecheck.studies import population_plots as plots

        paths = [plots.histograms(plan, samples, outputs, args.plot),
                 plots.scatter(plan, samples, outputs, args.plot)]
        good = {k: v for k, v in indices.items() if not isinstance(v, str)}
        if good:
            paths.append(plots.tornado(good, args.plot))
        for path in paths:
            print(f"wrote {path}", file=stream)
    if args.json:
        data = report_dict(scene, plan, samples, outputs,
                           {k: (v if isinstance(v, str) else v.as_dict())
                            for k, v in indices.items()}, notes)
        data["fe_spot_checks"] = spots
        write_text(args.json, json.dumps(with_provenance(data, scene), indent=2,
                                         default=float) + "\n")
    for line in notes:
        print(f"fecheck: note: {line}", file=sys.stderr)
    failed = sum(1 for s in samples.values() if s.failed)
    stalled = sum(1 for s in samples.values() if not s.failed and not s.converged)
    if failed:
        first = next(s for s in samples.values() if s.failed)
        print(f"fecheck: {failed} of {plan.runs} samples failed (first: sample {first.index}: "
              f"{first.error})", file=sys.stderr)
    if stalled:
        print(f"fecheck: {stalled} of {plan.runs} samples did not converge", file=sys.stderr)
    if interrupted:
        print(f"fecheck: interrupted: {plan.runs - len(samples)} of {plan.runs} samples "
              f"missing ({len(samples)} finished)"
              + ("; run the same command again to resume from the CSV" if args.csv else ""),
              file=sys.stderr)
        return 130
    return 0 if not failed and not stalled else 1


def run(args: argparse.Namespace) -> int:
    """Check everything, run the samples (SIGTERM stops like Ctrl-C), report."""
    from fecheck.studies.pool import interrupts_ignored, interrupts_raised
    from fecheck.studies.population import PopulationInterrupted, run_population
    from fecheck.studies.sweep import dask_executor

    scene, plan, done, notes, start = _prepare(args)
    if done:
        print(f"fecheck: resuming: {len(done)} of {plan.runs} samples already in {args.csv}",
              file=sys.stderr)
    executor = (dask_executor(args.scheduler) if args.scheduler
                else contextlib.nullcontext(None))
    try:
        with interrupts_raised(), executor as pool:
            samples = run_population(scene, plan, done=done, start=start,
                                     workers=args.workers,
                                     executor=pool, on_sample=_Checkpoint(args.csv, plan))
    except PopulationInterrupted as stop:
        with interrupts_ignored():
            return _report(args, scene, plan, stop.samples, notes, interrupted=True)
    return _report(args, scene, plan, samples, notes, interrupted=False)
