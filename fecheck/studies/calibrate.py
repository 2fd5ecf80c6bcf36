"""Calibrate the EF on a scene's own FE (`fecheck calibrate`).

The FE cross-check (`fecheck.fe.knee.crosscheck.cross_check`, the scene's mode) is solved at a
few loads; then the calibrated law's C and n of each compartment
(`fecheck.laws.calibrated`) are fitted, by least squares on the logs, so that the EF
equilibrium of the scene with that law reproduces the FE's contact area and peak
pressure of each compartment and its share of the load at every one of those loads
(each EF equilibrium warm-started from the last). The fit quality is reported per load
against the FE, beside the linear EF's; a fit worse than `FIT_TOLERANCE` or an exponent
on its bound is warned about. The file records the fingerprint of the scene's surfaces
and material (`fecheck.model.fingerprint`), so that a scene it was not made for is warned
about when it reads the file. Units: mm, N, MPa.
"""

from __future__ import annotations

import math
import tempfile
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fecheck.errors import FecheckError
from fecheck.laws import calibrated
from fecheck.laws.calibrated import Calibration
from fecheck.laws.materials import ef_stiffness
from fecheck.scene import Scene, with_values
from fecheck.scene.constants import COMPARTMENTS
from fecheck.scene.provenance import provenance

LOAD_FACTORS = (0.6, 1.0, 1.4)
"""Loads calibrated at by default, as multiples of the scene's load.force_N."""
SPLIT_WEIGHT = 5.0
"""Weight of a compartment's load-share residual beside the log residuals of its area and
peak pressure (a 1 % share error counts as a 5 % area error)."""
QUANTITIES = ("area_mm2", "max_pressure_MPa")
FIT_TOLERANCE = 0.10
"""Largest error of the calibrated EF against the FE (area and p_max relative, the load
share absolute: 0.10 = 10 points) before `calibrate` warns."""
BOUND_TOLERANCE = 1e-3
"""An exponent within this of an end of `calibrated.EXPONENT_RANGE` sits on its bound."""


@dataclass(frozen=True)
class Answer:
    """Per compartment: force (N), area (mm²), peak pressure (MPa); and the load share."""

    values: dict[str, dict[str, float]]

    def share(self, c: str) -> float:
        total = sum(v["force_N"] for v in self.values.values())
        return self.values[c]["force_N"] / total if total > 0 else math.nan


@dataclass(frozen=True)
class CalibrationFit:
    """Fitted parameters, the FE answers they were fitted to, and the EF answers (linear
    and calibrated) at the same loads."""

    parameters: dict[str, Calibration]
    loads_N: list[float]
    fe: list[Answer]
    linear: list[Answer]
    fitted: list[Answer]
    seconds: dict[str, float]
    fingerprint: str = ""

    def errors(self, which: str) -> list[dict[str, float]]:
        """Relative errors against the FE per load: area, p_max per compartment, and the
        load share (absolute, in share points) of `which` ("linear" or "fitted")."""
        out = []
        for fe, ef in zip(self.fe, getattr(self, which), strict=True):
            row = {}
            for c in COMPARTMENTS:
                for q in QUANTITIES:
                    row[f"{c}_{q}"] = ef.values[c][q] / fe.values[c][q] - 1.0
                row[f"{c}_share"] = ef.share(c) - fe.share(c)
            out.append(row)
        return out


def _ef_answer(result) -> Answer:
    return Answer({c: {"force_N": r.force_N, "area_mm2": r.area_mm2,
                       "max_pressure_MPa": r.max_pressure_MPa}
                   for c, r in result.compartments.items()})


def fe_answers(scene: Scene, loads_N: Sequence[float],
               log: Callable[[str], None]) -> list[Answer]:
    """The FE cross-check's answer at each load (the scene's FE mode and mesh)."""
    from fecheck.fe.knee.crosscheck import cross_check

    out = []
    for load in loads_N:
        log(f"calibrate: FE at {load:g} N")
        check = cross_check(with_values(scene, load__force_N=float(load)), log=None)
        out.append(Answer({c: {"force_N": chk.fe.force_N, "area_mm2": chk.fe.area_mm2,
                               "max_pressure_MPa": chk.fe.max_pressure_MPa}
                           for c, chk in check.compartments.items()}))
    return out


