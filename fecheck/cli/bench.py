"""`fecheck bench [SUITE]`: benchmarks (run time and accuracy, reported as ratios)."""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

SUITES = ("pareto", "detection", "peers", "sweeps")


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "bench", help="run a benchmark suite (default pareto: run time against error of "
                      "every method; detection: thesis Figs. 3.21/3.25; peers: against Drake "
                      "and OpenSim; sweeps: equilibria per second of load-point sweeps)",
        description="Benchmarks measured in one run and reported as ratios. 'pareto' (the "
                    "default): time and error of EF (clipped, whole-face, analytic master), "
                    "the thesis stack, Hertz and FE on the baseline compartments against "
                    "each model's converged reference, and time per contact evaluation "
                    "against faces (fecheck.studies.bench). 'detection': "
                    "contact detection time and area/volume errors against exact values, "
                    "our engine vs the thesis stack (fcl, ray parity + cKDTree). 'peers': time "
                    "per contact evaluation of an icosphere on a plane against Drake's "
                    "hydroelastic contact and OpenSim's elastic foundation, in one process "
                    "(fecheck.studies.bench_peers; pip install -e '.[peers]'). 'sweeps': "
                    "equilibria per second of load-point sweeps of the baseline and the "
                    "scanned femur-tibia scene, serial and on 2 workers "
                    "(fecheck.studies.bench_sweeps).")
    p.add_argument("suite", nargs="?", default="pareto", choices=SUITES,
                   help="benchmark suite (default: pareto)")
    p.add_argument("--quick", action="store_true",
                   help="small sizes only (≤ 20,480 faces; peers: ≤ 5,120; sweeps: 100 and 10 "
                        "points)")
    p.add_argument("--json", type=Path, metavar="PATH",
                   help="write rows and ratios as JSON ('-': standard output)")
    p.add_argument("--plot", type=Path, metavar="DIR",
                   help="write log-log PNGs into DIR (not for peers or sweeps)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from fecheck.io.outputs import check_output

    check_output(args.json)                     # before minutes of work, not after
    check_output(args.plot, directory=True)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    if args.suite == "pareto":
        return _pareto(args)
    if args.suite in ("peers", "sweeps"):
        return _unplotted(args, args.suite)
    from fecheck.studies import bench_detection as bench

    result = bench.run(quick=args.quick,
                       progress=lambda m: print(f"  {m}", file=sys.stderr, flush=True))
    _report(args, bench.table(result), json.dumps(_stamped(result), indent=1) + "\n",
            lambda: bench.plot(result, args.plot))
    return 0


def _pareto(args: argparse.Namespace) -> int:
    from fecheck.studies import bench

    config = bench.BenchConfig.quick() if args.quick else bench.BenchConfig()
    result = bench.run_bench(config, log=lambda m: print(f"  {m}", file=sys.stderr, flush=True))
    _report(args, bench.table(result), bench.json_text(_stamped(result)),
            lambda: bench.plot(result, str(args.plot)))
    return 0


def _unplotted(args: argparse.Namespace, suite: str) -> int:
    """Run a suite that draws no plots (peers, sweeps): its table and JSON."""
    import importlib

    module = importlib.import_module(f"fecheck.studies.bench_{suite}")
    if args.plot:
        print(f"bench {suite} draws no plots: --plot ignored", file=sys.stderr)
    result = module.run(quick=args.quick,
                        progress=lambda m: print(f"  {m}", file=sys.stderr, flush=True))
    _report(args, module.table(result), json.dumps(_stamped(result), indent=1) + "\n", list)
    return 0


def _stamped(result: dict) -> dict:
    """`result` with its provenance (version, command, wall and CPU time)."""
    from fecheck.scene.provenance import with_provenance

    return with_provenance(result)


def _report(args: argparse.Namespace, table: str, json_text: str, plot) -> None:
    """Print the table (on stderr when the JSON goes to standard output), write the JSON
    (atomically; ``-`` = standard output) and the plots."""
    from fecheck.io.outputs import STDOUT, write_text

    to_stdout = args.json is not None and str(args.json) == STDOUT
    print(table, file=sys.stderr if to_stdout else sys.stdout)
    if args.json:
        write_text(args.json, json_text)
        if not to_stdout:
            print(f"wrote {args.json}")
    if args.plot:
        for path in plot():
            print(f"wrote {path}", file=sys.stderr if to_stdout else sys.stdout)
