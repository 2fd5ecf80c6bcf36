"""`fecheck validate`: reproduce the thesis's tables and figures and write report.md.

Only the standard library is imported here; the runner (`fecheck.studies.validate`) and the row
modules (`fecheck.studies.thesis`) are imported inside `run`.
"""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "validate", help="reproduce the thesis's tables/figures; write a report",
        description="Run the validation rows (fecheck.studies.thesis) and write OUT/report.md "
        "with one CSV and one PNG per table or figure: the thesis's number, fecheck's, the "
        "deviation and why they differ.")
    p.add_argument("--quick", action="store_true",
                   help="reduced set (coarser meshes, fewer sweep points) for CI")
    p.add_argument("--only", nargs="+", metavar="NAME",
                   help="run only these rows (--list names them), e.g. --only rigid mesh")
    p.add_argument("--out", type=Path, default=Path("out/validation"),
                   help="output folder (default: out/validation)")
    p.add_argument("--list", action="store_true", help="list the rows and exit")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from fecheck.io.outputs import check_output
    from fecheck.studies.validate import discover, run_validation

    if args.list:
        for name, module in discover().items():
            print(f"{name:20s} {module}")
        return 0
    check_output(args.out, directory=True)      # before the rows run, not after
    _, rows = run_validation(args.out, quick=args.quick, only=args.only)
    failed = [r.name for r in rows if r.status.startswith("failed")]
    return 1 if failed else 0
