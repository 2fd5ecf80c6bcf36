#!/usr/bin/env bash
# The tests: the default run (tests and doctests: what `python -m pytest` alone runs), then
# the validation study scripts' quick runs (`pytest -m validation`, left out of the default
# run for their minutes). Options go to both runs, e.g. `bash scripts/test.sh -q`; options
# that select no validation test (a test file's path) leave the second run with nothing to do.
set -euo pipefail
cd "$(dirname "$0")/.."
.venv/bin/python -m pytest "$@"
status=0
.venv/bin/python -m pytest -m validation "$@" || status=$?
[ "$status" -eq 0 ] || [ "$status" -eq 5 ] || exit "$status"   # 5: no test selected
