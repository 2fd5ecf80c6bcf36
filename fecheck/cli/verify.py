"""`fecheck verify`: the code-verification suite (observed orders against exact solutions)
and, for a scene, the discretization-error estimate of its FE answer.

Only the standard library is imported here; the suite (`fecheck.studies.verify`) is
imported inside `run`.
"""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "verify", help="code verification: observed orders against exact solutions",
        description="Solve each verification case (manufactured solutions, patch tests, "
        "load scaling, EF mesh independence and invariance, Hertz, the axisymmetric layer "
        "at several Poisson's ratios, the thin-layer limit, a flat punch and a sphere on a "
        "thin layer) at 2-3 levels; print the error at the finest level, the observed order "
        "and pass/fail against the expected order and tolerance. Exit code 1 if a case "
        "fails (a known, stated limitation does not).")
    p.add_argument("--quick", action="store_true", help="cheaper levels, for CI (~1-2 min)")
    p.add_argument("--only", nargs="+", metavar="TEXT",
                   help="run only the cases whose name or group contains TEXT")
    p.add_argument("--list", action="store_true", help="list the cases and exit")
    p.add_argument("--out", type=Path, metavar="DIR",
                   help="write DIR/verify.csv, DIR/verify.png and DIR/report.md")
    p.add_argument("--json", type=Path, metavar="PATH",
                   help="write the rows as JSON ('-': standard output)")
    p.add_argument("--scene", type=Path, metavar="SCENE",
                   help="add the discretization-error estimate (GCI) of this scene's FE "
                        "answer to the report (needs --out)")
    p.add_argument("--scene-levels", type=int, nargs="+", default=[0, 1], metavar="N",
                   help="fe.refine levels of the scene estimate, 2 or 3 (default 0 1)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    import json
    import sys

    from fecheck.errors import FecheckError
    from fecheck.io.outputs import STDOUT, check_output, write_text
    from fecheck.scene.provenance import with_provenance
    from fecheck.studies import verify

    chosen = verify.select(args.only)
    if args.list:
        for c in chosen:
            print(f"{c.name:34s} {c.group:22s} {c.verifies}")
        return 0
    if args.scene is not None and args.out is None:
        raise FecheckError("--scene writes its estimate into the report: give --out DIR")
    check_output(args.json)
    check_output(args.out, directory=True)
    scene = None
    if args.scene is not None:
        from fecheck.scene import load_scene

        verify.check_levels(args.scene_levels)
        scene = load_scene(args.scene)
    table = sys.stderr if args.json is not None and str(args.json) == STDOUT else sys.stdout
    print(verify.HEADER, file=table, flush=True)
    rows = verify.run_suite(chosen, args.quick,
                            log=lambda r: print(verify.line(r), file=table, flush=True))
    counts = {s: sum(r.status == s for r in rows) for s in ("pass", "known", "FAIL")}
    print(f"{len(rows)} cases: {counts['pass']} pass, {counts['known']} known, "
          f"{counts['FAIL']} fail", file=table)
    if args.json is not None:
        data = with_provenance({"cases": [r.as_dict() for r in rows]}, scene)
        write_text(args.json, json.dumps(data, indent=1) + "\n")
    if args.out is not None:
        estimate = (verify.scene_estimate(scene, args.scene_levels, str(args.scene))
                    if scene else "")
        verify.write_csv(rows, args.out / "verify.csv")
        verify.plot(rows, args.out / "verify.png")
        write_text(args.out / "report.md", verify.report(rows, args.quick, estimate))
        print(f"wrote {args.out / 'report.md'}", file=table)
    return 1 if counts["FAIL"] else 0
