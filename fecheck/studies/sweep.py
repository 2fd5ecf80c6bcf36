"""Parameter sweeps: one scene solved for a list of values of one key.

Serial sweeps warm-start each point from its neighbour's equilibrium; parallel sweeps
send the points, in value order, to a `concurrent.futures` executor — a local process
pool, or a Dask distributed cluster's executor (``fecheck[dask]``) through the same code
path — and each worker warm-starts a point from the last one it solved. Serial or not,
the model parts a point's value does not change are built once per sweep (per worker):
`fecheck.model.reuse`.
The thesis's load-point sweeps (Figs. 5.2/5.6/5.8: ``load.point_mm[0]`` from −8 to +8
mm around the reference) and material sweeps (Tables 5.4, 5.5) are sweeps of scenes.

A sweep keeps going past a failing point: the failure is recorded in that point
(`SweepPoint.error`) and the other points still run, unless ``fail_fast`` is set. Every
value is validated before the first solve. An interrupt (Ctrl-C, or SIGTERM turned into
one by the CLI) cancels the queued points, kills the local pool's workers (they ignore
SIGINT, so only the parent decides) and raises `SweepInterrupted` carrying the finished
points.

>>> parse_values("-8:8:5")
[-8.0, -4.0, 0.0, 4.0, 8.0]
"""

from __future__ import annotations

import csv
import io
import math
import os
import queue
import re
import socket
import sys
import threading
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Executor, Future
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fecheck.errors import FecheckError
from fecheck.io.outputs import write_output, write_text
from fecheck.model.plausibility import check_ef_poisson
from fecheck.model.results import RunResult
from fecheck.model.reuse import reusing_builds
from fecheck.scene import SCHEMA, Scene, apply_overrides, with_values
from fecheck.scene.load import warn_inert
from fecheck.scene.packaged import PACKAGE_PREFIX
from fecheck.scene.relevance import SCANNED_KINDS
from fecheck.scene.surfaces import base_dir
from fecheck.studies.pool import (
    KILL_WAIT_S,
    ProcessPool,
    interrupts_held,
    interrupts_ignored,
    raise_pending_interrupt,
    rearm_handlers,
)

_INDEXED = re.compile(r"^(?P<key>[\w.]+)\[(?P<index>\d+)\]$")
_SET_PREFIX = re.compile(r"^--set( on [^:]*)?: ")
"""How `apply_overrides` starts its messages; a sweep's values are not ``--set``."""
MAX_POINTS = 10_000
"""Most points a sweep runs: every point's result stays in memory for the table, the CSV
and the plots (measured on the baseline: 2,000 points 215 s and 0.68 GB peak against 0.31
GB at 200, about 0.2 MB and 0.1 s a point), so 10,000 points are about 2 GB and 20
minutes; the values are checked against the scene first (0.12 ms each)."""
_POLL_S = 0.25
PLAIN_PROGRESS_S = 10.0
"""Without a terminal, a sweep's progress line is written at most this often, s."""
"""Longest wait for a finished point before the main thread looks at signals again, s."""


def parse_values(text: str) -> list[float]:
    """``"A:B:N"`` → N evenly spaced values from A to B; ``"a,b,c"`` → those values; at
    most `MAX_POINTS` (counted before any value is made)."""
    try:
        if ":" in text:
            a, b, n = text.split(":")
            count = int(n)
            if count < 1:
                raise ValueError
            if count > MAX_POINTS:
                raise FecheckError(f"--values {text!r}: {count:,} points, more than the "
                                   f"{MAX_POINTS:,} a sweep runs (each point's result is kept "
                                   "for the table: about 0.2 MB and 0.1 s a point on the "
                                   f"baseline): give N <= {MAX_POINTS:,}, or split the range "
                                   "into several sweeps")
            ends = [float(a), float(b)]
            values = (ends if not np.all(np.isfinite(ends)) else
                      [float(v) for v in np.linspace(*ends, count)])
        else:
            values = [float(v) for v in text.split(",")]
    except ValueError:
        raise FecheckError(f"--values {text!r}: expected START:STOP:COUNT (e.g. -8:8:17) or "
                           f"a comma list (e.g. 0.15,0.3,0.45)") from None
    if not values or not all(np.isfinite(values)):
        raise FecheckError(f"--values {text!r}: give finite numbers")
    if len(values) > MAX_POINTS:
        raise FecheckError(f"--values: {len(values):,} values listed, more than the "
                           f"{MAX_POINTS:,} a sweep runs: split them into several sweeps")
    return values


