"""CLI: the `fecheck` command line, one module per verb; the last stage, it may import all.

Each verb lives in its own module of this package and exposes
``add_parser(subparsers)`` and ``run(args) -> int``. Those modules import only the
standard library at the top, so that ``fecheck --help`` stays fast; the heavy work is
imported inside ``run``.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
import warnings

from fecheck.errors import FecheckError


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every verb module of this package."""
    parser = argparse.ArgumentParser(
        prog="fecheck",
        description="Finite-element cross-check workbench for tibio-femoral contact "
        "(units mm, N, MPa; thesis frame: x right, y anterior, z superior).",
    )
    sub = parser.add_subparsers(dest="verb", metavar="VERB")
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        module = importlib.import_module(f"fecheck.cli.{info.name}")
        module.add_parser(sub)
    return parser


_shown: set[str] = set()


def _one_line_warning(message, category, filename, lineno, file=None, line=None):
    """Print each distinct warning once, on one line (libraries may reset the filters)."""
    text = f"fecheck: warning: {message}"
    if text not in _shown:
        _shown.add(text)
        print(text, file=sys.stderr if file is None else file)


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; returns the exit code (0 success, 2 user error, 130 interrupted)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.verb is None:
        parser.print_help()
        return 0
    warnings.showwarning = _one_line_warning
    try:
        return int(args.run(args) or 0)
    except FecheckError as err:
        print(f"fecheck: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("fecheck: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
