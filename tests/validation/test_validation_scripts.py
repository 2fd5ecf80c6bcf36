"""Every validation script runs to the end in its ``--quick`` mode.

The scripts are found by globbing ``validation/*.py``, so a new one is run without
editing this file; each runs as a file (``python validation/x.py``) in a subprocess from a
temporary folder, with its output options (``--out``, ``--json``, ``--plot``, as its
``--help`` lists them) pointed there, and answers ``--help`` as a module of the package
(``python -m validation.x`` from the repository root: all of them in one subprocess, each
run by `runpy` as ``-m`` runs it).

The quick runs (minutes in all: each script is a study) are marked ``validation``: the
default run leaves them out, ``bash scripts/test.sh`` (the README's test command, which CI
runs) runs them after it, by ``python -m pytest -m validation``.

The row scripts (``validation/row_*.py``, which run the rows of `fecheck.studies.thesis`)
are the exception: CI's ``fecheck validate --quick`` runs every one of them in its quick
mode and fails on a failed row, as their ``main_for`` does, so here one of them runs as a
file (the command line they share; marked ``validation`` too) and the others only answer
``--help``.
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

VALIDATION = Path(__file__).resolve().parents[2] / "validation"
NOT_SCRIPTS = {
    "json_equal.py": "a refactoring tool comparing two folders of JSON (test_json_equal.py)",
    "__init__.py": "the package file (the scripts import one another as validation.x)",
    "passive_reference.py": "the source model's two published passive-flexion runs read as "
                            "reference curves, for flex_passive.py",
}
SCRIPTS = sorted(p for p in VALIDATION.glob("*.py") if p.name not in NOT_SCRIPTS)
ROWS = "row_"
"""Prefix of the row scripts that ``fecheck validate --quick`` runs (`fecheck.studies.validate`)."""
STUDIES = [p for p in SCRIPTS if not p.name.startswith(ROWS)]
NEEDS = {"population_dask.py": ("distributed", "pip install 'fecheck[dask]'")}
"""Scripts that need an optional library: (module, how to install it)."""
OUTPUT_OPTIONS = {"--out": ".", "--json": "result.json", "--plot": "."}
TIMEOUT_S = 600


def _run(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1",
               MKL_NUM_THREADS="1", MPLBACKEND="Agg")
    return subprocess.run([sys.executable, *args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=TIMEOUT_S)


def output_args(script: Path, out: Path) -> list[str]:
    """The output options that `script --help` lists, each pointed into `out`."""
    usage = _run([str(script), "--help"], out)
    assert usage.returncode == 0, usage.stderr
    args = []
    for option, name in OUTPUT_OPTIONS.items():
        if re.search(rf"{option}\b", usage.stdout):
            args += [option, str(out / name)]
    return args


def test_the_files_left_out_are_there():
    assert {p.name for p in VALIDATION.glob("*.py")} >= set(NOT_SCRIPTS)


AS_MODULES = """\
import contextlib, io, json, runpy, sys, traceback
answers = {}
for name in sys.argv[1:]:
    sys.argv = ["-m", "--help"]
    out, err, code = io.StringIO(), io.StringIO(), 0
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            runpy.run_module("validation." + name, run_name="__main__", alter_sys=True)
        except SystemExit as stop:
            code = stop.code if isinstance(stop.code, int) else 1
        except BaseException:
            traceback.print_exc()
            code = 1
    answers[name] = [code, out.getvalue(), err.getvalue()]
print(json.dumps(answers))
"""
"""Runs ``validation.<name> --help`` for each name of its arguments as ``python -m`` does
(`runpy.run_module` as ``__main__``, the repository root first on sys.path) and prints
{name: [exit status, stdout, stderr]} as JSON."""


@pytest.fixture(scope="module")
def help_as_modules() -> dict[str, list]:
    """Each script's answer to ``--help`` run as a module of the package, from one process."""
    done = _run(["-c", AS_MODULES, *(p.stem for p in SCRIPTS)], VALIDATION.parent)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.splitlines()[-1])


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.stem)
def test_runs_as_a_module_of_the_package(script, help_as_modules):
    # `python -m validation.x` from the repository root finds the same script and its siblings
    code, out, err = help_as_modules[script.stem]
    assert code == 0, err[-3000:]
    assert "usage:" in out


@pytest.mark.validation
@pytest.mark.parametrize("script", STUDIES, ids=lambda p: p.stem)
def test_quick_mode_runs_to_the_end(script, tmp_path):
    module, install = NEEDS.get(script.name, (None, ""))
    if module is not None and importlib.util.find_spec(module) is None:
        pytest.skip(f"{script.name} needs {module}: {install}")
    done = _run([str(script), "--quick", *output_args(script, tmp_path)], tmp_path)
    assert done.returncode == 0, f"{script.name}: exit {done.returncode}\n{done.stderr[-3000:]}"
    assert "Traceback" not in done.stderr, done.stderr[-3000:]


def test_the_row_scripts_are_the_ones_fecheck_validate_runs():
    from fecheck.studies.validate import SCRIPT_PREFIX, discover

    assert SCRIPT_PREFIX == ROWS
    rows = {p.stem for p in SCRIPTS if p.name.startswith(ROWS)}
    assert rows and {ROWS + name for name in discover()} == rows


@pytest.mark.validation
def test_a_row_script_runs_as_a_file_in_its_quick_mode(tmp_path):
    # the command line every row script shares (`report.main_for`): rows printed
    done = _run([str(VALIDATION / "row_rigid.py"), "--quick", "--out", str(tmp_path)],
                tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "### Table 5.1: rigid model force distribution" in done.stdout
    assert (tmp_path / "table_5_1.csv").is_file()
