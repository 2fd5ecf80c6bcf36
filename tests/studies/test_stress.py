"""The stress matrix: its quick subset has no unexplained outcome, and the runner turns
hangs, tracebacks, NaNs and unbalanced answers into named outcomes."""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import pytest

from fecheck.model.run import run_scene
from fecheck.scene import load_scene
from fecheck.studies import stress


def test_quick_matrix_has_no_unexplained_outcome(tmp_path):
    results = stress.run_matrix(quick=True, timeout_s=120.0)
    assert len(results) == sum(c.quick for c in stress.cases())
    bad = stress.unexplained(results)
    assert not bad, "\n".join(stress.row(r) for r in bad)
    counts = stress.summary(results)
    assert counts.get("converged", 0) >= 15 and counts.get("clear-error", 0) >= 8
    stress.write_json(results, tmp_path / "stress.json")
    doc = (tmp_path / "stress.json").read_text()
    assert '"cases"' in doc and '"time_s"' in doc


def test_known_issues_name_only_cases_of_the_matrix():
    names = {c.name for c in stress.cases()}
    assert set(stress.KNOWN) <= names


def _sleep(params):
    time.sleep(30)


def _crash(params):
    return 1 / 0


def test_a_hang_becomes_a_timeout_and_a_traceback_an_exception():
    hang = stress.run_case(stress.Case("hang", "sleep"), timeout_s=1.0, runner=_sleep)
    # liveness, not speed: a 1 s timeout ends the 30 s sleep instead of waiting for it
    assert hang.outcome == "timeout" and hang.time_s < 10
    crash = stress.run_case(stress.Case("crash", "crash"), timeout_s=30.0, runner=_crash)
    assert crash.outcome == "exception"
    assert "ZeroDivisionError" in crash.message and "test_stress.py" in crash.message


def test_an_input_that_must_be_refused_but_converges_is_inconsistent():
    case = stress.Case("baseline expecting an error", "scene", {"overrides": []},
                       expect="clear-error")
    assert stress.execute(case)["outcome"] == "inconsistent"


@pytest.fixture(scope="module")
def baseline():
    scene = load_scene()
    return scene, run_scene(scene)


def _with_medial(result, **changes):
    comps = dict(result.compartments)
    comps["medial"] = dataclasses.replace(comps["medial"], **changes)
    return dataclasses.replace(result, compartments=comps)


def test_checks_accept_the_baseline_and_name_nan_tension_and_imbalance(baseline):
    scene, result = baseline
    it, residual, message = stress.check_run(scene, result)
    assert it == result.iterations and residual < 1e-6 and "balance" in message
    med = result.compartments["medial"]
    cases = {
        "nan": _with_medial(result, max_pressure_MPa=float("nan")),
        "inconsistent": _with_medial(result, face_pressure_MPa=np.where(
            med.face_pressure_MPa > 0, -med.face_pressure_MPa, 0.0)),
    }
    for outcome, doctored in cases.items():
        with pytest.raises(stress.Inconsistent) as err:
            stress.check_run(scene, doctored)
        assert err.value.outcome == outcome
    shifted = dataclasses.replace(result.pose, q=tuple(np.add(result.pose.q, [0, 0, 0.01, 0, 0])))
    with pytest.raises(stress.Inconsistent, match="force balance"):
        stress.check_run(scene, dataclasses.replace(result, pose=shifted))
    unconverged = dataclasses.replace(result, converged=False)
    with pytest.raises(stress.Inconsistent) as err:
        stress.check_run(scene, unconverged)
    assert err.value.outcome == "diverged"
