"""`fecheck run [SCENE]`: solve one scene's equilibrium and report it.

Only the standard library is imported here; the solver is imported inside `run`, and
pyvista only with ``--plot``.
"""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "run", help="solve a scene (default: the packaged baseline) and print the result",
        description="Static equilibrium of the tibia for one scene (TOML). Prints a table; "
                    "optionally writes JSON, CSV and pressure plots.")
    p.add_argument("scene", nargs="?", type=Path,
                   help="scene TOML file (default: the packaged baseline scene)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scene key, value as a TOML literal "
                        "(e.g. --set contact.poisson=0.4 --set contact.law=hertz)")
    p.add_argument("--json", type=Path, metavar="PATH", help="write the result as JSON")
    p.add_argument("--csv", type=Path, metavar="PATH", help="write the result as a CSV row")
    p.add_argument("--plot", type=Path, metavar="DIR",
                   help="write off-screen PNGs of the face pressures (pyvista) into DIR")
    p.add_argument("--explain", action="store_true",
                   help="print the plan first (meshes built or cached, detection path per "
                        "contact pair, optional parts) and check after the run that it kept "
                        "to it")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from fecheck.model.run import run_scene
    from fecheck.scene import load_scene

    scene = load_scene(args.scene, args.overrides)
    if args.explain:
        from fecheck.model.explain import plan_scene

        plan = plan_scene(scene, plot=bool(args.plot))
        print(plan.text(), flush=True)
    result = run_scene(scene)
    print(result.table())
    if args.json:
        result.write_json(args.json)
    if args.csv:
        result.write_csv(args.csv)
    if args.plot:
        from fecheck.io.plots import write_pressure_plots

        for path in write_pressure_plots(result, args.plot):
            print(f"wrote {path}")
    if args.explain:
        deviations = plan.audit()
        print("audit: " + ("the run kept to the plan" if not deviations
                           else "; ".join(deviations)))
    return 0 if result.converged else 1
