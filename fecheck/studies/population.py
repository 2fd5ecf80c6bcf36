"""Population studies: the EF at many samples of a scene's varied keys.

The samples are a design in the unit cube (`fecheck.studies.sobol`: Saltelli's, for
Sobol indices, or plain points) mapped to key values by each key's distribution
(`fecheck.studies.population_inputs`). Each sample is one scene run with its overrides,
through the sweep's machinery (`fecheck.studies.sweep`): serially in this process or
on a local process pool or a Dask cluster in batches of samples (`run_batch`), each
worker reusing the model parts a sample's values do not change (`fecheck.model.reuse`).
Every sample starts from the equilibrium predicted for it by the linearised response of
the scene's own (the baseline pose; `predict_starts`) with fresh contact state, so that
its numbers depend on its values alone, not on the worker or the samples before it: a
study on a cluster equals the serial one. A sample not solved from there is solved from
the baseline pose, and one not solved from that either is reached by a continuation
from the scene's values (`solve_sample`); a stalled solve stops early (`STALL_STEPS`).
Only a flat row of numbers comes back from a sample (`slim_row`), so that 10,000 samples
of the scanned knee fit in memory.

A failed sample is recorded with its error and counted; a sample that did not converge
is kept with ``converged`` false. Neither enters the statistics (NaN there), and a Sobol
index leaves out the base rows that contain one (`fecheck.studies.sobol`).

A study is resumable: its CSV holds one row per finished sample, and a study started
again with the same keys, distributions, method, seed and sample count runs only the
samples missing from it.
"""

from __future__ import annotations

import csv
import io
import math
import os
import sys
import threading
import time
import uuid
from collections.abc import Callable, Sequence
from concurrent.futures import Executor, Future
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from fecheck.errors import FecheckError
from fecheck.io.outputs import write_text
from fecheck.model.results import RunResult
from fecheck.model.reuse import reusing_builds
from fecheck.model.run import forget_contact_state, run_scene
from fecheck.scene import Scene, apply_overrides
from fecheck.statics.newton import stopping_stalls
from fecheck.studies import sobol
from fecheck.studies.pool import (
    ProcessPool,
    interrupts_held,
    interrupts_ignored,
    raise_pending_interrupt,
    rearm_handlers,
)
from fecheck.studies.population_inputs import Varied, overrides_for
from fecheck.studies.sweep import (
    describe_error,
    finished_futures,
    pin_geometry_dir,
)

DEFAULT_OUTPUTS = ("max_pressure_MPa", "medial_share", "medial_max_pressure_MPa",
                   "lateral_max_pressure_MPa")
DERIVED = {
    "max_pressure_MPa": "the larger compartment max pressure, MPa",
    "medial_share": "medial force / (medial + lateral force): the split",
    "area_mm2": "medial + lateral contact area, mm²",
}
"""Outputs computed from the compartments (beside every column of a run's flat row)."""
REBUILD_FACTOR = 3.0
"""A varied key is refused (without --allow-rebuild) when rebuilding the model parts it
changes takes longer than this many solves and more than `REBUILD_MIN_S`."""
REBUILD_MIN_S = 0.2
"""Rebuilds shorter than this (s) are accepted, but for a mesh key's (the baseline's laws:
0.05-0.1 s; a new plateau mesh: 0.1-0.6 s, measured, with the machine's load)."""
MESH_SECTIONS = ("mesh.", "geometry.")
"""Keys of these sections change a mesh: varied, they re-mesh at every sample whatever the
rebuild takes on this machine, so they are refused without --allow-rebuild."""


@dataclass(frozen=True)
class Plan:
    """A study's samples: varied keys, unit-cube design `u` (runs, d), its `overrides`,
    `method`, `seed`, whether the design carries Sobol indices, and the base rows."""

    varied: tuple[Varied, ...]
    u: np.ndarray
    overrides: tuple[tuple[str, ...], ...]
    method: str
    seed: int | None
    indices: bool
    base_rows: int

    @property
    def runs(self) -> int:
        """Number of samples (scene runs)."""
        return int(self.u.shape[0])

    def drawn(self) -> np.ndarray:
        """(runs, d) the reported value of each key at each sample (`Varied.drawn`)."""
        return np.column_stack([v.drawn(self.u[:, j]) for j, v in enumerate(self.varied)])


