"""`validation.json_equal.differences`: two JSON trees compared number by number."""

from __future__ import annotations

import pytest

from validation.json_equal import differences

REF = {"force_N": 324.2037009935172, "pose": {"z_mm": 0.98312813, "x_mm": 0.0},
       "converged": True, "notes": ["a", "b"], "timing_s": {"total": 3.1},
       "forces": [1.0, -2.5e-3]}


def test_a_tree_equals_itself_and_a_copy_within_the_tolerance():
    near = {**REF, "force_N": REF["force_N"] * (1 + 5e-9), "forces": [1.0 + 5e-9, -2.5e-3],
            "pose": {"z_mm": 0.98312813, "x_mm": 5e-9}}          # absolute about zero
    assert differences(REF, REF) == []
    assert differences(REF, near, tol=1e-8) == []


@pytest.mark.parametrize("change, where", [
    ({"force_N": 324.2037009935172 * (1 + 2e-8)}, "$.force_N"),      # relative above 1
    ({"forces": [1.0, -2.5e-3 + 2e-8]}, "$.forces[1]"),              # absolute below 1
    ({"pose": {"z_mm": 0.98312813}}, "$.pose.x_mm: missing"),
    ({"converged": 1}, "$.converged"),                               # a bool is not a number
    ({"notes": ["a"]}, "$.notes: length"),
    ({"notes": ["a", "c"]}, "$.notes[1]"),
    ({"extra": 1.0}, "$.extra: only in the new tree"),
])
def test_each_kind_of_difference_is_reported_with_its_path(change, where):
    diffs = differences(REF, {**REF, **change}, tol=1e-8)
    assert len(diffs) == 1 and diffs[0].startswith(where), diffs


def test_timing_fields_are_ignored_and_added_keys_may_be_allowed():
    new = {**REF, "timing_s": {"total": 9.9, "solve": 1.0}, "extra": 2}
    assert differences(REF, new, allow_added=True) == []
    assert differences(REF, {k: v for k, v in REF.items() if k != "timing_s"}) == []


def test_nan_equals_only_nan():
    assert differences({"a": float("nan")}, {"a": float("nan")}) == []
    assert differences({"a": float("nan")}, {"a": 0.0}) != []
