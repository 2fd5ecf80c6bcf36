"""The documentation keeps up with the code: every verb of the command line (read from its
parser, so a new verb without a page fails here) has a page in docs/verbs/ with the six
sections a user looks for, and a row in the README's table whose time is the measured one
(docs/verb_times.json, written by scripts/time_verbs.py); every scene key of the schema has
its row on the scene-keys page; the README fits a screen or two."""

from __future__ import annotations

import argparse
import json
import re
from pathlib import Path

import pytest

from fecheck.cli import build_parser
from fecheck.scene import SCHEMA

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs"
SECTIONS = ("What it answers", "Inputs", "Outputs", "Units", "Typical time",
            "Failure messages")
README_MAX_LINES = 120


def _verbs() -> list[str]:
    parser = build_parser()
    (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return sorted(sub.choices)


def _readme() -> str:
    return (REPO / "README.md").read_text(encoding="utf-8")


@pytest.mark.parametrize("verb", _verbs())
def test_every_verb_has_its_page_with_the_six_sections(verb):
    page = DOCS / "verbs" / f"{verb}.md"
    assert page.is_file(), f"fecheck {verb} has no page: write docs/verbs/{verb}.md"
    text = page.read_text(encoding="utf-8")
    assert re.search(rf"^# .*\b{verb}\b", text, re.MULTILINE), f"{page.name}: no title naming it"
    headings = re.findall(r"^## (.+?)\s*$", text, re.MULTILINE)
    missing = [s for s in SECTIONS if s not in headings]
    assert not missing, f"docs/verbs/{verb}.md lacks the sections {missing}"


def test_every_verb_page_is_a_verb():
    pages = {p.stem for p in (DOCS / "verbs").glob("*.md")}
    assert pages <= set(_verbs()), f"pages of no verb: {sorted(pages - set(_verbs()))}"


def test_every_scene_key_has_its_row_on_the_scene_keys_page():
    text = (DOCS / "scene-keys.md").read_text(encoding="utf-8")
    rows = set(re.findall(r"^\| `([^`]+)` \|", text, re.MULTILINE))
    missing = sorted(set(SCHEMA) - rows)
    assert not missing, f"scene keys without a row in docs/scene-keys.md: {missing}"


def test_the_readme_fits_a_screen_or_two():
    assert len(_readme().splitlines()) <= README_MAX_LINES


def test_every_verb_has_a_row_in_the_readme_table_with_its_measured_time():
    times = json.loads((DOCS / "verb_times.json").read_text(encoding="utf-8"))["verbs"]
    rows = dict(re.findall(r"^\| \[`([\w-]+)`\]\(docs/verbs/[\w-]+\.md\) \|.*\| ([^|]*) \|$",
                           _readme(), re.MULTILINE))
    assert set(rows) == set(_verbs()), "the README's table of verbs is not the CLI's verbs"
    for verb, shown in rows.items():
        if verb in times:
            assert shown == times[verb]["short"], (
                f"README: {verb} shows {shown!r}, measured {times[verb]['short']!r} "
                "(python scripts/time_verbs.py rewrites the table)")


def test_the_readme_names_the_build_command_and_the_two_commands():
    text = _readme()
    for command in ("bash scripts/build_docs.sh",
                    "bash scripts/setup.sh && .venv/bin/fecheck run",
                    "bash scripts/setup.sh && bash scripts/test.sh"):
        assert command in text
    assert (REPO / "scripts" / "build_docs.sh").is_file()
    # CI runs the README's test command (the default run, then `pytest -m validation`)
    assert (REPO / "scripts" / "test.sh").is_file()
    assert "\nbash scripts/test.sh" in (REPO / ".ci" / "run").read_text(encoding="utf-8")