class _EFRuns:
    """EF equilibria of the scene at the calibration loads for given law parameters
    (through a calibration file in a temporary folder), warm-started."""

    def __init__(self, scene: Scene, loads_N: Sequence[float], folder: Path,
                 fingerprint: str = ""):
        self.scene, self.loads, self.path = scene, list(loads_N), folder / "calibration.json"
        self.start: list[np.ndarray | None] = [None] * len(self.loads)
        self.count = 0
        self.info = {"fingerprint": fingerprint} if fingerprint else {}

    def __call__(self, parameters: dict[str, Calibration]) -> list[Answer]:
        from fecheck.model.run import run_scene

        calibrated.write_calibration(self.path, parameters, self.info)
        out = []
        for i, load in enumerate(self.loads):
            s = with_values(self.scene, contact__law="ef-calibrated",
                            contact__calibration=str(self.path), load__force_N=float(load))
            result = run_scene(s, self.start[i])
            self.count += 1
            if not result.converged:
                raise FecheckError(f"calibrate: the calibrated EF did not converge at {load:g} N")
            self.start[i] = np.asarray(result.pose.q, dtype=float)
            out.append(_ef_answer(result))
        return out


def _unpack(x: np.ndarray) -> dict[str, Calibration]:
    return {c: Calibration(float(math.exp(x[2 * i])), float(x[2 * i + 1]))
            for i, c in enumerate(COMPARTMENTS)}


def _residuals(answers: list[Answer], fe: list[Answer]) -> np.ndarray:
    r = []
    for ef, ref in zip(answers, fe, strict=True):
        for c in COMPARTMENTS:
            r += [math.log(ef.values[c][q] / ref.values[c][q]) for q in QUANTITIES]
            r.append(SPLIT_WEIGHT * (ef.share(c) - ref.share(c)))
    return np.asarray(r)


def calibration_loads(scene: Scene, load_factors: Sequence[float]) -> list[float]:
    """The loads (N) a calibration fits at: `load_factors` × load.force_N, each checked."""
    if not scene["load.force_N"] > 0:
        raise FecheckError("calibrate: the scene has no load (load.force_N = 0)")
    if not load_factors or not all(math.isfinite(f) and f > 0 for f in load_factors):
        raise FecheckError(f"calibrate: the load factors must be positive numbers (multiples "
                           f"of load.force_N), got {list(load_factors)}")
    return [f * scene["load.force_N"] for f in load_factors]


def calibrate(scene: Scene, load_factors: Sequence[float] = LOAD_FACTORS,
              log: Callable[[str], None] = lambda s: None) -> CalibrationFit:
    """Fit the calibrated EF of `scene` to its FE at `load_factors` × load.force_N."""
    from scipy.optimize import least_squares

    from fecheck.model.fingerprint import scene_fingerprint
    from fecheck.model.run import run_scene

    loads = calibration_loads(scene, load_factors)
    t0 = time.perf_counter()
    fe = fe_answers(scene, loads, log)
    t1 = time.perf_counter()
    linear_scene = with_values(scene, contact__law="ef")
    linear = [_ef_answer(run_scene(with_values(linear_scene, load__force_N=float(f))))
              for f in loads]
    k = ef_stiffness(scene["contact.youngs_MPa"], scene["contact.poisson"],
                     scene["contact.thickness_mm"])
    x0 = np.array([math.log(k), 1.0] * len(COMPARTMENTS))
    lo, hi = calibrated.EXPONENT_RANGE
    bounds = ([-np.inf, lo] * len(COMPARTMENTS), [np.inf, hi] * len(COMPARTMENTS))
    fingerprint = scene_fingerprint(scene)
    with tempfile.TemporaryDirectory() as folder:
        runs = _EFRuns(scene, loads, Path(folder), fingerprint)

        def residuals(x: np.ndarray) -> np.ndarray:
            return _residuals(runs(_unpack(x)), fe)

        log(f"calibrate: fitting C and n per compartment to the FE at {len(loads)} loads")
        fit = least_squares(residuals, x0, bounds=bounds, diff_step=1e-4, x_scale=1.0,
                            xtol=1e-6, ftol=1e-8, max_nfev=60)
        parameters = _unpack(fit.x)
        fitted = runs(parameters)
        log(f"calibrate: {runs.count} EF equilibria")
    t2 = time.perf_counter()
    out = CalibrationFit(parameters, loads, fe, linear, fitted,
                         {"fe": t1 - t0, "fit": t2 - t1}, fingerprint)
    for message in fit_warnings(out, str(scene.source)):
        warnings.warn(message, stacklevel=2)
    return out