def override_for(scene: Scene, param: str, value: float) -> str:
    """The ``KEY=VALUE`` override setting `param` (``key`` or ``key[i]``) to `value`."""
    match = _INDEXED.match(param)
    key = match["key"] if match else param
    if key not in SCHEMA:
        raise FecheckError(f"--param {param!r}: unknown scene key {key!r}")
    kind = SCHEMA[key].kind
    if match:
        current = [float(v) for v in scene[key]]
        index = int(match["index"])
        if index >= len(current):
            raise FecheckError(f"--param {param!r}: {key} has {len(current)} components")
        current[index] = float(value)
        return f"{key}={current!r}"
    if kind == "int":
        if value != int(value):
            raise FecheckError(f"--param {param!r} is an integer key; give integer values")
        return f"{key}={int(value)}"
    if kind != "float":
        raise FecheckError(f"--param {param!r}: sweeps take numeric keys (or key[i] of a "
                           f"vector key); {key} is a {kind}")
    return f"{key}={float(value)!r}"


def sweep_overrides(scene: Scene, param: str, values: Sequence[float]) -> list[str]:
    """The override of every value, each checked against the scene before any solve; an
    `InertKeyWarning` when the swept key has no effect in the scene.

    Raises
    ------
    FecheckError
        Naming ``--values`` and the first value the scene does not accept.
    """
    overrides = []
    for value in values:
        override = override_for(scene, param, value)
        try:
            check_ef_poisson(apply_overrides(scene, [override]))
        except FecheckError as err:
            reason = _SET_PREFIX.sub("", str(err))
            if not reason.startswith(f"{param} ="):
                reason = f"{_label(param, value)}: {reason}"
            raise FecheckError(f"--values: {reason}") from None
        overrides.append(override)
    match = _INDEXED.match(param)
    warn_inert(scene, [match["key"] if match else param])     # a sweep of a key that does nothing
    return overrides


@dataclass(frozen=True)
class SweepPoint:
    """One swept value and its result, or the one-line error that stopped its solve.

    value : the swept value (units of the swept key)
    result : the run's result; None when the point failed
    error : the failure message ("" when the point was solved)
    """

    value: float
    result: RunResult | None
    error: str = ""

    @property
    def failed(self) -> bool:
        """True when the point's solve raised an error."""
        return self.result is None

    @property
    def converged(self) -> bool:
        """True when the point was solved and its Newton solve converged."""
        return self.result is not None and bool(self.result.converged)


class SweepInterrupted(KeyboardInterrupt):
    """A sweep stopped by Ctrl-C (or SIGTERM turned into one): its finished points.

    points : the finished points, in value order
    total : how many points the sweep had
    """

    def __init__(self, points: list[SweepPoint], total: int):
        super().__init__(f"sweep interrupted: {len(points)} of {total} points finished")
        self.points = points
        self.total = total


def _label(param: str, value: float) -> str:
    """``"KEY = VALUE"``: how messages name a point."""
    return f"{param} = {value:g}"


def describe_error(err: BaseException) -> str:
    """One line for an error: its message (a `FecheckError`) or type and message."""
    text = str(err) if isinstance(err, FecheckError) else f"{type(err).__name__}: {err}"
    return " ".join(text.split())


def _run_point(scene: Scene, override: str | Sequence[str], warm_start=None) -> RunResult:
    """Solve `scene` with one override (or several: a population's sample), from
    `warm_start` (5,) if given."""
    from fecheck.model.run import run_scene

    overrides = [override] if isinstance(override, str) else list(override)
    return run_scene(apply_overrides(scene, overrides), warm_start)


def _solve_here(scene: Scene, override: str | Sequence[str], value: float,
                warm_start=None) -> SweepPoint:
    """Solve one point in this process (retried from the scene's start if it stalls)."""
    try:
        result = _run_point(scene, override, warm_start)
        if not result.converged and warm_start is not None:
            result = _run_point(scene, override)
    except Exception as err:
        return SweepPoint(value, None, describe_error(err))
    return SweepPoint(value, result)


