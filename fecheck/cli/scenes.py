"""`fecheck scenes`: the scenes packaged with fecheck, by name, with a one-line
description each (the first sentence of the scene's leading comment).

Every verb that takes a scene takes one of these names in place of a path
(`fecheck run femur_tibia`). Only the standard library is imported here.
"""

from __future__ import annotations

import argparse


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "scenes", help="list the packaged scenes by name (`fecheck run NAME` runs one)",
        description="List the scenes packaged with fecheck: name and description. Verbs "
                    "that take a scene (run, fe, sweep, calibrate) take a name in place of "
                    "a path; a file of that name in the working folder wins.")
    p.add_argument("--paths", action="store_true",
                   help="print each scene's file path instead (to copy one and edit it)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from fecheck.scene.packaged import ALIASES, description, scene_names, scene_path

    names = scene_names()
    if args.paths:
        print("\n".join(str(scene_path(n)) for n in names))
        return 0
    alias = {stem: name for name, stem in ALIASES.items()}
    labels = {n: n + (f" ({alias[n]})" if n in alias else "") for n in names}
    width = max(map(len, labels.values()))
    for n in names:
        print(f"{labels[n]:<{width}}  {description(scene_path(n))}")
    return 0
