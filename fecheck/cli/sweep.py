"""`fecheck sweep [SCENE] --param KEY --values A:B:N`: one scene over a range of one key.

Only the standard library is imported here; the solver inside `run`.

Exit codes: 0 every point converged, 1 a point failed or did not converge, 2 a user
error before the first solve, 130 interrupted (Ctrl-C or SIGTERM: the finished points
are kept in the CSV and stderr says how many are missing).
"""

from __future__ import annotations

import argparse
import contextlib
import math
import sys
import time
from pathlib import Path
from typing import Any, TextIO

from fecheck.cli import add_scene_arguments

_TABLE_COLUMNS = ("converged", "medial_force_N", "lateral_force_N",
                  "medial_max_pressure_MPa", "lateral_max_pressure_MPa")
_WIDTH = 24

CHECKPOINT_S = 1.0
"""While a sweep runs, its CSV is rewritten after a finished point once this long has
passed since the last write (s), or ten times that write's duration if longer: a killed
sweep loses at most that much work, and rewriting the growing file stays a small part of
the run (after every point, a 1,000-point sweep took 7x as long). The first point is
written at once, and the report writes every finished point at the end."""


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "sweep", help="solve a scene for a range of values of one key",
        description="Sweep one numeric scene key (or one component, KEY[i]) and tabulate "
                    "the compartment forces and pressures. Serial sweeps warm-start each "
                    "point from the previous one; --workers/--scheduler run points in "
                    "parallel. A failing point is recorded in its row and the sweep goes "
                    "on (exit code 1); Ctrl-C keeps the finished points (exit code 130). "
                    "Example: fecheck sweep --param 'load.point_mm[0]' "
                    "--values=-0.1:15.9:17 (write --values=A:B:N when A is negative)")
    add_scene_arguments(p, "override a scene key for every point (TOML literal)")
    p.add_argument("--param", required=True, metavar="KEY",
                   help="scene key to sweep, e.g. contact.youngs_MPa or load.point_mm[0]")
    p.add_argument("--values", required=True, metavar="A:B:N",
                   help="N values from A to B, or a comma list")
    p.add_argument("--csv", metavar="PATH",
                   help="write one CSV row per finished point, kept up to date while the sweep "
                        "runs (rewritten at most about once a second) "
                        "('-': standard output at the end, the table then goes to stderr)")
    p.add_argument("--plot", type=Path, metavar="DIR",
                   help="write PNG plots of forces and max pressures against the value")
    p.add_argument("--workers", type=int, default=1, metavar="N",
                   help="run points in N local processes (default 1: serial, warm-started)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run points on a Dask distributed scheduler (needs fecheck[dask])")
    p.add_argument("--fail-fast", action="store_true",
                   help="stop at the first failing point (the finished rows are still "
                        "written)")
    p.set_defaults(run=run)


def _cell(value: Any) -> str:
    """One right-aligned table cell: numbers to 6 digits, None as '-'."""
    if isinstance(value, float):
        return f"{value:{_WIDTH}.6g}"
    return f"{'-' if value is None else value!s:>{_WIDTH}.{_WIDTH}s}"


def _print_table(table: list[dict[str, Any]], param: str, stream: TextIO) -> None:
    """The sweep's main columns, one line per finished point; failed points show their
    error instead of the forces."""
    print("  ".join(f"{c:>{_WIDTH}s}" for c in (param, *_TABLE_COLUMNS)), file=stream)
    for row in table:
        if row["error"]:
            cells = [_cell(row[param]), _cell(False), f"error: {row['error']}"]
        else:
            cells = [_cell(row[c]) for c in (param, *_TABLE_COLUMNS)]
        print("  ".join(cells), file=stream)


def _summary(points: list, total: int, param: str, interrupted: bool) -> list[str]:
    """Lines for stderr: missing points, failed points, points that did not converge."""
    lines = []
    failed = [p for p in points if p.failed]
    stalled = [p for p in points if not p.failed and not p.converged]
    if interrupted:
        lines.append(f"interrupted: {total - len(points)} of {total} points missing "
                     f"({len(points)} finished)")
    elif failed and len(points) < total:
        lines.append(f"stopped at {param} = {failed[0].value:g} (--fail-fast): "
                     f"{failed[0].error}; {total - len(points)} of {total} points not run")
    if failed:
        lines.append(f"{len(failed)} of {total} points failed: {param} = "
                     + ", ".join(f"{p.value:g}" for p in failed))
    if stalled:
        lines.append(f"{len(stalled)} of {total} points did not converge: {param} = "
                     + ", ".join(f"{p.value:g}" for p in stalled))
    return lines


def _report(args: argparse.Namespace, points: list, total: int, interrupted: bool) -> int:
    """Write the CSV and plots, print the table and summary; return the exit code."""
    from fecheck.studies.sweep import rows, write_csv, write_plots

    stream = sys.stderr if args.csv == "-" else sys.stdout
    _print_table(rows(points, args.param), args.param, stream)
    if args.csv:
        write_csv(points, args.param, args.csv)
    if args.plot:
        paths = write_plots(points, args.param, args.plot)
        for path in paths:
            print(f"wrote {path}", file=stream)
        if not paths:
            print("fecheck: no point was solved: no plots", file=sys.stderr)
    for line in _summary(points, total, args.param, interrupted):
        print(f"fecheck: {line}", file=sys.stderr)
    if interrupted:
        return 130
    return 0 if len(points) == total and all(p.converged for p in points) else 1


class _Checkpoint:
    """`run_sweep`'s ``on_point``: rewrites the CSV at the pace of `CHECKPOINT_S` (not
    standard output, a FIFO or a device: written once, at the end)."""

    def __init__(self, path: str | None, param: str):
        from fecheck.io.outputs import writes_in_place

        self.path = None if not path or path == "-" or writes_in_place(path) else path
        self.param = param
        self.written_at, self.took = -math.inf, 0.0

    def __call__(self, points) -> None:
        from fecheck.studies.sweep import write_csv

        if self.path is None:
            return
        start = time.monotonic()
        if start - self.written_at < max(CHECKPOINT_S, 10.0 * self.took):
            return
        write_csv(points, self.param, self.path)
        self.written_at = time.monotonic()
        self.took = self.written_at - start


def run(args: argparse.Namespace) -> int:
    """Check every value and output path, run the sweep (SIGTERM stops it like Ctrl-C),
    report; the CSV is kept up to date while it runs (`CHECKPOINT_S`)."""
    from fecheck.errors import FecheckError
    from fecheck.io.outputs import check_output
    from fecheck.scene import load_scene
    from fecheck.studies.pool import interrupts_raised
    from fecheck.studies.sweep import (
        SweepInterrupted,
        dask_executor,
        interrupts_ignored,
        parse_values,
        run_sweep,
        sweep_overrides,
    )

    if args.workers < 1:
        raise FecheckError("--workers must be at least 1")
    values = parse_values(args.values)
    scene = load_scene(args.scene, args.overrides)
    sweep_overrides(scene, args.param, values)
    check_output(args.csv)
    check_output(args.plot, directory=True)

    executor = (dask_executor(args.scheduler) if args.scheduler
                else contextlib.nullcontext(None))
    try:
        with interrupts_raised(), executor as pool:
            points = run_sweep(scene, args.param, values, workers=args.workers,
                               executor=pool, fail_fast=args.fail_fast,
                               on_point=_Checkpoint(args.csv, args.param))
    except SweepInterrupted as stop:
        with interrupts_ignored():
            return _report(args, stop.points, len(values), interrupted=True)
    return _report(args, points, len(values), interrupted=False)
