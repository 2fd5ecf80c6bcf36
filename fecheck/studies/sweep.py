"""Parameter sweeps: one scene solved for a list of values of one key.

Serial sweeps warm-start each point from its neighbour's equilibrium; parallel sweeps
send independent points to a `concurrent.futures` executor — a local process pool, or
a Dask distributed cluster's executor (``fecheck[dask]``) through the same code path.
The thesis's load-point sweeps (Figs. 5.2/5.6/5.8: ``load.point_mm[0]`` from −8 to +8
mm around the reference) and material sweeps (Tables 5.4, 5.5) are sweeps of scenes.

>>> parse_values("-8:8:5")
[-8.0, -4.0, 0.0, 4.0, 8.0]
"""

from __future__ import annotations

import re
import sys
from collections.abc import Callable, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fecheck.errors import FecheckError
from fecheck.model.results import RunResult, write_rows
from fecheck.scene import SCHEMA, Scene, apply_overrides

_INDEXED = re.compile(r"^(?P<key>[\w.]+)\[(?P<index>\d+)\]$")


def parse_values(text: str) -> list[float]:
    """``"A:B:N"`` → N evenly spaced values from A to B; ``"a,b,c"`` → those values."""
    try:
        if ":" in text:
            a, b, n = text.split(":")
            if int(n) < 1:
                raise ValueError
            return [float(v) for v in np.linspace(float(a), float(b), int(n))]
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise FecheckError(f"--values {text!r}: expected START:STOP:COUNT (e.g. -8:8:17) or "
                           f"a comma list (e.g. 0.15,0.3,0.45)") from None
    if not values or not all(np.isfinite(values)):
        raise FecheckError(f"--values {text!r}: give finite numbers")
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


@dataclass(frozen=True)
class SweepPoint:
    """One swept value and its result."""

    value: float
    result: RunResult


def _run_point(scene: Scene, override: str, warm_start=None) -> RunResult:
    from fecheck.model.run import run_scene

    return run_scene(apply_overrides(scene, [override]), warm_start)


def _progress(show: bool, done: int, total: int) -> None:
    if not show:
        return
    stream = sys.stderr
    width = 30
    filled = width * done // total
    stream.write(f"\rsweep [{'#' * filled}{'.' * (width - filled)}] {done}/{total}")
    if done == total:
        stream.write("\n")
    stream.flush()


def run_sweep(scene: Scene, param: str, values: Sequence[float], *, workers: int = 1,
              executor: Executor | None = None, progress: bool = True
              ) -> list[SweepPoint]:
    """Solve `scene` for each value of `param`.

    workers = 1 and no executor: serial, each point warm-started from the previous one.
    Otherwise the points run independently on `executor` (or a new process pool of
    `workers` processes). `progress` draws a text bar on stderr.
    """
    overrides = [override_for(scene, param, v) for v in values]
    total = len(values)
    results: list[RunResult] = []
    _progress(progress, 0, total)
    if executor is None and workers <= 1:
        warm = None
        for i, override in enumerate(overrides):
            result = _run_point(scene, override, warm)
            if not result.converged:
                result = _run_point(scene, override)      # retry from the scene's start
            warm = result.extra.get("q")
            results.append(result)
            _progress(progress, i + 1, total)
        return [SweepPoint(v, r) for v, r in zip(values, results, strict=True)]
    owned = executor is None
    if owned:
        from concurrent.futures import ProcessPoolExecutor

        executor = ProcessPoolExecutor(max_workers=workers)
    try:
        futures = [executor.submit(_run_point, scene, o) for o in overrides]
        for i, future in enumerate(futures):
            results.append(future.result())
            _progress(progress, i + 1, total)
    finally:
        if owned:
            executor.shutdown()
    return [SweepPoint(v, r) for v, r in zip(values, results, strict=True)]


def dask_executor(address: str) -> Executor:
    """A `concurrent.futures` executor on the Dask cluster at `address` (fecheck[dask])."""
    try:
        from dask.distributed import Client
    except ImportError:
        raise FecheckError("--scheduler needs Dask: pip install 'fecheck[dask]'") from None
    try:
        return Client(address).get_executor()
    except OSError as err:
        raise FecheckError(f"cannot reach the Dask scheduler at {address}: {err}") from None


def rows(points: Sequence[SweepPoint], param: str) -> list[dict[str, Any]]:
    """Flat CSV rows: the swept value, then `RunResult.flat_row()`."""
    return [{param: p.value, **p.result.flat_row()} for p in points]


def write_csv(points: Sequence[SweepPoint], param: str, path: str | Path) -> None:
    """Write the sweep as CSV (one row per value)."""
    write_rows(path, rows(points, param))


def write_plots(points: Sequence[SweepPoint], param: str, directory: str | Path
                ) -> list[Path]:
    """PNG plots of compartment forces and max pressures against the swept value."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    x = [p.value for p in points]
    paths = []
    metrics: list[tuple[str, str, Callable]] = [
        ("force_N", "compartment force (N)", lambda c: c.force_N),
        ("max_pressure_MPa", "max pressure (MPa)", lambda c: c.max_pressure_MPa)]
    for name, label, get in metrics:
        fig, ax = plt.subplots(figsize=(6, 4))
        for comp in points[0].result.compartments:
            ax.plot(x, [get(p.result.compartments[comp]) for p in points], "o-", label=comp)
        ax.set_xlabel(param)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
        ax.legend()
        fig.tight_layout()
        path = out / f"sweep_{name}.png"
        fig.savefig(path, dpi=120)
        plt.close(fig)
        paths.append(path)
    return paths