def make_plan(scene: Scene, varied: Sequence[Varied], samples: int, method: str,
              seed: int | None, indices: bool) -> Plan:
    """The samples of a study (`samples` runs at most; `sobol.runs_for`)."""
    d = len(varied)
    sobol.check_samples(samples, d, indices)
    base, _ = sobol.runs_for(samples, d, indices)
    u = (sobol.design(base, d, method, seed) if indices
         else sobol.base_matrix(base, d, method, seed))
    return Plan(tuple(varied), u, tuple(overrides_for(varied, scene, u)), method, seed,
                indices, base)


@dataclass(frozen=True)
class Sample:
    """One finished sample: its `index`, its output row (None when it failed) and the
    error that stopped it ("" when solved)."""

    index: int
    row: dict[str, float] | None
    error: str = ""

    @property
    def failed(self) -> bool:
        """True when the sample's run raised an error."""
        return self.row is None

    @property
    def converged(self) -> bool:
        """True when solved and converged."""
        return self.row is not None and bool(self.row["converged"])


def slim_row(result: RunResult) -> dict[str, float]:
    """The numbers of a run kept by a study: its flat row (`RunResult.flat_row`), the
    `DERIVED` outputs and the build time ``build_s``."""
    row = {k: float(v) for k, v in result.flat_row().items()
           if isinstance(v, (int, float)) and v is not None}
    comps = result.compartments
    forces = [c.force_N for c in comps.values()]
    row["max_pressure_MPa"] = float(max(c.max_pressure_MPa for c in comps.values()))
    row["area_mm2"] = float(sum(c.area_mm2 for c in comps.values()))
    total = sum(forces)
    row["medial_share"] = (float(comps["medial"].force_N / total)
                           if "medial" in comps and total > 0 else math.nan)
    row["build_s"] = float(result.timing_s.get("build", math.nan))
    return row


BATCH = 16
"""Samples per task on a local pool or a Dask cluster (one task's scene and keys are sent
once for all of them; a Ctrl-C loses at most the batches running)."""
CONTINUATION_STEPS = 4
"""A sample whose equilibrium is not found from the baseline pose is approached from the
scene's own values in this many equal steps of all its keys at once, each step solved
from the last one's pose."""
CONTINUATION_HALVINGS = 4
"""A continuation step that fails is halved, at most this many times in a sample."""
STALL_STEPS = 3
"""A sample's solve stops, not converged, after this many steps in a row whose line
search made no headway (`fecheck.statics.newton.stopping_stalls`): a stalled sample of
the scanned knee spent 60 iterations of ~18 evaluations on each of its six solves (the
direct one and the continuation's), as many evaluations as 900 samples that converge."""

_worker = threading.local()
"""A worker thread's study (``study_id``) and the model parts it built (``memo``,
`fecheck.model.reuse.reusing_builds`)."""


def _memo(study_id: str) -> dict:
    """This thread's built parts for the study `study_id` (new for another study)."""
    if getattr(_worker, "study_id", None) != study_id:
        _worker.study_id, _worker.memo = study_id, {}
    return _worker.memo


def _run_at(scene: Scene, overrides: Sequence[str], start: np.ndarray | None,
            memo: dict) -> RunResult:
    """The scene with `overrides`, solved from pose `start` with fresh contact state
    (`forget_contact_state`) and the parts kept in `memo`, a stalled solve stopped
    (`STALL_STEPS`)."""
    with reusing_builds(memo), stopping_stalls(STALL_STEPS):
        moved = apply_overrides(scene, list(overrides))
        forget_contact_state(moved)
        return run_scene(moved, start)


PREDICTOR_FRACTION = 0.25
"""`predict_starts` moves each varied key this fraction of the way from the scene's value
to each end of its range to measure the equilibrium's response."""
NEAR_BASELINE_MM = 1.0
"""A predicted start closer than this to the baseline pose (translations mm, rotations
rad x `ROTATION_LENGTH_MM`) is not used: the sample starts from the baseline pose, whose
broad-phase set every worker keeps (a new pose rebuilds it, which costs more than the
Newton steps saved over so short a move; the broad phase reuses a set over 1.8 mm)."""
ROTATION_LENGTH_MM = 50.0
"""Length that turns a rotation (rad) into a move (mm) in `NEAR_BASELINE_MM` (the
solver's scale of moments and rotations)."""