def _solve_reusing(memo: dict, scene: Scene, override: str | Sequence[str], value: float,
                   warm_start=None) -> SweepPoint:
    """`_solve_here` reusing the model parts built for earlier points (`memo`, see
    `reusing_builds`); after a failed point they are dropped, so that the next point
    starts from fresh parts."""
    with reusing_builds(memo):
        point = _solve_here(scene, override, value, warm_start)
    if point.failed:
        memo.clear()
    return point


_worker = threading.local()
"""A worker thread's sweep (``sweep_id``), its built parts (``memo``, `reusing_builds`)
and the equilibrium q (5,) of the last point it solved (``q``)."""


def solve_on_worker(scene: Scene, override: str | Sequence[str], value: float, label: str,
                     sweep_id: str) -> SweepPoint:
    """Solve one point on a pool or Dask worker; an error names the point and worker.

    The point starts from the equilibrium of the last point this worker solved in the
    same sweep: the points are handed out in value order, so a worker's points are near
    each other, as the serial sweep's are (a start that stalls is retried from the
    scene's start, and the equilibrium does not depend on the start). The model parts it
    built for them are reused where the point's value does not change them.
    """
    if getattr(_worker, "sweep_id", None) != sweep_id:
        _worker.sweep_id, _worker.memo, _worker.q = sweep_id, {}, None
    point = _solve_reusing(_worker.memo, scene, override, value, _worker.q)
    if not point.failed:
        _worker.q = point.result.pose.q
        return point
    where = f"worker {socket.gethostname()} pid {os.getpid()}"
    return SweepPoint(value, None, f"{label} failed on {where}: {point.error}")


def _is_terminal(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError, OSError):
        return False


class Progress:
    """A sweep's progress on `stream` (default stderr): on a terminal a bar redrawn in
    place (``\r``); otherwise (a redirected log) a plain line ``sweep: done/total points``
    at the start, at most every `every_s` seconds, and at the end."""

    def __init__(self, total: int, stream=None, every_s: float = PLAIN_PROGRESS_S):
        self.stream = sys.stderr if stream is None else stream
        self.total, self.every_s = total, every_s
        self.terminal = _is_terminal(self.stream)
        self._last = -math.inf

    def show(self, done: int) -> None:
        """Say that `done` of the points are finished."""
        if self.terminal:
            width = 30
            filled = width * done // self.total
            self.stream.write(f"\rsweep [{'#' * filled}{'.' * (width - filled)}] "
                              f"{done}/{self.total}" + ("\n" if done == self.total else ""))
        elif done == self.total or time.monotonic() - self._last >= self.every_s:
            self._last = time.monotonic()
            self.stream.write(f"sweep: {done}/{self.total} points\n")
        self.stream.flush()

    def end(self, done: int) -> None:
        """End a bar left unfinished (an interrupted or failed sweep)."""
        if self.terminal and done < self.total:
            self.stream.write("\n")
            self.stream.flush()


class _Finished:
    """The finished points of a sweep: progress (`Progress`) and `on_point` after each."""

    def __init__(self, total: int, progress: bool,
                 on_point: Callable[[list[SweepPoint]], None] | None):
        self.total = total
        self._progress = Progress(total) if progress else None
        self._on_point = on_point
        self._points: dict[int, SweepPoint] = {}
        if self._progress is not None:
            self._progress.show(0)

    def add(self, index: int, point: SweepPoint) -> None:
        """Record the point of value number `index`."""
        self._points[index] = point
        if self._progress is not None:
            self._progress.show(len(self._points))
        if self._on_point is not None:
            self._on_point(self.points())

    def points(self) -> list[SweepPoint]:
        """The finished points in value order."""
        return [self._points[i] for i in sorted(self._points)]

    def end_line(self) -> None:
        """End an unfinished progress bar's line."""
        if self._progress is not None:
            self._progress.end(len(self._points))


