"""Interrupting the stress matrix: one Ctrl-C (or SIGTERM) stops `fecheck stress` within
seconds, exit code 130, its case process and fork server gone, and the JSON keeps the
finished cases. The matrix runs as a real command in its own session."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest
from test_sweep_interrupt import EXIT_WITHIN_S, _session

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"),
                                reason="reads /proc to find the matrix's processes")


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_one_signal_stops_the_matrix_and_keeps_the_finished_cases(tmp_path, sig):
    out = tmp_path / "stress.json"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    with open(tmp_path / "stdout", "w") as stdout, open(tmp_path / "stderr", "w") as stderr:
        proc = subprocess.Popen([sys.executable, "-m", "fecheck", "stress", "--quick",
                                 "--json", str(out)], env=env, start_new_session=True,
                                stdout=stdout, stderr=stderr)
    try:
        deadline = time.monotonic() + 120.0
        while (tmp_path / "stdout").read_text().count("\n") < 3:     # header + two cases
            assert proc.poll() is None, "the matrix ended early"
            assert time.monotonic() < deadline, "no case finished within two minutes"
            time.sleep(0.05)
        start = time.monotonic()
        os.kill(proc.pid, sig)
        proc.wait(timeout=EXIT_WITHIN_S)
        elapsed = time.monotonic() - start
        time.sleep(0.5)
        # a zombie reparented to PID 1 is the init system's to reap (it does, except in
        # sandboxes whose PID 1 reaps nothing); every other process must be gone
        left = [p for p in _session(proc.pid) if not p.endswith(" Z")]
        assert not left, f"processes of the matrix left behind (pid state): {left}"
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    err = (tmp_path / "stderr").read_text()
    assert proc.returncode == 130 and elapsed < EXIT_WITHIN_S, err
    assert "cases not run" in err and "Traceback" not in err
    cases = json.loads(out.read_text())["cases"]
    assert len(cases) >= 2 and all(c["outcome"] in ("converged", "clear-error") for c in cases)