@dataclass(frozen=True)
class Starts:
    """Where a study's samples start: the baseline equilibrium `q0` (5,) and its
    linearised response `slopes` (d, 5), per unit of each varied key's drawn value
    (`Varied.drawn`) away from the scene's, `x0` (d,)."""

    q0: np.ndarray
    x0: np.ndarray
    slopes: np.ndarray

    def at(self, varied: Sequence[Varied], u: np.ndarray) -> np.ndarray:
        """The predicted equilibrium q (5,) of the sample at unit coordinates `u` (d,)."""
        x = np.array([float(v.drawn(np.asarray([u[j]]))[0]) for j, v in enumerate(varied)])
        return self.q0 + (x - self.x0) @ self.slopes

    def start(self, varied: Sequence[Varied], u: np.ndarray) -> np.ndarray | None:
        """The predicted equilibrium (`at`) if it lies `NEAR_BASELINE_MM` or more from the
        baseline pose, else None (the sample then starts from the baseline pose)."""
        q = self.at(varied, u)
        move = (q - self.q0) * np.array([1.0, 1.0, 1.0, ROTATION_LENGTH_MM,
                                         ROTATION_LENGTH_MM])
        return q if float(np.linalg.norm(move)) >= NEAR_BASELINE_MM else None


def _scene_value(v: Varied) -> float:
    """The scene's value of a varied key as `Varied.drawn` reports it."""
    return 1.0 if v.vector_scaled else float(v.nominal)


def predict_starts(scene: Scene, varied: Sequence[Varied], start: np.ndarray) -> Starts:
    """The baseline equilibrium `start` (5,) and its response to each varied key: the
    key moved `PREDICTOR_FRACTION` towards each end of its range (the others at the
    scene's values) and solved from `start`; the slope between the two ends (or between
    `start` and the one end that converged; none if neither did). Every sample then
    starts from the equilibrium this linear response predicts (`solve_sample`): most
    converge there in fewer Newton steps, each of them shorter, than from the baseline."""
    memo: dict = {}
    slopes = np.zeros((len(varied), len(start)))
    x0 = np.array([_scene_value(v) for v in varied])
    for j, v in enumerate(varied):
        ends = []
        for edge in (0.0, 1.0):
            x = x0[j] + PREDICTOR_FRACTION * (float(v.drawn(np.asarray([edge]))[0]) - x0[j])
            overrides = overrides_for([v], scene, np.array([[edge]]), PREDICTOR_FRACTION)[0]
            try:
                result = _run_at(scene, overrides, start, memo)
            except FecheckError:
                continue
            if result.converged and x != x0[j]:
                ends.append((x, np.asarray(result.pose.q, dtype=float)))
        if len(ends) == 1:
            ends.append((x0[j], np.asarray(start, dtype=float)))
        if len(ends) == 2:
            (xa, qa), (xb, qb) = ends
            slopes[j] = (qb - qa) / (xb - xa)
    return Starts(np.asarray(start, dtype=float), x0, slopes)


