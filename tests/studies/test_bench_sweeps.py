"""`fecheck bench sweeps` reduced to 20 baseline points (and 5 femur-tibia points when
the scanned knee data set is there): the JSON schema, every point converged, the counting
(equilibria per second = points / wall time) and the CLI wiring. Times are only checked
to be positive and to fit in the time the run took."""

from __future__ import annotations

import json
import math
import time

import pytest

from fecheck.cli import main
from fecheck.scene import load_scene, with_values
from fecheck.studies import bench_sweeps

SIZES = {"baseline": 20, "femur_tibia": 5}
CASE_KEYS = {"scene", "points", "mode", "values_mm", "converged", "wall_s",
             "equilibria_per_s", "median_point_ms", "single_solve_ms", "start_s"}
MODES = ["serial", "2 workers"]


@pytest.fixture(scope="module")
def timed():
    """The reduced run as the CLI writes it, and the wall time it took (s)."""
    start = time.perf_counter()
    result = bench_sweeps.run(sizes=(SIZES["baseline"], SIZES["femur_tibia"]))
    return json.loads(json.dumps(result)), time.perf_counter() - start


def test_schema_and_every_scene_run_or_skipped(timed):
    result, _ = timed
    assert {"cases", "speedup", "skipped", "quick", "machine"} <= set(result)
    assert "cpus" in result["machine"]
    for case in result["cases"]:
        assert set(case) == CASE_KEYS
    assert "femur_tibia" not in result["skipped"] or "not found" in result["skipped"][
        "femur_tibia"]
    expected = [s for s in SIZES if s not in result["skipped"]]
    assert [(c["scene"], c["mode"]) for c in result["cases"]] == [
        (s, m) for s in expected for m in MODES]
    assert set(result["speedup"]) == set(expected)


def test_every_point_counted_and_converged(timed):
    result, _ = timed
    for case in result["cases"]:
        assert case["points"] == SIZES[case["scene"]]
        assert case["converged"] == case["points"]


def test_equilibria_per_second_is_points_over_wall_time(timed):
    result, elapsed = timed
    for case in result["cases"]:
        assert case["equilibria_per_s"] == pytest.approx(case["points"] / case["wall_s"],
                                                         rel=1e-12)
        for key in ("median_point_ms", "single_solve_ms"):
            assert math.isfinite(case[key]) and case[key] > 0
        assert (case["start_s"] is None) == (case["mode"] == "serial")
        assert case["mode"] == "serial" or case["start_s"] > 0
    # bookkeeping, not speed: the cases' times are parts of the run the test timed
    assert 0 < sum(c["wall_s"] + (c["start_s"] or 0) for c in result["cases"]) < elapsed
    for scene, speedup in result["speedup"].items():
        wall = {c["mode"]: c["wall_s"] for c in result["cases"] if c["scene"] == scene}
        assert speedup == pytest.approx(wall["serial"] / wall["2 workers"])


def test_values_span_the_reference_load_point(timed):
    result, _ = timed
    x0 = load_scene(None)["load.point_mm"][0]
    for case in (c for c in result["cases"] if c["scene"] == "baseline"):
        assert case["values_mm"] == pytest.approx([x0 - 8.0, x0 + 8.0])


def test_missing_data_names_the_absent_file():
    scene = load_scene(None)
    assert bench_sweeps.missing_data(scene) == ""
    scanned = with_values(scene, model__kind="femur-tibia", geometry__dir="/nonexistent",
                          geometry__femur="femur.stl", geometry__tibia="tibia.stl")
    assert "/nonexistent/femur.stl" in bench_sweeps.missing_data(scanned)


def test_cli_prints_the_table_and_writes_the_json(timed, tmp_path, monkeypatch, capsys):
    result, _ = timed
    monkeypatch.setattr(bench_sweeps, "run", lambda quick, progress: result)
    out = tmp_path / "sweeps.json"
    assert main(["bench", "sweeps", "--quick", "--json", str(out)]) == 0
    written = json.loads(out.read_text())
    assert written.pop("provenance")["command"] == ["fecheck", "bench", "sweeps", "--quick",
                                                    "--json", str(out)]
    assert written == result
    text = capsys.readouterr().out
    assert "baseline    serial" in text and "points not converged: none" in text
