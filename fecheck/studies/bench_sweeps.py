"""Sweep throughput: equilibria per second of `fecheck sweep`, measured in one run.

Cases: a sweep of the load point's medio-lateral position ``load.point_mm[0]`` (mm),
evenly spaced around the scene's own load point, as the thesis's load-point sweeps are:

* ``baseline`` — the packaged default scene, 1,000 points over the reference ± 8 mm
  (quick: 100); the load stays between the contact points (x = -20.4 and 28.3 mm).
* ``femur_tibia`` — the packaged scene ``femur_tibia``, the scanned lenhart2015
  cartilage sheets, 100 points over the reference ± 5 mm (quick: 10). It reads the knee
  packaged with fecheck; when one of its files is absent (``--set geometry.dir``
  elsewhere) the case is named in ``skipped`` with the reason.

Each case runs `fecheck.studies.sweep.run_sweep` twice: ``serial`` (in this process,
each point warm-started from the previous equilibrium) and ``2 workers`` (a local pool,
each point warm-started from the last one its worker solved). The wall time runs from
the call to its return, so for the pool it includes starting the workers (forked),
sending the scene and stopping them. That fixed cost is measured on its own before the
pooled sweep: ``start_s``, the wall time of a pooled sweep of one point per worker (each
worker loads the compiled kernels and builds the model once, whatever the sweep's
length).
Equilibria per second = points / wall time. The median time per equilibrium is the
median over the points of ``RunResult.timing_s["solve"]`` (the Newton solve with its
contact evaluations, no mesh build); beside it the same field of ONE cold-started
`run_scene` of the scene at its own load point in this process, after one untimed
`run_scene` that builds the meshes. The machine is shared: compare the numbers as
ratios within one run.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from fecheck.errors import FecheckError
from fecheck.scene import Scene, load_scene, packaged_scene_path
from fecheck.scene.surfaces import FILE_KEYS, file_path, required_path
from fecheck.studies.bench import machine

PARAM = "load.point_mm[0]"
WORKERS = 2
SCANNED_SCENE = "femur_tibia"
"""The scanned scene, packaged with fecheck."""


@dataclass(frozen=True)
class Case:
    """One benchmarked sweep.

    label : the scene's name in the table
    scene : the scene, at its reference load point
    points : how many values
    half_range_mm : the values span the reference ``load.point_mm[0]`` ± this, mm
    """

    label: str
    scene: Scene
    points: int
    half_range_mm: float

    def values_mm(self) -> list[float]:
        """The swept values of ``load.point_mm[0]``, mm."""
        x0 = float(self.scene["load.point_mm"][0])
        return [float(v) for v in np.linspace(x0 - self.half_range_mm,
                                              x0 + self.half_range_mm, self.points)]


def missing_data(scene: Scene) -> str:
    """Why `scene` cannot be solved here: the first of its ``[geometry]`` files that is
    absent, as the run itself would say it ("" when every file is there)."""
    for key in FILE_KEYS:
        if file_path(scene, key) is None:
            continue
        try:
            required_path(scene, key, "the benchmark")
        except FecheckError as err:
            return str(err)
    return ""


def scanned_scene() -> Scene | str:
    """The femur-tibia scene, or why it is skipped (a file of its data set absent)."""
    scene = load_scene(packaged_scene_path(SCANNED_SCENE))
    return missing_data(scene) or scene


def single_solve_ms(scene: Scene) -> float:
    """``timing_s["solve"]`` of one cold-started `run_scene` (after an untimed one that
    builds the meshes), ms."""
    from fecheck.model.run import run_scene

    run_scene(scene)
    return 1e3 * run_scene(scene).timing_s["solve"]


def mode(workers: int) -> str:
    """A mode's name: "serial" (1 process) or "N workers"."""
    return "serial" if workers == 1 else f"{workers} workers"


def sweep_row(case: Case, workers: int, single_ms: float) -> dict:
    """Time one sweep of `case` on `workers` processes (1: serial, in this process): its
    row, wall time in s, solve times in ms (`single_ms`, the single solve's, as given);
    for a pool, first its fixed cost ``start_s`` (a sweep of one point per worker), s."""
    from fecheck.studies.sweep import run_sweep

    values = case.values_mm()
    start_s = None
    if workers > 1:
        start = time.perf_counter()
        run_sweep(case.scene, PARAM, values[:workers], workers=workers, progress=False)
        start_s = time.perf_counter() - start
    start = time.perf_counter()
    points = run_sweep(case.scene, PARAM, values, workers=workers, progress=False)
    wall_s = time.perf_counter() - start
    solve_ms = [1e3 * p.result.timing_s["solve"] for p in points if not p.failed]
    return {"scene": case.label, "points": len(values), "mode": mode(workers),
            "values_mm": [values[0], values[-1]],
            "converged": sum(p.converged for p in points), "wall_s": wall_s,
            "equilibria_per_s": len(values) / wall_s, "start_s": start_s,
            "median_point_ms": statistics.median(solve_ms) if solve_ms else None,
            "single_solve_ms": single_ms}


