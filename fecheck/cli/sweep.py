"""`fecheck sweep [SCENE] --param KEY --values A:B:N`: one scene over a range of one key.

Only the standard library is imported here; the solver inside `run`.
"""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "sweep", help="solve a scene for a range of values of one key",
        description="Sweep one numeric scene key (or one component, KEY[i]) and tabulate "
                    "the compartment forces and pressures. Serial sweeps warm-start each "
                    "point from the previous one; --workers/--scheduler run points in "
                    "parallel. Example: fecheck sweep --param 'load.point_mm[0]' "
                    "--values=-0.1:15.9:17 (write --values=A:B:N when A is negative)")
    p.add_argument("scene", nargs="?", type=Path,
                   help="scene TOML file (default: the packaged baseline scene)")
    p.add_argument("--param", required=True, metavar="KEY",
                   help="scene key to sweep, e.g. contact.youngs_MPa or load.point_mm[0]")
    p.add_argument("--values", required=True, metavar="A:B:N",
                   help="N values from A to B, or a comma list")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scene key for every point (TOML literal)")
    p.add_argument("--csv", type=Path, metavar="PATH", help="write one CSV row per value")
    p.add_argument("--plot", type=Path, metavar="DIR",
                   help="write PNG plots of forces and max pressures against the value")
    p.add_argument("--workers", type=int, default=1, metavar="N",
                   help="run points in N local processes (default 1: serial, warm-started)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run points on a Dask distributed scheduler (needs fecheck[dask])")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from fecheck.errors import FecheckError
    from fecheck.scene import load_scene
    from fecheck.studies.sweep import (
        dask_executor,
        parse_values,
        rows,
        run_sweep,
        write_csv,
        write_plots,
    )

    if args.workers < 1:
        raise FecheckError("--workers must be at least 1")
    values = parse_values(args.values)
    scene = load_scene(args.scene, args.overrides)
    executor = dask_executor(args.scheduler) if args.scheduler else None
    points = run_sweep(scene, args.param, values, workers=args.workers, executor=executor)
    table = rows(points, args.param)
    cols = [args.param, "converged", "medial_force_N", "lateral_force_N",
            "medial_max_pressure_MPa", "lateral_max_pressure_MPa"]
    print("  ".join(f"{c:>24s}" for c in cols))
    for row in table:
        print("  ".join(f"{'-' if row[c] is None else row[c]!s:>24.24s}"
                        if not isinstance(row[c], float) else f"{row[c]:24.6g}" for c in cols))
    if args.csv:
        write_csv(points, args.param, args.csv)
    if args.plot:
        for path in write_plots(points, args.param, args.plot):
            print(f"wrote {path}")
    return 0 if all(p.result.converged for p in points) else 1