def fit_warnings(fit: CalibrationFit, scene_name: str) -> list[str]:
    """One line per compartment whose exponent sits on its bound, and one for the worst
    error of the calibrated EF against the FE when it exceeds `FIT_TOLERANCE`."""
    out = []
    lo, hi = calibrated.EXPONENT_RANGE
    for c, p in fit.parameters.items():
        if min(abs(p.n - lo), abs(p.n - hi)) <= BOUND_TOLERANCE:
            out.append(f"calibrate {scene_name}: the {c} exponent n = {p.n:.4g} sits on its "
                       f"bound ({lo:g} <= n <= {hi:g}): the law p = C·d·(d + d_s)^(n−1) "
                       "cannot follow this FE; check the FE (fecheck fe SCENE --plot DIR) "
                       "and keep the linear EF (contact.law = 'ef') if it holds")
    worst, load, name = max((abs(v), load, name) for load, row in
                            zip(fit.loads_N, fit.errors("fitted"), strict=True)
                            for name, v in row.items())
    if worst > FIT_TOLERANCE:
        c, _, what = name.partition("_")
        unit = " points of the load share" if what == "share" else " %"
        what = {"area_mm2": "area", "max_pressure_MPa": "p_max", "share": "load share"}[what]
        out.append(f"calibrate {scene_name}: the calibrated EF misses the FE by up to "
                   f"{100 * worst:.1f}{unit} ({c} {what} at {load:g} N; more than "
                   f"{100 * FIT_TOLERANCE:g}{unit}): do not use it as a stand-in for the "
                   "FE on this scene; check the FE (fecheck fe SCENE --plot DIR) or "
                   "calibrate at the loads you will run (--loads)")
    return out


def write(fit: CalibrationFit, scene: Scene, path: str | Path) -> Path:
    """The calibration file of `fit` (contact.calibration reads it)."""
    info = {"scene": scene.label, "fe_mode": scene["fe.mode"],
            "fingerprint": fit.fingerprint, "loads_N": fit.loads_N,
            "fe": [a.values for a in fit.fe],
            "errors": {"linear_ef": fit.errors("linear"), "calibrated_ef": fit.errors("fitted")},
            "seconds": fit.seconds, "provenance": provenance(scene)}
    return calibrated.write_calibration(path, fit.parameters, info)


def report(fit: CalibrationFit) -> str:
    """The fit quality as a table: per load and compartment, FE area and p_max, and the
    linear and calibrated EF's errors on them and on the load share."""
    lines = [f"{'load N':>8} {'':8} {'FE area':>8} {'FE p_max':>8} | "
             f"{'EF linear: area':>15} {'p_max':>7} {'share':>7} | "
             f"{'calibrated: area':>16} {'p_max':>7} {'share':>7}"]
    lin, cal = fit.errors("linear"), fit.errors("fitted")
    for i, (load, fe) in enumerate(zip(fit.loads_N, fit.fe, strict=True)):
        for c in COMPARTMENTS:
            v = fe.values[c]
            cells = [f"{100 * e[f'{c}_{q}']:+6.1f}%" for e in (lin[i], cal[i])
                     for q in (*QUANTITIES, "share")]
            lines.append(f"{load:8.1f} {c:8} {v['area_mm2']:8.1f} {v['max_pressure_MPa']:8.3f} | "
                         f"{cells[0]:>15} {cells[1]:>7} {cells[2]:>7} | "
                         f"{cells[3]:>16} {cells[4]:>7} {cells[5]:>7}")
    for c, p in fit.parameters.items():
        lines.append(f"{c}: p = {p.C:.4g} · d · (d + {calibrated.SOFT_DEPTH_MM:g})^({p.n:.4f} - 1)"
                     f" MPa (d in mm)")
    lines.append("share errors are in points of the load share (EF share - FE share)")
    return "\n".join(lines)