def solve_sample(scene: Scene, varied: Sequence[Varied], u: np.ndarray,
                 start: np.ndarray | Starts | None, memo: dict) -> tuple[RunResult, int]:
    """One sample's run, `u` (d,) its unit coordinates, and the continuation steps it took
    (0: solved directly).

    `start`: the baseline equilibrium (5,), or `Starts`: the sample is first solved from
    the equilibrium predicted for it (unless that is near the baseline pose,
    `Starts.start`), then, if that fails or stalls, from the baseline.
    Where the direct solve fails or stalls (a slack length far from the scene's leaves the
    baseline pose without the bundles that hold it), the sample's values are reached from
    the scene's in `CONTINUATION_STEPS` steps, each solved from the last one's pose, a
    failing step halved (`CONTINUATION_HALVINGS`). If that fails too, the direct solve's
    error is raised (or its unconverged result returned)."""
    if isinstance(start, Starts):
        q = start.start(varied, u)
        start = start.q0
        try:
            predicted = (None if q is None else
                         _run_at(scene, overrides_for(varied, scene, np.asarray(u)[None, :])[0],
                                 q, memo))
            if predicted is not None and predicted.converged:
                return predicted, 0
        except Exception:           # any solver failure: solved from the baseline then
            pass
    u = np.asarray(u, dtype=float)[None, :]
    try:
        direct = _run_at(scene, overrides_for(varied, scene, u)[0], start, memo)
        if direct.converged:
            return direct, 0
        error = None
    except Exception as err:        # any solver failure: the sample records it
        direct, error = None, err
    q, done, step, halvings, steps = start, 0.0, 1.0 / CONTINUATION_STEPS, 0, 0
    while halvings <= CONTINUATION_HALVINGS:
        target = min(1.0, done + step)
        steps += 1
        try:
            result = _run_at(scene, overrides_for(varied, scene, u, target)[0], q, memo)
        except Exception:
            result = None
        if result is not None and result.converged:
            if target == 1.0:
                return result, steps
            q, done = result.pose.q, target
            continue
        halvings += 1
        step *= 0.5
    if error is not None:
        raise error
    return direct, 0


def run_batch(scene: Scene, varied: Sequence[Varied], items: Sequence[tuple[int, np.ndarray]],
              start: np.ndarray | Starts | None, study_id: str) -> list[Sample]:
    """Run samples `items` = [(index, u (d,))] on a worker (or in this process), each from
    `start` (the baseline pose, or `Starts`: its prediction; `solve_sample`) with fresh
    contact state, reusing the parts the worker built
    for the study `study_id`: a sample's numbers depend on nothing but its values, so a
    study's outcome does not depend on where or in which order its samples ran."""
    memo = _memo(study_id)
    out = []
    for index, u in items:
        try:
            result, steps = solve_sample(scene, varied, u, start, memo)
        except Exception as err:
            out.append(Sample(index, None, f"{_label(index)}: {describe_error(err)}"))
            continue
        row = slim_row(result)
        row["continuation_steps"] = float(steps)
        out.append(Sample(index, row))
    return out


class PopulationInterrupted(KeyboardInterrupt):
    """A study stopped by Ctrl-C or SIGTERM: the samples finished until then."""

    def __init__(self, samples: dict[int, Sample]):
        super().__init__(f"population interrupted: {len(samples)} samples finished")
        self.samples = samples