def _run_serial(scene: Scene, values: Sequence[float], overrides: Sequence[str],
                finished: _Finished, fail_fast: bool) -> None:
    """Solve the points in order, each warm-started from the previous equilibrium, the
    model parts that the swept value does not change built once (`reusing_builds`)."""
    warm = None
    memo: dict = {}
    for i, (value, override) in enumerate(zip(values, overrides, strict=True)):
        point = _solve_reusing(memo, scene, override, value, warm)
        rearm_handlers()
        raise_pending_interrupt()
        warm = None if point.failed else point.result.pose.q
        finished.add(i, point)
        if fail_fast and point.failed:
            return


def finished_futures(futures: Sequence[Future]) -> Iterator[Future]:
    """The futures as they finish; the main thread wakes every `_POLL_S` for signals.

    Each future reports itself once, when it finishes (`concurrent.futures.wait` would
    watch every pending future again at each call: 1 ms per point in a 1,000-point
    sweep)."""
    finished: queue.SimpleQueue[Future] = queue.SimpleQueue()
    for future in futures:
        future.add_done_callback(finished.put)
    left = len(futures)
    while left:
        try:
            future = finished.get(timeout=_POLL_S)
        except queue.Empty:
            continue
        left -= 1
        yield future


def _collect(future: Future, value: float, label: str) -> SweepPoint:
    """A finished future's point; an error raised around the worker call is recorded."""
    try:
        return future.result()
    except Exception as err:
        return SweepPoint(value, None, f"{label} failed on a worker: {describe_error(err)}")


def _run_on(executor: Executor, scene: Scene, param: str, values: Sequence[float],
            overrides: Sequence[str], finished: _Finished, fail_fast: bool) -> bool:
    """Submit every point to `executor` and collect them as they finish.

    Returns True when every point finished, False when `fail_fast` stopped the sweep.
    On any early exit, the futures not yet started are cancelled.
    """
    labels = [_label(param, v) for v in values]
    sweep_id = uuid.uuid4().hex
    futures: dict[Future, int] = {}
    complete = False
    try:
        with interrupts_held():
            for i, (value, override) in enumerate(zip(values, overrides, strict=True)):
                future = executor.submit(solve_on_worker, scene, override, value, labels[i],
                                         sweep_id)
                futures[future] = i
        for future in finished_futures(list(futures)):
            i = futures[future]
            point = _collect(future, values[i], labels[i])
            finished.add(i, point)
            if fail_fast and point.failed:
                return False
        complete = True
        return True
    finally:
        if not complete:
            with interrupts_ignored():
                for future in futures:
                    future.cancel()


def _run_pool(workers: int, scene: Scene, param: str, values: Sequence[float],
              overrides: Sequence[str], finished: _Finished, fail_fast: bool) -> None:
    """Run the points on a local pool of `workers` processes, terminated on any early
    exit (its queued points cancelled, its running points abandoned)."""
    pool = ProcessPool(workers)
    complete = False
    try:
        complete = _run_on(pool, scene, param, values, overrides, finished, fail_fast)
    finally:
        with interrupts_ignored():
            if complete:
                pool.shutdown()
            else:
                pool.terminate()


def reads_files(scene: Scene) -> bool:
    """True when solving `scene` reads its ``[geometry]`` files."""
    return scene["model.kind"] in SCANNED_KINDS or scene["scanned.ligaments"] != "none"


def pin_geometry_dir(scene: Scene) -> Scene:
    """`scene` with ``geometry.dir`` made absolute, for workers: a worker elsewhere (Dask)
    may run in another folder, where a path relative to the scene file's folder, or to
    this process's working folder, would not resolve. Scenes that read no file, or read
    a data set packaged with fecheck (found wherever fecheck is installed), are returned
    as they are."""
    if not reads_files(scene) or scene["geometry.dir"].startswith(PACKAGE_PREFIX):
        return scene
    return with_values(scene, geometry__dir=str(base_dir(scene)))


