"""Interrupting a parallel sweep: one Ctrl-C (or SIGTERM) stops `fecheck sweep
--workers 2` within seconds, exit code 130, no process of its session left, and the CSV
keeps the finished points. The sweep runs as a real command in its own session."""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"),
                                reason="reads /proc to find the sweep's processes")

EXIT_WITHIN_S = 5.0
"""Liveness limit, not a benchmark: the README promises within a second; a sweep that
waited for its slow points (seconds each) or hung on a worker would take far longer."""
FIRST_ROW_WITHIN_S = 60.0
"""Generous: the first row (workers started, numba kernels loaded)."""
SLOW_VALUES = "0.8," + ",".join(f"{0.09 - 1e-4 * i:.4f}" for i in range(40))
"""One quick point (the default 0.8 mm plateau refinement) then points whose plateau
meshes take seconds each (every value a new mesh): when the quick point is written the
other worker is inside a slow one, which an interrupt must abandon, not wait for."""


def _session(sid: int) -> list[str]:
    """Processes (zombies too) whose session id is `sid`: ``"pid state"``."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        fields = stat.rsplit(")", 1)[1].split()
        if int(fields[3]) == sid:
            found.append(f"{entry.name} {fields[0]}")
    return found


def _rows(path: Path) -> list[dict[str, str]]:
    try:
        with open(path, newline="") as fh:
            return list(csv.DictReader(fh))
    except FileNotFoundError:
        return []


def _start(tmp_path: Path, param: str, values: str, workers: int
           ) -> tuple[subprocess.Popen, Path]:
    """The sweep as a command in its own session; stdout and stderr go to files (a pipe
    would also wait for any process left holding it)."""
    out = tmp_path / "sweep.csv"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1",
               FECHECK_CACHE_DIR=str(tmp_path / "cache"))
    with open(tmp_path / "stdout", "w") as stdout, open(tmp_path / "stderr", "w") as stderr:
        proc = subprocess.Popen(
            [sys.executable, "-m", "fecheck", "sweep", "--param", param,
             f"--values={values}", "--workers", str(workers), "--csv", str(out)],
            env=env, start_new_session=True, stdout=stdout, stderr=stderr)
    return proc, out


def _wait_for_first_row(proc: subprocess.Popen, out: Path) -> None:
    deadline = time.monotonic() + FIRST_ROW_WITHIN_S
    while not _rows(out):
        if proc.poll() is not None:
            pytest.fail(f"the sweep ended early (exit code {proc.returncode})")
        if time.monotonic() > deadline:
            os.killpg(proc.pid, signal.SIGKILL)
            pytest.fail("no CSV row within a minute")
        time.sleep(0.05)


def _interrupt(tmp_path: Path, param: str, values: str, signals: list[int],
               workers: int = 2) -> tuple[int, float, str, Path]:
    """Start the sweep, send `signals` (0.1 s apart) after its first row; return the exit
    code, the seconds from the first signal to the exit, stderr and the CSV path.
    Fails if a process of the sweep's session is left."""
    proc, out = _start(tmp_path, param, values, workers)
    try:
        _wait_for_first_row(proc, out)
        start = time.monotonic()
        for i, sig in enumerate(signals):
            if i:
                time.sleep(0.1)
            os.kill(proc.pid, sig)
        try:
            proc.wait(timeout=EXIT_WITHIN_S)
        except subprocess.TimeoutExpired:
            pytest.fail(f"still running {EXIT_WITHIN_S:g} s after {signals}")
        elapsed = time.monotonic() - start
        left = _session(proc.pid)
        assert not left, f"processes of the sweep left behind (pid state): {left}"
        return proc.returncode, elapsed, (tmp_path / "stderr").read_text(), out
    finally:
        if proc.poll() is None or _session(proc.pid):
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


def _assert_finished_rows(out: Path, param: str) -> None:
    rows = _rows(out)
    assert len(rows) >= 1
    for row in rows:
        assert list(row)[:2] == [param, "converged"] and "error" in row
        assert row["converged"] == "True" and row["error"] == ""
        float(row[param])
        float(row["medial_force_N"])


def test_ctrl_c_stops_a_parallel_sweep_and_keeps_the_finished_points(tmp_path):
    param = "load.point_mm[0]"
    code, elapsed, err, out = _interrupt(tmp_path, param, "0:10:400", [signal.SIGINT])
    assert code == 130, err
    assert elapsed < EXIT_WITHIN_S
    assert "points missing" in err and "Traceback" not in err
    _assert_finished_rows(out, param)
    assert len(_rows(out)) < 400


def test_sigterm_abandons_running_points_and_keeps_the_finished_ones(tmp_path):
    param = "mesh.plateau_refine_mm"
    code, elapsed, err, out = _interrupt(tmp_path, param, SLOW_VALUES, [signal.SIGTERM])
    assert code == 130, err
    assert elapsed < EXIT_WITHIN_S
    assert "40 of 41 points missing" in err and "Traceback" not in err
    _assert_finished_rows(out, param)


def test_a_second_ctrl_c_during_cleanup_does_not_hang(tmp_path):
    # the second Ctrl-C lands in the cleanup (ignored there) or, once the sweep has
    # reported, in the interpreter's exit (which then dies of SIGINT): never a hang
    param = "mesh.plateau_refine_mm"
    code, elapsed, err, out = _interrupt(tmp_path, param, SLOW_VALUES,
                                         [signal.SIGINT, signal.SIGINT])
    assert code in (130, -signal.SIGINT), err
    assert elapsed < EXIT_WITHIN_S
    assert "points missing" in err
    _assert_finished_rows(out, param)


def test_sigterm_stops_a_serial_sweep_the_same_way(tmp_path):
    # the first point's Gmsh build resets a Python SIGTERM handler at the C level; the
    # sweep re-arms it after each point
    param = "load.point_mm[0]"
    code, elapsed, err, out = _interrupt(tmp_path, param, "0:10:400", [signal.SIGTERM],
                                         workers=1)
    assert code == 130, err
    assert elapsed < EXIT_WITHIN_S
    assert "points missing" in err
    _assert_finished_rows(out, param)


def test_an_interrupt_swallowed_inside_a_kernel_is_raised_at_the_next_point():
    # numba's dispatcher swallows a KeyboardInterrupt raised while it calls back into
    # Python; the serial sweep must still stop after the point it was in
    from fecheck.studies.pool import interrupts_raised, raise_pending_interrupt

    with interrupts_raised():
        raise_pending_interrupt()                     # nothing caught yet: no raise
        try:
            signal.raise_signal(signal.SIGTERM)
        except KeyboardInterrupt:
            pass                                      # what the kernel's callback does
        with pytest.raises(KeyboardInterrupt):
            raise_pending_interrupt()
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
    try:
        raise_pending_interrupt()
    except KeyboardInterrupt:
        pytest.fail("an interrupt caught in the block outlived it")
