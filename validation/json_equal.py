"""Compare two JSON result trees number by number: a tool for refactors.

Two modes:

- ``python -m validation.json_equal dump OUTDIR`` runs ``fecheck run --json`` on every
  packaged scene with this interpreter (the code on ``PYTHONPATH`` decides which checkout
  runs) and writes ``OUTDIR/<scene>.json``;
- ``python -m validation.json_equal compare REF NEW [--tol 1e-8]`` compares every JSON file
  of REF with the file of the same name in NEW and prints one line per file (exit 1 when
  any differs).

Numbers agree when ``|a - b| <= tol * max(1, |a|, |b|)`` (relative above 1, absolute
below); strings, booleans and nulls must be equal; a key present on one side only is a
difference, except keys added in NEW when ``--allow-added`` is given. Timing fields (a key
containing ``time``, ``seconds`` or ending in ``_s``) are ignored.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

TIMING = re.compile(r"(time|seconds|elapsed|wall|_s$)", re.IGNORECASE)
"""Key names that hold a measured duration: never compared."""


def differences(ref: Any, new: Any, tol: float = 1e-8, allow_added: bool = False,
                path: str = "$") -> list[str]:
    """Every place where two JSON trees differ.

    Parameters
    ----------
    ref, new : the decoded JSON values (dicts, lists, numbers, strings, booleans, None).
    tol : relative tolerance on numbers (absolute below magnitude 1).
    allow_added : keys present only in `new` are not differences.
    path : the JSON path of `ref` (used in the messages).

    Returns
    -------
    One line per difference: the JSON path and the two values.
    """
    if isinstance(ref, bool) or isinstance(new, bool) or ref is None or new is None:
        return [] if ref is new or ref == new and type(ref) is type(new) else \
            [f"{path}: {ref!r} != {new!r}"]
    if isinstance(ref, (int, float)) and isinstance(new, (int, float)):
        return [] if _close(float(ref), float(new), tol) else [f"{path}: {ref!r} != {new!r}"]
    if isinstance(ref, dict) and isinstance(new, dict):
        return _dict_differences(ref, new, tol, allow_added, path)
    if isinstance(ref, list) and isinstance(new, list):
        if len(ref) != len(new):
            return [f"{path}: length {len(ref)} != {len(new)}"]
        return [d for i, (a, b) in enumerate(zip(ref, new, strict=True))
                for d in differences(a, b, tol, allow_added, f"{path}[{i}]")]
    return [] if ref == new and type(ref) is type(new) else [f"{path}: {ref!r} != {new!r}"]


def _dict_differences(ref: dict, new: dict, tol: float, allow_added: bool,
                      path: str) -> list[str]:
    out = [f"{path}.{k}: missing in the new tree" for k in ref
           if k not in new and not TIMING.search(k)]
    if not allow_added:
        out += [f"{path}.{k}: only in the new tree" for k in new
                if k not in ref and not TIMING.search(k)]
    for key in ref:
        if key in new and not TIMING.search(key):
            out += differences(ref[key], new[key], tol, allow_added, f"{path}.{key}")
    return out


def _close(a: float, b: float, tol: float) -> bool:
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    if math.isinf(a) or math.isinf(b):
        return a == b
    return abs(a - b) <= tol * max(1.0, abs(a), abs(b))


def _scene_names() -> list[str]:
    out = subprocess.run([sys.executable, "-m", "fecheck", "scenes"], check=True,
                         capture_output=True, text=True).stdout
    return [line.split()[0] for line in out.splitlines() if line.strip()]


def dump(outdir: Path, scenes: list[str] | None = None) -> None:
    """Write ``outdir/<scene>.json`` from ``fecheck run --json`` of each packaged scene."""
    outdir.mkdir(parents=True, exist_ok=True)
    for name in scenes or _scene_names():
        target = outdir / f"{name}.json"
        proc = subprocess.run([sys.executable, "-m", "fecheck", "run", name, "--json",
                               str(target)], capture_output=True, text=True,
                              env=os.environ.copy())
        status = "ok" if proc.returncode == 0 else f"exit {proc.returncode}"
        print(f"{name:28s} {status}", flush=True)
        if proc.returncode:
            (outdir / f"{name}.err").write_text(proc.stderr, encoding="utf-8")


def compare(ref_dir: Path, new_dir: Path, tol: float, allow_added: bool) -> int:
    """Print one line per JSON file of `ref_dir`; the number of files that differ."""
    bad = 0
    for ref in sorted(ref_dir.glob("*.json")):
        new = new_dir / ref.name
        if not new.exists():
            print(f"{ref.stem:28s} MISSING in {new_dir}")
            bad += 1
            continue
        diffs = differences(json.loads(ref.read_text()), json.loads(new.read_text()), tol,
                            allow_added)
        print(f"{ref.stem:28s} {'equal' if not diffs else f'{len(diffs)} differences'}")
        for d in diffs[:20]:
            print(f"    {d}")
        bad += bool(diffs)
    return bad


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="verb", required=True)
    d = sub.add_parser("dump", help="run every packaged scene, write OUTDIR/<scene>.json")
    d.add_argument("outdir", type=Path)
    d.add_argument("--scene", action="append", help="only these scenes (repeatable)")
    c = sub.add_parser("compare", help="compare REF/*.json with NEW/*.json")
    c.add_argument("ref", type=Path)
    c.add_argument("new", type=Path)
    c.add_argument("--tol", type=float, default=1e-8)
    c.add_argument("--allow-added", action="store_true")
    args = parser.parse_args(argv)
    if args.verb == "dump":
        dump(args.outdir, args.scene)
        return 0
    return 1 if compare(args.ref, args.new, args.tol, args.allow_added) else 0


if __name__ == "__main__":
    sys.exit(main())