def run_sweep(scene: Scene, param: str, values: Sequence[float], *, workers: int = 1,
              executor: Executor | None = None, progress: bool = True,
              fail_fast: bool = False,
              on_point: Callable[[list[SweepPoint]], None] | None = None
              ) -> list[SweepPoint]:
    """Solve `scene` for each value of `param`.

    Parameters
    ----------
    scene, param, values
        The scene, the swept key (``key`` or ``key[i]``) and its values (key's units).
    workers
        1 and no `executor`: serial, each point warm-started from the previous one.
        More: the points run on a new local pool of `workers` processes.
    executor
        Run the points on this executor (threads, Dask); the caller
        owns it.
    progress
        Show the progress on stderr (`Progress`: a bar on a terminal, else plain lines).
    fail_fast
        Stop at the first failing point (the points not yet run are left out).
    on_point
        Called after each finished point with the finished points, in value order.

    Returns
    -------
    list of SweepPoint
        The finished points in value order; a failed point carries its error.

    Raises
    ------
    FecheckError
        A value the scene does not accept (before any solve).
    SweepInterrupted
        On KeyboardInterrupt: the queued points are cancelled, the local pool's
        workers terminated; it carries the finished points.
    """
    overrides = sweep_overrides(scene, param, values)
    finished = _Finished(len(values), progress, on_point)
    try:
        if executor is None and workers <= 1:
            _run_serial(scene, values, overrides, finished, fail_fast)
        elif executor is None:
            _run_pool(workers, pin_geometry_dir(scene), param, values, overrides, finished,
                      fail_fast)
        else:
            _run_on(executor, pin_geometry_dir(scene), param, values, overrides, finished,
                    fail_fast)
    except KeyboardInterrupt:
        finished.end_line()
        raise SweepInterrupted(finished.points(), len(values)) from None
    finished.end_line()
    return finished.points()


@contextmanager
def dask_executor(address: str) -> Iterator[Executor]:
    """A `concurrent.futures` executor on the Dask cluster at `address` (fecheck[dask]).

    The client is closed when the block ends (its unfinished futures cancelled).

    Raises
    ------
    FecheckError
        Without Dask, or when no scheduler answers at `address`.
    """
    try:
        from dask.distributed import Client
    except ImportError:
        raise FecheckError("--scheduler needs Dask: pip install 'fecheck[dask]'") from None
    try:
        client = Client(address)
    except Exception as err:
        raise FecheckError(f"--scheduler {address!r}: cannot reach a Dask scheduler there "
                           f"({describe_error(err)})") from None
    try:
        yield client.get_executor()
    finally:
        with interrupts_ignored():
            client.close(timeout=2 * KILL_WAIT_S)


def rows(points: Sequence[SweepPoint], param: str) -> list[dict[str, Any]]:
    """Flat CSV rows: the swept value, `RunResult.flat_row()`, then the point's error."""
    out = []
    for p in points:
        solved = {} if p.failed else p.result.flat_row()
        out.append({param: p.value, "converged": False, **solved, "error": p.error})
    return out


def csv_text(points: Sequence[SweepPoint], param: str) -> str:
    """The sweep as CSV text: one row per finished point, columns of every row."""
    table = rows(points, param)
    columns = [param, "converged"]
    for row in table:
        columns += [c for c in row if c not in columns and c != "error"]
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=[*columns, "error"], restval="")
    writer.writeheader()
    writer.writerows(table)
    return buffer.getvalue()


def write_csv(points: Sequence[SweepPoint], param: str, path: str | Path) -> None:
    """Write the sweep as CSV (one row per finished point), atomically; ``-`` = stdout."""
    write_text(path, csv_text(points, param))


def write_plots(points: Sequence[SweepPoint], param: str, directory: str | Path
                ) -> list[Path]:
    """PNG plots of compartment forces and max pressures against the swept value
    (failed points left out; no plots when none was solved)."""
    solved = [p for p in points if not p.failed]
    if not solved:
        return []
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(directory)
    x = [p.value for p in solved]
    paths = []
    metrics: list[tuple[str, str, Callable]] = [
        ("force_N", "compartment force (N)", lambda c: c.force_N),
        ("max_pressure_MPa", "max pressure (MPa)", lambda c: c.max_pressure_MPa)]
    for name, label, get in metrics:
        fig, ax = plt.subplots(figsize=(6, 4))
        for comp in solved[0].result.compartments:
            ax.plot(x, [get(p.result.compartments[comp]) for p in solved], "o-", label=comp)
        ax.set_xlabel(param)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
        ax.legend()
        fig.tight_layout()
        path = out / f"sweep_{name}.png"
        write_output(path, lambda tmp, fig=fig: fig.savefig(tmp, dpi=120))
        plt.close(fig)
        paths.append(path)
    return paths
