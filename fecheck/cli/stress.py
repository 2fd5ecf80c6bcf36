"""`fecheck stress`: the numerical-stability matrix of hard cases (see `fecheck.studies.stress`).

Only the standard library is imported here; the matrix is imported inside `run`.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path


def _seconds(text: str) -> float:
    """A positive, finite number of seconds (argparse type)."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a positive number of seconds, got {text!r}")
    return value


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "stress", help="run the numerical-stability stress matrix (each case in its own "
                       "process with a timeout)",
        description="Hard cases through the public entry points: extreme materials, loads, "
                    "starts, meshes, damaged meshes, non-finite inputs, grazing and inclined "
                    "contact. Each must converge to a finite, balanced, non-tensile answer or "
                    "stop with a clear fecheck error. Prints case, outcome, iterations, "
                    "residual (N), time (s); exit code 1 if any case ends otherwise without a "
                    "known, explained cause.")
    p.add_argument("--quick", action="store_true", help="the CI subset (< ~3 min)")
    p.add_argument("--json", type=Path, metavar="PATH",
                   help='write {"cases": [...], "summary": {...}} as JSON '
                        "('-': standard output; the table then goes to standard error)")
    p.add_argument("--timeout", type=_seconds, default=120.0, metavar="S",
                   help="seconds before a case is killed and reported as a timeout "
                        "(default 120)")
    p.add_argument("--only", metavar="TEXT", help="run only the cases whose name contains TEXT")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from fecheck.io.outputs import STDOUT, check_output

    check_output(args.json)                     # before the matrix, not after it
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from fecheck.studies import stress
    from fecheck.studies.pool import interrupts_raised

    stress.choose(args.quick, args.only)       # a selection that matches no case: error
    table = sys.stderr if args.json is not None and str(args.json) == STDOUT else sys.stdout
    print(stress.HEADER, file=table, flush=True)
    interrupted = None
    try:
        with interrupts_raised():
            results = stress.run_matrix(
                quick=args.quick, timeout_s=args.timeout, select=args.only,
                log=lambda r: print(stress.row(r), file=table, flush=True))
    except stress.StressInterrupted as stop:
        results, interrupted = stop.results, stop
    counts = stress.summary(results)
    print("outcomes: " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())), file=table)
    if args.json:
        stress.write_json(results, args.json)
        if table is sys.stdout:
            print(f"wrote {args.json}")
    if interrupted is not None:
        print(f"fecheck: interrupted: {interrupted.total - len(results)} of "
              f"{interrupted.total} cases not run", file=sys.stderr)
        return 130
    return 1 if stress.unexplained(results) else 0
