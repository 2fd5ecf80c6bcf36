"""CLI: the `fecheck` command line, one module per verb; the last stage, it may import all.

Each verb lives in its own module of this package and exposes
``add_parser(subparsers)`` and ``run(args) -> int``. Those modules import only the
standard library at the top, so that ``fecheck --help`` stays fast; the heavy work is
imported inside ``run``.
"""

from __future__ import annotations

import argparse
import importlib
import io
import os
import pkgutil
import re
import sys
import warnings

from fecheck.errors import FecheckError


def add_scene_arguments(parser: argparse.ArgumentParser, set_help: str) -> None:
    """The scene file (optional positional) and the repeatable ``--set KEY=VALUE`` of a
    verb that solves a scene; `set_help` says what an override does there."""
    from pathlib import Path

    parser.add_argument("scene", nargs="?", type=Path,
                        help="scene TOML file, or the name of a packaged scene (`fecheck "
                        "scenes` lists them; a file of that name wins); default: the "
                        "packaged baseline scene")
    parser.add_argument("--set", dest="overrides", action="append", default=[],
                        metavar="KEY=VALUE", help=set_help)


class _Version(argparse.Action):
    """``--version``: print ``fecheck X.Y.Z`` (the installed package's version) and exit."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS,
                 help="print the fecheck version and exit"):
        super().__init__(option_strings, dest, nargs=0, default=default, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"fecheck {package_version()}")
        parser.exit()


def package_version() -> str:
    """The installed version of the fecheck package (its metadata), or "unknown"."""
    from fecheck.scene.provenance import fecheck_version

    return fecheck_version()


_NEGATIVE = re.compile(r"-[\d.]")
"""A command-line word that is a negative number, range or list (-0.48,0,0 or -10:0:5)."""
_argv: list[str] = []
"""The words being parsed (for `_Parser.error`'s hint)."""


def negative_value_hint(message: str, words: list[str]) -> str:
    """A hint for argparse's "expected one argument" when the word after the option is a
    negative value (argparse reads a word starting with '-' as an option), else "".

    >>> negative_value_hint("argument --angles: expected one argument",
    ...                     ["flex", "--angles", "-10:0:5"])
    "; a value starting with '-' reads as an option: write --angles=-10:0:5"
    """
    match = re.match(r"argument (\S+): expected one argument", message)
    if not match:
        return ""
    names = match[1].split("/")
    for i, word in enumerate(words[:-1]):
        if word in names and _NEGATIVE.match(words[i + 1]):
            return (f"; a value starting with '-' reads as an option: write "
                    f"{word}={words[i + 1]}")
    return ""


class _Parser(argparse.ArgumentParser):
    """argparse's parser, its "expected one argument" error with `negative_value_hint`."""

    def error(self, message: str):
        super().error(message + negative_value_hint(message, _argv))


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every verb module of this package."""
    parser = _Parser(
        prog="fecheck",
        description="Finite-element cross-check workbench for tibio-femoral contact "
        "(units mm, N, MPa; thesis frame: x right, y anterior, z superior). "
        "`fecheck keys` lists the scene keys.",
    )
    parser.add_argument("--version", action=_Version)
    sub = parser.add_subparsers(dest="verb", metavar="VERB")
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        module = importlib.import_module(f"fecheck.cli.{info.name}")
        module.add_parser(sub)
    return parser


_shown: set[str] = set()


def one_line(text: object) -> str:
    """`text` with its line breaks turned into spaces (messages print on one line)."""
    return " ".join(str(text).split("\n"))


def _one_line_warning(message, category, filename, lineno, file=None, line=None):
    """Print each distinct warning once, on one line (libraries may reset the filters)."""
    text = f"fecheck: warning: {one_line(message)}"
    if text not in _shown:
        _shown.add(text)
        print(text, file=sys.stderr if file is None else file)


def _silence_stdout() -> None:
    """After the reader of stdout went away (``fecheck keys | head``): send the rest of
    the output, and Python's flush at exit, to /dev/null instead of a traceback."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError, io.UnsupportedOperation):
        pass


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; returns the exit code (0 success, 2 user error, 130 interrupted, 141
    output pipe closed by its reader)."""
    parser = build_parser()
    _argv[:] = sys.argv[1:] if argv is None else list(argv)
    args = parser.parse_args(argv)
    if args.verb is None:
        parser.print_help()
        return 0
    warnings.showwarning = _one_line_warning
    from fecheck.io import outputs
    from fecheck.scene.provenance import start_clock

    start_clock(sys.argv[1:] if argv is None else argv)

    outputs.forget_checked()
    try:
        return int(args.run(args) or 0)
    except FecheckError as err:
        print(f"fecheck: error: {one_line(err)}{outputs.earlier_note()}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"fecheck: interrupted{outputs.earlier_note()}", file=sys.stderr)
        return 130
    except BrokenPipeError:
        _silence_stdout()
        return 141


if __name__ == "__main__":
    sys.exit(main())
