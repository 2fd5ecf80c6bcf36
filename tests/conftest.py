"""Shared test fixtures and paths.

A test asserts on wall-clock time only as a generous liveness limit (a signal stops a
command within seconds, a subprocess timeout). Speed claims (X faster than Y, a slope of
time against faces) are marked ``@pytest.mark.bench``: the default run leaves them out
(pyproject's ``-m 'not bench'``), ``python -m pytest -m bench`` runs them on a quiet
machine, and the functional part of such a check stays an unmarked test.

The tests mirror the packages (tests/geometry, tests/scene, ..., tests/cli); the shared
helpers (`contact_helpers`) sit here, beside this file, and a test imports a helper or
another test module by its bare name: every folder of tests is on ``sys.path``.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
TESTS = Path(__file__).resolve().parent
sys.path[:0] = [str(TESTS), *(str(d) for d in sorted(TESTS.iterdir())
                              if d.is_dir() and not d.name.startswith(("_", ".")))]
SHARED_DATA = Path(os.environ.get("FECHECK_SHARED_DATA", REPO.parent / "shared" / "data"))
"""The data sets beside the repository: the source the package data are built from."""
KNEE_DIR = Path(os.environ.get("FECHECK_KNEE_DIR",
                               REPO / "fecheck" / "data" / "knee" / "lenhart2015"))
"""The scanned knee the tests read: the one packaged with fecheck, or $FECHECK_KNEE_DIR."""
os.environ.setdefault("FECHECK_KNEE_DIR", str(KNEE_DIR))


@pytest.fixture(autouse=True)
def _isolated_cache(tmp_path_factory, monkeypatch):
    """Every test session writes meshes to its own cache folder, never the user's."""
    monkeypatch.setenv("FECHECK_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "cache"))


def require_knee_data() -> Path:
    """The scanned-knee folder, or skip the test with a clear message."""
    if not KNEE_DIR.is_dir():
        pytest.skip(f"scanned knee data not found at {KNEE_DIR} (set FECHECK_KNEE_DIR)")
    return KNEE_DIR