@dataclass
class Progress:
    """Finished samples, with a progress line on stderr and a callback after each."""

    total: int
    show: bool
    on_sample: Callable[[dict[int, Sample]], None] | None = None
    done: dict[int, Sample] = field(default_factory=dict)
    start: float = field(default_factory=time.monotonic)
    resumed: int = 0
    _drawn_at: float = -math.inf

    def add(self, sample: Sample) -> None:
        """Record a finished sample."""
        self.done[sample.index] = sample
        self.draw()
        if self.on_sample is not None:
            self.on_sample(self.done)

    def draw(self, final: bool = False) -> None:
        """Redraw the progress line (at most 5 times a second, and at the end)."""
        now = time.monotonic()
        if not self.show or (now - self._drawn_at < 0.2 and not final):
            return
        self._drawn_at = now
        n = len(self.done)
        new = n - self.resumed
        rate = new / max(now - self.start, 1e-9)
        eta = (self.total - n) / rate if rate > 0 else math.inf
        failed = sum(1 for s in self.done.values() if s.failed)
        width = 30
        bar = "#" * (width * n // max(self.total, 1))
        eta_text = f"{eta:.0f} s left" if math.isfinite(eta) else ""
        sys.stderr.write(f"\rpopulation [{bar:.<{width}s}] {n}/{self.total}  "
                         f"{rate:.1f}/s  {failed} failed  {eta_text}   ")
        if final:
            sys.stderr.write("\n")
        sys.stderr.flush()


def _label(index: int) -> str:
    return f"sample {index}"


def _batches(plan: Plan, todo: Sequence[int], size: int) -> list[list[tuple[int, np.ndarray]]]:
    """The samples `todo` as (index, u) in batches of `size`."""
    items = [(i, plan.u[i]) for i in todo]
    return [items[k:k + size] for k in range(0, len(items), size)]


def _run_serial(scene: Scene, plan: Plan, todo: Sequence[int], start: np.ndarray | Starts | None,
                progress: Progress, study_id: str) -> None:
    for batch in _batches(plan, todo, 1):
        samples = run_batch(scene, plan.varied, batch, start, study_id)
        rearm_handlers()
        raise_pending_interrupt()
        for sample in samples:
            progress.add(sample)


def _collect(future: Future, batch: Sequence[tuple[int, np.ndarray]]) -> list[Sample]:
    try:
        return future.result()
    except Exception as err:
        return [Sample(i, None, f"{_label(i)} failed on a worker: {describe_error(err)}")
                for i, _ in batch]


def _run_on(executor: Executor, scene: Scene, plan: Plan, todo: Sequence[int],
            start: np.ndarray | Starts | None, progress: Progress, study_id: str) -> None:
    futures: dict[Future, list] = {}
    complete = False
    try:
        with interrupts_held():
            for batch in _batches(plan, todo, BATCH):
                futures[executor.submit(run_batch, scene, plan.varied, batch, start,
                                        study_id)] = batch
        for future in finished_futures(list(futures)):
            for sample in _collect(future, futures[future]):
                progress.add(sample)
        complete = True
    finally:
        if not complete:
            with interrupts_ignored():
                for future in futures:
                    future.cancel()


def run_population(scene: Scene, plan: Plan, *, done: dict[int, Sample] | None = None,
                   start: np.ndarray | None = None,
                   workers: int = 1, executor: Executor | None = None,
                   progress: bool = True,
                   on_sample: Callable[[dict[int, Sample]], None] | None = None
                   ) -> dict[int, Sample]:
    """Run the samples of `plan` not in `done`; every finished sample by index.

    start : (5,) the baseline equilibrium (`baseline_pose`; None: solved here); each
        sample starts from its linearised response there (`predict_starts`)
    workers : 1 and no `executor`: serial in this process; more: a local pool.
    executor : run on it (a Dask cluster's); the caller owns it.

    Raises
    ------
    PopulationInterrupted
        On Ctrl-C (SIGTERM): carries every sample finished, `done` included.
    """
    tracker = Progress(plan.runs, progress, on_sample, dict(done or {}))
    tracker.resumed = len(tracker.done)
    todo = [i for i in range(plan.runs) if i not in tracker.done]
    study_id = uuid.uuid4().hex
    if start is None and todo:
        start = baseline_pose(scene)
    if start is not None and todo:
        start = predict_starts(scene, plan.varied, start)
    try:
        if executor is None and workers <= 1:
            _run_serial(scene, plan, todo, start, tracker, study_id)
        elif executor is None:
            pool = ProcessPool(workers)
            ok = False
            try:
                _run_on(pool, pin_geometry_dir(scene), plan, todo, start, tracker, study_id)
                ok = True
            finally:
                with interrupts_ignored():
                    pool.shutdown() if ok else pool.terminate()
        else:
            _run_on(executor, pin_geometry_dir(scene), plan, todo, start, tracker, study_id)
    except KeyboardInterrupt:
        tracker.draw(final=True)
        raise PopulationInterrupted(tracker.done) from None
    tracker.draw(final=True)
    return tracker.done


# --- the rebuild check --------------------------------------------------------------


@dataclass(frozen=True)
class Probe:
    """The scene's nominal run and the cost of the rebuilds the varied keys cause.

    solve_s : the nominal run's solve time, s (parts reused)
    start : (5,) the nominal equilibrium q, where every sample starts (`baseline_pose`)
    rebuild_s : {varied name: build time of a run with that key moved, s} for the keys
        the model's reusable builds read (the others rebuild nothing)
    """

    solve_s: float
    start: np.ndarray | None
    rebuild_s: dict[str, float]


def baseline_pose(scene: Scene) -> np.ndarray | None:
    """The scene's own equilibrium q (5,), where a study's samples start (None when it does
    not converge: the samples then start from the scene's start pose)."""
    result = run_scene(scene)
    return np.asarray(result.pose.q, dtype=float) if result.converged else None


def probe(scene: Scene, plan: Plan) -> Probe:
    """Run the nominal scene twice (the second reuses the parts), then, for each varied
    key that a reusable build reads, one run with that key at a random value of its
    distribution from the nominal parts: how long the rebuild it causes takes (a random
    value, so that no mesh cached on disk by an earlier study hides the cost)."""

    memo: dict = {}
    with reusing_builds(memo):
        first = run_scene(scene)
        warm = run_scene(scene)
    start = np.asarray(first.pose.q, dtype=float) if first.converged else None
    solve_s = float(warm.timing_s.get("total", math.nan))
    read = set().union(*(entry[1] for entry in memo.values())) if memo else set()
    saved = dict(memo)
    costs = {}
    fresh = np.random.default_rng()     # a value no earlier run cached a mesh for
    for v in plan.varied:
        if v.key not in read:
            continue
        u = np.full((1, 1), fresh.uniform(0.05, 0.95))
        moved = apply_overrides(scene, list(overrides_for([v], scene, u)[0]))
        memo.clear()
        memo.update(saved)
        with reusing_builds(memo):
            try:
                result = run_scene(moved)
            except FecheckError:
                continue                         # the sample will record its own error
        costs[v.name] = float(result.timing_s.get("build", 0.0))
    return Probe(solve_s, start, costs)


def check_rebuilds(found: Probe, plan: Plan) -> list[str]:
    """Refuse mesh keys (`MESH_SECTIONS`) and keys whose rebuild at every sample costs more
    than `REBUILD_FACTOR` solves (and `REBUILD_MIN_S`); lines describing the accepted
    rebuilds' costs.

    Raises
    ------
    FecheckError
        Naming the key, the rebuild time per sample and the study's extra time.
    """
    lines = []
    for name, cost in found.rebuild_s.items():
        extra = _duration(cost * plan.runs)
        if (name.startswith(MESH_SECTIONS)
                or cost > max(REBUILD_MIN_S, REBUILD_FACTOR * found.solve_s)):
            raise FecheckError(
                f"--vary {name} rebuilds the model's meshes and contact parts at every "
                f"sample: {cost:.2g} s each against a {found.solve_s:.2g} s solve, about "
                f"{extra} more for {plan.runs} samples; vary it with `fecheck sweep` over a "
                f"few values, or pass --allow-rebuild")
        if cost > 0.1 * found.solve_s:
            lines.append(f"{name} rebuilds the model's contact parts at every sample: "
                         f"{cost:.2g} s each ({extra} for {plan.runs} samples)")
    return lines


def _duration(seconds: float) -> str:
    """``"40 s"``, ``"12 min"`` or ``"3.1 h"``."""
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


# --- outputs, CSV and resume --------------------------------------------------------


def output_columns(samples: dict[int, Sample]) -> list[str]:
    """Every output column seen in the solved samples, in first-seen order."""
    columns: dict[str, None] = {}
    for s in samples.values():
        if s.row is not None:
            columns.update(dict.fromkeys(s.row))
    return list(columns)


def check_outputs(names: Sequence[str], available: Sequence[str]) -> None:
    """Refuse an output no solved sample has."""
    for name in names:
        if name not in available:
            raise FecheckError(f"--outputs {name}: no such output; choose from "
                               f"{', '.join(available)}")


def csv_text(plan: Plan, samples: dict[int, Sample]) -> str:
    """One row per finished sample, by index: sample, the drawn values, converged, every
    output, error."""
    drawn = plan.drawn()
    outputs = [c for c in output_columns(samples) if c != "converged"]
    columns = ["sample", *(v.column() for v in plan.varied), "converged", *outputs, "error"]
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(columns)
    for i in sorted(samples):
        s = samples[i]
        row = s.row or {}
        writer.writerow([i, *(repr(float(x)) for x in drawn[i]),
                         bool(row.get("converged", False)),
                         *(repr(row[c]) if c in row else "" for c in outputs), s.error])
    return buffer.getvalue()


def write_csv(plan: Plan, samples: dict[int, Sample], path: str | os.PathLike) -> None:
    """Write the finished samples as CSV, atomically (`csv_text`)."""
    write_text(path, csv_text(plan, samples))


def read_done(path: str | os.PathLike, plan: Plan) -> dict[int, Sample]:
    """The samples already in a study's CSV (none if it does not exist).

    Raises
    ------
    FecheckError
        When the file was written for another study (keys, values or sample count).
    """
    path = Path(path)
    if not path.is_file():
        return {}
    try:
        with path.open(newline="") as f:
            table = list(csv.DictReader(f))
    except (OSError, csv.Error, UnicodeDecodeError) as err:
        raise FecheckError(f"--csv {path}: cannot read it to resume ({err})") from None
    other = (f"--csv {path} holds samples of another study (other keys, distributions, "
             "method, seed or sample count): give another --csv, or remove it to start again")
    drawn = plan.drawn()
    done = {}
    for row in table:
        try:
            i = int(row["sample"])
            values = [float(row[v.column()]) for v in plan.varied]
        except (KeyError, TypeError, ValueError):
            raise FecheckError(other) from None
        if not 0 <= i < plan.runs or not np.allclose(values, drawn[i], rtol=1e-9, atol=0.0):
            raise FecheckError(other)
        done[i] = _sample_from_csv(i, row, plan)
    return done


def _sample_from_csv(i: int, row: dict[str, str], plan: Plan) -> Sample:
    if row.get("error"):
        return Sample(i, None, row["error"])
    skip = {"sample", "error", *(v.column() for v in plan.varied)}
    out = {k: (float(v) if v not in ("", None) else math.nan)
           for k, v in row.items() if k not in skip and k != "converged"}
    out["converged"] = float(row.get("converged") == "True")
    return Sample(i, out)


# --- statistics ---------------------------------------------------------------------


def output_matrix(plan: Plan, samples: dict[int, Sample], name: str) -> np.ndarray:
    """(runs,) the output at every sample; NaN where a sample is missing, failed or did
    not converge."""
    y = np.full(plan.runs, math.nan)
    for i, s in samples.items():
        if s.converged:
            y[i] = s.row.get(name, math.nan)
    return y


def describe(y: np.ndarray) -> dict[str, float]:
    """Mean, standard deviation and the 5, 50 and 95 % quantiles of the finite values."""
    y = y[np.isfinite(y)]
    if y.size == 0:
        return {"n": 0}
    q5, q50, q95 = np.percentile(y, [5, 50, 95])
    return {"n": int(y.size), "mean": float(y.mean()), "sd": float(y.std(ddof=1))
            if y.size > 1 else 0.0, "p5": float(q5), "median": float(q50), "p95": float(q95),
            "min": float(y.min()), "max": float(y.max())}


def indices_of(plan: Plan, samples: dict[int, Sample], name: str) -> sobol.Indices:
    """Sobol indices of output `name` (the plan must carry them)."""
    return sobol.sobol_indices(output_matrix(plan, samples, name),
                               [v.name for v in plan.varied], seed=plan.seed)


def extreme_samples(plan: Plan, samples: dict[int, Sample], name: str, k: int) -> list[int]:
    """The indices of the `k` samples farthest from the median of output `name`."""
    y = output_matrix(plan, samples, name)
    ok = np.flatnonzero(np.isfinite(y))
    if ok.size == 0:
        return []
    order = np.argsort(-np.abs(y[ok] - np.median(y[ok])), kind="stable")
    return [int(i) for i in ok[order[:k]]]


def report_dict(scene: Scene, plan: Plan, samples: dict[int, Sample], outputs: Sequence[str],
                indices: dict[str, Any], notes: Sequence[str]) -> dict[str, Any]:
    """The study as a JSON-ready dict."""
    failed = {i: s.error for i, s in sorted(samples.items()) if s.failed}
    stalled = [i for i, s in sorted(samples.items()) if not s.failed and not s.converged]
    return {
        "scene": scene.source, "method": plan.method, "seed": plan.seed,
        "samples": plan.runs, "finished": len(samples), "base_rows": plan.base_rows,
        "keys": {v.name: {"distribution": v.dist.text(), "unit": v.unit,
                          "nominal": v.nominal} for v in plan.varied},
        "failed": {"count": len(failed), "samples": failed},
        "not_converged": {"count": len(stalled), "samples": stalled},
        "outputs": {n: describe(output_matrix(plan, samples, n)) for n in outputs},
        "indices": indices, "notes": list(notes)}
