"""`fecheck keys [PREFIX]`: every scene key with its kind, unit, default, allowed values and
documentation, generated from the scene schema.

Only the standard library is imported here; the schema inside `run`.
"""

from __future__ import annotations

import argparse

FORMATS = ("text", "toml", "markdown")


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "keys", help="list the scene keys (kind, unit, default, allowed values, documentation)",
        description="List every scene key from the scene schema. 'text' (the default): one "
                    "entry per key; 'toml': a complete documented scene with every key at "
                    "its default (the packaged baseline scene, a starting point for your "
                    "own); 'markdown': tables per section (docs/scene-keys.md).")
    p.add_argument("prefix", nargs="?", default="", metavar="PREFIX",
                   help="only the keys starting with PREFIX, e.g. contact or ligaments.ACL")
    p.add_argument("--format", choices=FORMATS, default="text",
                   help="output format (default: text)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from fecheck.scene.document import baseline_document, keys_markdown, keys_text

    render = {"text": keys_text, "toml": baseline_document, "markdown": keys_markdown}
    print(render[args.format](args.prefix), end="" if args.format != "text" else "\n")
    return 0
