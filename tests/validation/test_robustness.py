"""The adversarial pass's verdicts (validation/robustness.py): what counts as a clean answer.
Its quick mode runs end to end in tests/validation/test_validation_scripts.py."""

from __future__ import annotations

import json

import pytest

from validation.robustness import Answer, Case, all_cases, first_line, verbs, verdict

CASE = Case(("run", "baseline"), "a test", 60.0)
JSON_CASE = Case(("run", "--json", "r.json"), "a test", 60.0, json_out=("r.json",))
ERROR = "fecheck: error: contact.poisson = 0.5 is out of range; it must be < 0.5"


def _answer(code, out="", err="", case=CASE, texts=None) -> Answer:
    return Answer(case, code, out, err, 1.0, texts or {})


@pytest.mark.parametrize("answer, clean, why", [
    (_answer(0, "scene: baseline\np_max 3.1 MPa"), True, "result"),
    (_answer(2, "", "fecheck: warning: x has no effect\n" + ERROR), True, "one-line error"),
    (_answer(2, "", "usage: fecheck run [-h]\nfecheck run: error: unrecognized arguments"),
     True, "one-line error"),
    (_answer(1, "", "Traceback (most recent call last):\nKeyError: 'lateral'"), False,
     "traceback"),
    (_answer(2, "", "Traceback (most recent call last):\n" + ERROR), False, "traceback"),
    (_answer(1, "scene: baseline", "fecheck: not converged"), False, "exit 1"),
    (_answer(None, "", ""), False, "no answer within 60 s"),
    (_answer(-9, "", ""), False, "killed by signal 9"),
    (_answer(0, "p_max nan MPa"), False, "NaN in the output"),
    (_answer(0, "tibia mesh 4,244 faces; no NaN, no degenerate face"), True, "result"),
    (_answer(0, "", "flex [1/3] -10°: medial 690 N"), True, "result"),
    (_answer(0, "", ""), False, "exit 0 in silence"),
    (_answer(2, "", ERROR + "\n" + ERROR), False, "2 error lines"),
    (_answer(2, "", "something went wrong"), False, "no error line"),
    (_answer(0, "ok", case=JSON_CASE, texts={"r.json": json.dumps({"a": 1})}), False,
     "r.json carries no provenance"),
    (_answer(0, "ok", case=JSON_CASE, texts={"r.json": '{"a": NaN, "provenance": {}}'}),
     False, "NaN in r.json"),
    (_answer(0, "ok", case=JSON_CASE), False, "r.json not written"),
    (_answer(0, "ok", case=JSON_CASE, texts={"r.json": json.dumps({"provenance": {}})}),
     True, "result"),
])
def test_verdict(answer, clean, why):
    assert verdict(answer) == (clean, why)


def test_the_answer_line_is_the_error_or_the_last_words_of_a_failure():
    assert first_line(_answer(2, "", "usage: x\n" + ERROR)) == ERROR
    assert first_line(_answer(1, "", "Traceback …\nKeyError: 'lateral'")) == "KeyError: 'lateral'"
    assert first_line(_answer(0, "scene: baseline\nmore")) == "scene: baseline"


def test_the_pass_covers_every_verb_with_enough_inputs():
    cases = all_cases()
    assert len(cases) >= 150
    assert set(verbs()) <= {c.args[0] for c in cases if c.args}
    quick = [c for c in cases if c.quick]
    assert 15 <= len(quick) <= 25
    assert len({c.args for c in cases}) == len(cases)          # no input twice