def measure(case: Case, progress: Callable[[str], None]) -> list[dict]:
    """The single solve, then the serial and the pooled sweep of `case`."""
    progress(f"{case.label}: one cold-started solve")
    single_ms = single_solve_ms(case.scene)
    progress(f"{case.label}: solve {single_ms:.2f} ms")
    rows = []
    for workers in (1, WORKERS):
        progress(f"{case.label}: {mode(workers)} sweep, {case.points} points")
        row = sweep_row(case, workers, single_ms)
        progress(f"{case.label}: {row['wall_s']:.2f} s, {row['equilibria_per_s']:.1f} "
                 f"equilibria/s, {row['converged']}/{row['points']} converged")
        rows.append(row)
    return rows


def speedups(cases: list[dict]) -> dict[str, float]:
    """Serial wall time over the pool's, per scene."""
    wall = {(c["scene"], c["mode"]): c["wall_s"] for c in cases}
    return {scene: wall[scene, "serial"] / wall[scene, mode(WORKERS)]
            for scene, m in wall if m == "serial"}


def run(quick: bool = False, progress: Callable[[str], None] = lambda message: None, *,
        sizes: tuple[int, int] | None = None) -> dict:
    """Both cases in both modes: {"cases", "speedup", "skipped", "quick", "machine"}.

    `sizes` (baseline points, femur-tibia points) overrides the quick/full defaults,
    e.g. for a smoke test.
    """
    baseline_n, scanned_n = sizes or ((100, 10) if quick else (1000, 100))
    cases = [Case("baseline", load_scene(None), baseline_n, 8.0)]
    skipped = {}
    scanned = scanned_scene()
    if isinstance(scanned, str):
        skipped["femur_tibia"] = scanned
        progress(f"femur_tibia skipped: {scanned}")
    else:
        cases.append(Case("femur_tibia", scanned, scanned_n, 5.0))
    rows = [row for case in cases for row in measure(case, progress)]
    return {"cases": rows, "speedup": speedups(rows), "skipped": skipped, "quick": quick,
            "machine": machine()}


def _verdict(row: dict) -> str:
    """The sweep's median solve time against the single solve's, in words."""
    if row["median_point_ms"] is None:
        return "no point solved"
    ratio = row["median_point_ms"] / row["single_solve_ms"]
    return f"{ratio:.2f}x the single solve: " + ("no worse" if ratio <= 1 else "slower")


def table(result: dict) -> str:
    """The cases (one line per scene and mode), speed-ups, verdicts and skipped cases."""
    lines = [f"sweeps of {PARAM} (mm); wall s from the run_sweep call to its return "
             f"(worker start-up and shutdown included), eq/s = points / wall s;",
             "solve ms = RunResult.timing_s['solve']: the median over the sweep's points, "
             "and of one cold-started run_scene",
             f"{'scene':12s}{'mode':10s}{'range mm':>16s}{'points':>8s}{'conv':>6s}"
             f"{'wall s':>9s}{'eq/s':>8s}{'wall ms/pt':>11s}{'median solve ms':>16s}"
             f"{'single solve ms':>16s}"]
    for r in result["cases"]:
        lo, hi = r["values_mm"]
        median = "-" if r["median_point_ms"] is None else f"{r['median_point_ms']:.2f}"
        lines.append(f"{r['scene']:12s}{r['mode']:10s}{f'{lo:.2f} … {hi:.2f}':>16s}"
                     f"{r['points']:8d}{r['converged']:6d}{r['wall_s']:9.2f}"
                     f"{r['equilibria_per_s']:8.1f}{1e3 * r['wall_s'] / r['points']:11.2f}"
                     f"{median:>16s}{r['single_solve_ms']:16.2f}")
    lines.append(f"speed-up of {mode(WORKERS)} over serial (wall time): " + (", ".join(
        f"{scene} {s:.2f}x" for scene, s in result["speedup"].items()) or "-"))
    lines += [f"  of which starting the pool ({r['scene']}: one point per worker, each "
              f"loading the compiled kernels and building the model): {r['start_s']:.2f} s"
              for r in result["cases"] if r["start_s"] is not None]
    lines.append("median solve per equilibrium in the sweep vs one cold-started solve:")
    lines += [f"  {r['scene']} {r['mode']}: {_verdict(r)}" for r in result["cases"]]
    unconverged = [f"{r['scene']} {r['mode']} ({r['points'] - r['converged']})"
                   for r in result["cases"] if r["converged"] < r["points"]]
    lines.append("points not converged: " + (", ".join(unconverged) or "none"))
    lines += [f"skipped {name}: {why}" for name, why in result["skipped"].items()]
    m = result["machine"]
    lines.append(f"machine: {m['platform']}, {m['cpus']} cpus, python {m['python']}")
    return "\n".join(lines)
