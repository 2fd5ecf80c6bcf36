"""The typed run result: the solved pose (`Pose`) and the Newton solve's record
(`SolveRecord`), and the run JSON they are written as."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from fecheck.model.results import POSE_KEYS, Pose, RunResult, SolveRecord


def test_pose_reads_coordinates_and_angles_in_both_units():
    pose = Pose.of(np.array([1.5, -2.0, 3.25, math.pi / 6, -math.pi / 4]), math.pi / 2)
    assert (pose.x_mm, pose.y_mm, pose.z_mm) == (1.5, -2.0, 3.25)
    assert pose.abduction_rad == math.pi / 6 and pose.internal_rad == -math.pi / 4
    assert pose.abduction_deg == pytest.approx(30.0, abs=1e-12)
    assert pose.internal_deg == pytest.approx(-45.0, abs=1e-12)
    assert pose.flexion_deg == pytest.approx(90.0, abs=1e-12)
    assert pose.body == "tibia" and isinstance(pose.q, tuple)
    assert list(pose) == list(POSE_KEYS) and len(pose) == 7
    assert dict(pose) == pytest.approx({"x_mm": 1.5, "y_mm": -2.0, "z_mm": 3.25,
                                        "abduction_deg": 30.0, "internal_deg": -45.0,
                                        "adduction_deg": 30.0,          # right knee: +θy
                                        "internal_rotation_deg": -45.0})
    with pytest.raises(KeyError):
        pose["flexion_deg"]
    with pytest.raises(dataclasses.FrozenInstanceError):
        pose.q = (0.0,) * 5


def _result(record: SolveRecord | None) -> RunResult:
    return RunResult("s", "sphere-plane", "ef", True, 3, 1e-9,
                     Pose.of([0.5, 0.0, -1.0, 0.0, 0.25]), {}, {}, {"total": 1.0},
                     record=record)


def test_run_json_extra_keeps_its_keys_in_order_with_the_pose_q():
    record = SolveRecord(7, {"medial": 20}, {"medial": "closed form"}, (10.0, float("nan")),
                         equal_forces_multiplier=-2.5,
                         wrench_N={"contact": np.arange(6.0)})
    extra = _result(record).as_dict()["extra"]
    assert list(extra) == ["evaluations", "contact_faces", "detection", "residual_history",
                           "equal_forces_multiplier", "q", "wrench_N"]
    assert extra["q"] == [0.5, 0.0, -1.0, 0.0, 0.25]
    assert extra["residual_history"] == [10.0, None]           # NaN written as null
    assert extra["wrench_N"] == {"contact": [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]}
    plain = _result(SolveRecord(7, {}, {}, ())).as_dict()["extra"]
    assert list(plain) == ["evaluations", "contact_faces", "detection", "residual_history", "q"]
    rigid = _result(None)
    assert rigid.as_dict()["extra"] == {} and rigid.poses == {"tibia": rigid.pose}
    assert rigid.as_dict()["pose"]["internal_deg"] == pytest.approx(math.degrees(0.25))
