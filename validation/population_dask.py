"""The scanned knee's population on a local Dask cluster equals the serial study.

Starts a Dask scheduler and two single-threaded workers on this machine as the docs say
(``dask scheduler``, then ``dask worker ADDRESS --nworkers 2 --nthreads 1``), runs the
population of ``validation/population_study.py`` (the same keys and ranges) once on the
cluster (``--scheduler ADDRESS``) and once serially in this process, and compares the two
CSVs: every drawn value and every output of every sample must be equal to the last digit
(the CSV holds each number's repr), the timing columns (``build_s``, ``solve_s``) aside.
Each sample starts from the pose predicted for it from the baseline's linearised
response, with fresh contact state, so its numbers do not depend on the worker or on the
samples that ran before it there.

The full run is 112 samples of the full-resolution knee in Saltelli's design (the Sobol
indices are compared too); --quick is 16 plain samples of the knee decimated to 1,500
tibial faces. Exit 1 when a value differs, 2 without Dask (``pip install 'fecheck[dask]'``).

    python validation/population_dask.py [--quick] [--samples N] [--out DIR]
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.cli import main as fecheck
from validation.population_study import QUICK_SET, SCENE, VARY

ROOT = Path(__file__).resolve().parents[1]
SAMPLES, QUICK_SAMPLES = 112, 16
TIMINGS = ("build_s", "solve_s")
"""Columns that hold times, which differ from run to run."""
START_TIMEOUT_S = 120.0


def arguments(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true",
                   help=f"{QUICK_SAMPLES} plain samples of the decimated knee")
    p.add_argument("--samples", type=int, help=f"samples (default {SAMPLES})")
    p.add_argument("--out", type=Path, default=Path("out/validation/population_dask"),
                   help="output folder (both CSVs and JSONs, the comparison)")
    return p.parse_args(argv)


def _environment() -> dict[str, str]:
    """This process's environment, with this checkout first on the workers' path."""
    path = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH", "")) if p)
    return dict(os.environ, PYTHONPATH=path, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1",
                MKL_NUM_THREADS="1")


@contextlib.contextmanager
def local_cluster(workers: int = 2):
    """A scheduler and `workers` worker processes on 127.0.0.1 started from the command
    line (``dask scheduler``, ``dask worker ADDRESS``); yields the scheduler's address and
    stops them at the end."""
    from distributed import Client

    env = _environment()
    dask = [sys.executable, "-m", "dask"]
    started: list[subprocess.Popen] = []
    with tempfile.TemporaryDirectory() as tmp:
        info = Path(tmp) / "scheduler.json"
        try:
            started.append(subprocess.Popen(
                [*dask, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                 "--scheduler-file", str(info)], env=env, stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL))
            deadline = time.monotonic() + START_TIMEOUT_S
            while not info.is_file() and time.monotonic() < deadline:
                time.sleep(0.2)
            address = json.loads(info.read_text())["address"]
            started.append(subprocess.Popen(
                [*dask, "worker", address, "--nworkers", str(workers), "--nthreads", "1",
                 "--no-dashboard", "--host", "127.0.0.1"], env=env, cwd=tmp,
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
            with Client(address, timeout=START_TIMEOUT_S) as client:
                client.wait_for_workers(workers, timeout=START_TIMEOUT_S)
            yield address
        finally:
            for process in reversed(started):
                process.terminate()
            for process in reversed(started):
                try:
                    process.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    process.kill()
                    process.wait()


def read_rows(path: Path) -> dict[str, dict[str, str]]:
    """{sample: row} of a population CSV."""
    with path.open(newline="") as f:
        return {row["sample"]: row for row in csv.DictReader(f)}


def differences(serial: dict, cluster: dict) -> tuple[int, list[str]]:
    """(values compared, one line per difference) between two population CSVs."""
    out, compared = [], 0
    if serial.keys() != cluster.keys():
        out.append(f"samples differ: {sorted(serial.keys() ^ cluster.keys())[:10]}")
    for sample in sorted(serial.keys() & cluster.keys(), key=int):
        a, b = serial[sample], cluster[sample]
        for column in a.keys() | b.keys():
            if column in TIMINGS:
                continue
            compared += 1
            if a.get(column) != b.get(column):
                out.append(f"sample {sample} {column}: serial {a.get(column)!r}, "
                           f"cluster {b.get(column)!r}")
    return compared, out


def main(argv=None) -> int:
    args = arguments(argv)
    try:
        import distributed  # noqa: F401
    except ImportError:
        print("population_dask: needs Dask: pip install 'fecheck[dask]'", file=sys.stderr)
        return 2
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    samples = args.samples or (QUICK_SAMPLES if args.quick else SAMPLES)
    study = ["population", SCENE, *(a for v in VARY for a in ("--vary", v)),
             "--samples", str(samples)]
    if args.quick:
        study += ["--indices", "none", *(a for s in QUICK_SET for a in ("--set", s))]
    runs = {}
    for name in ("serial", "cluster"):
        for suffix in ("csv", "json"):
            (out / f"{name}.{suffix}").unlink(missing_ok=True)
        files = ["--csv", str(out / f"{name}.csv"), "--json", str(out / f"{name}.json")]
        start = time.perf_counter()
        if name == "serial":
            code = fecheck([*study, *files])
        else:
            with local_cluster(2) as address:
                print(f"Dask scheduler at {address}, 2 workers", flush=True)
                code = fecheck([*study, *files, "--scheduler", address])
        runs[name] = time.perf_counter() - start
        if code not in (0, 1):
            print(f"population_dask: the {name} study exited {code}", file=sys.stderr)
            return 1
    compared, diff = differences(read_rows(out / "serial.csv"), read_rows(out / "cluster.csv"))
    summaries = [json.loads((out / f"{n}.json").read_text()) for n in ("serial", "cluster")]
    for key in ("failed", "not_converged", "outputs", "indices"):
        compared += 1
        if summaries[0][key] != summaries[1][key]:
            diff.append(f"the JSON's {key!r} differs")
    result = {"samples": samples, "quick": args.quick, "values_compared": compared,
              "differences": diff, "serial_s": runs["serial"], "cluster_s": runs["cluster"]}
    (out / "population_dask.json").write_text(json.dumps(result, indent=2) + "\n")
    print(f"{samples} samples, serial {runs['serial']:.0f} s, on the Dask cluster "
          f"{runs['cluster']:.0f} s: {compared} values compared, {len(diff)} differ")
    for line in diff[:20]:
        print(f"  {line}")
    return 1 if diff else 0


if __name__ == "__main__":
    sys.exit(main())
