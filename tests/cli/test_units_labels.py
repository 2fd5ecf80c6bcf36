"""Units in names, no internal references in user-facing text, a word before the first
compile, progress that suits a log."""

from __future__ import annotations

import ast
import io
import json
import math
import re
import subprocess
import sys
from pathlib import Path

import pytest

from fecheck.cli import build_parser, main
from fecheck.laws import coldstart
from fecheck.model.menisci import pose_record
from fecheck.model.results import Pose, RunResult
from fecheck.scene.document import keys_markdown, keys_text
from fecheck.scene.packaged import description, scene_names, scene_path
from fecheck.studies.sweep import Progress

REPO = Path(__file__).resolve().parents[2]
ISSUE = re.compile(r"\bissues?\s*#?\d+|\(#\d+\)", re.IGNORECASE)


def test_per_evaluation_in_seconds_for_every_contact_model(tmp_path):
    sphere = tmp_path / "sphere.json"
    assert main(["run", "baseline", "--json", str(sphere)]) == 0
    timing = json.loads(sphere.read_text())["timing_s"]
    assert timing["per_evaluation_s"] == timing["per_evaluation"] > 0
    scanned = tmp_path / "scanned.json"
    assert main(["run", "scanned-knee", "--set", "scanned.decimate_faces=1500",
                 "--json", str(scanned)]) == 0
    timing = json.loads(scanned.read_text())["timing_s"]
    assert timing["per_evaluation_s"] == pytest.approx(1e-6 * timing["per_evaluation_us"],
                                                       rel=1e-12)


def _menisci_result(q) -> RunResult:
    menisci = {"compartments": {}, "balance_N": {"x": 0.0}, "poses": {"meniscus_medial":
                                                                      pose_record(q)}}
    return RunResult("s", "femur-tibia", "ef", True, 1, 0.0, Pose.of([0.0] * 5), {}, {},
                     {"total": 1.0, "per_evaluation_s": 1e-3, "per_evaluation_us": 1e3},
                     menisci=menisci)


def test_menisci_poses_print_degrees_with_the_unit_named():
    q = [1.0, -2.0, 3.0, math.pi / 2, 0.0, -math.pi / 4]
    record = pose_record(q)
    assert record["q"] == q                             # the solved coordinates, kept
    assert record["translation_mm"] == [1.0, -2.0, 3.0]
    assert record["rotation_deg"] == pytest.approx([90.0, 0.0, -45.0], abs=1e-12)
    table = _menisci_result(q).table()
    line = next(s for s in table.splitlines() if s.startswith("pose meniscus_medial"))
    assert "rotation deg" in line and "+90.000" in line and "-45.000" in line
    assert "rad" not in line
    time_line = next(s for s in table.splitlines() if s.startswith("time s:"))
    assert "_us" not in time_line and "per_evaluation 0.0010" in time_line


def _user_texts() -> dict[str, str]:
    """Every text a user reads: help of every verb, scene list, scene files, key docs,
    the docs pages, the validation scripts' descriptions."""
    parser = build_parser()
    texts = {"help": parser.format_help()}
    verbs = next(a for a in parser._actions if a.dest == "verb").choices
    for name, sub in verbs.items():
        texts[f"help {name}"] = sub.format_help()
    for name in scene_names():
        texts[f"scene {name}"] = scene_path(name).read_text(encoding="utf-8")
        texts[f"scene list {name}"] = description(scene_path(name))
    texts["keys"] = keys_text("") + keys_markdown("")
    for page in (REPO / "docs").glob("*.md"):
        texts[str(page)] = page.read_text(encoding="utf-8")
    for script in (REPO / "validation").glob("*.py"):      # their --help prints it
        texts[str(script)] = ast.get_docstring(ast.parse(script.read_text("utf-8"))) or ""
    return texts


def test_no_issue_number_in_user_facing_text():
    found = {where: ISSUE.findall(text) for where, text in _user_texts().items()}
    assert {k: v for k, v in found.items() if v} == {}


def test_a_cold_kernel_cache_is_detected(tmp_path):
    code = "from fecheck.laws.coldstart import kernels_cold; print(kernels_cold())"
    env = {"NUMBA_CACHE_DIR": str(tmp_path), "PYTHONPATH": str(REPO),
           "OPENBLAS_NUM_THREADS": "1", "PATH": "/usr/bin:/bin"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, timeout=120)
    assert out.stdout.strip() == "True", out.stderr


@pytest.mark.parametrize("cold", [True, False])
def test_the_first_compile_is_announced_once(monkeypatch, cold):
    monkeypatch.setattr(coldstart, "kernels_cold", lambda: cold)
    monkeypatch.setattr(coldstart, "_announced", False)
    stream = io.StringIO()
    coldstart.announce_cold_kernels(stream)
    coldstart.announce_cold_kernels(stream)
    assert stream.getvalue() == (coldstart.MESSAGE + "\n" if cold else "")


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_redraws_only_on_a_terminal():
    log = io.StringIO()
    bar = Progress(5, log, every_s=3600.0)
    for done in range(6):
        bar.show(done)
    assert "\r" not in log.getvalue()
    assert log.getvalue().splitlines() == ["sweep: 0/5 points", "sweep: 5/5 points"]
    every = io.StringIO()
    bar = Progress(3, every, every_s=0.0)
    for done in range(4):
        bar.show(done)
    assert len(every.getvalue().splitlines()) == 4
    term = _Terminal()
    bar = Progress(5, term)
    for done in range(6):
        bar.show(done)
    assert term.getvalue().count("\r") == 6 and term.getvalue().endswith("5/5\n")
