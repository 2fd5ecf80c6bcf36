"""Where the EF can be trusted: an error model of the EF against the FE over some keys.

The EF runs at many samples of the varied keys (a population, `fecheck.studies.
population`); the FE (`fecheck.fe.knee.crosscheck.cross_check`, the scene's own `fecheck fe`)
runs at a few design points: first a space-filling set (a scrambled Sobol sequence of
its own), then, one batch at a time, the EF samples where the error model is least sure
(largest predictive standard deviation). The error model is one Gaussian process per
output (scikit-learn's `GaussianProcessRegressor`, an anisotropic RBF kernel plus noise,
on the unit-cube coordinates of the keys), cross-validated by k-fold; its stated error is
the cross-validated root-mean-square error.

Outputs (EF against FE, per design point): ``p_max`` and ``area``, the EF's relative
error of the larger compartment peak pressure and of the summed contact area
(EF / FE − 1); ``split``, the EF's medial share minus the FE's; ``cop_mm``, the larger
compartment distance between the EF and FE centres of pressure; and for a scene with the
linear EF, the same three of the calibrated EF (``contact.law = 'ef-calibrated'``) at the
same point, ``p_max_cal``, ``area_cal``, ``split_cal``. The EF is "within the
tolerance" where the predicted |p_max|, |area| and |split| errors all are.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass

import numpy as np

from fecheck.errors import FecheckError
from fecheck.laws.registry import law_spec, spec_of
from fecheck.model.run import run_scene
from fecheck.scene import Scene, apply_overrides
from fecheck.studies import sobol
from fecheck.studies.population_inputs import Varied, overrides_for

LINEAR = ("p_max", "area", "split")
CALIBRATED = ("p_max_cal", "area_cal", "split_cal")
OUTPUTS = (*LINEAR, "cop_mm", *CALIBRATED)
TOLERANCED = LINEAR
"""The outputs the tolerance applies to (dimensionless; the linear EF's, and the calibrated
EF's with `CALIBRATED`); ``cop_mm`` is reported in mm."""
FOLDS = 5


def fe_errors(scene: Scene, overrides: Sequence[str]) -> dict[str, float]:
    """The EF's errors against the FE at one point (module docstring), the FE's time."""
    import time

    from fecheck.fe.knee.crosscheck import cross_check

    start = time.perf_counter()
    check = cross_check(apply_overrides(scene, list(overrides)), log=None)
    comps = check.compartments
    fe_peak = max(c.fe.max_pressure_MPa for c in comps.values())
    ef_peak = max(c.ef_model.max_pressure_MPa for c in comps.values())
    fe_area = sum(c.fe.area_mm2 for c in comps.values())
    ef_area = sum(c.ef_model.area_mm2 for c in comps.values())
    split_fe, split_ef = check.split("fe"), check.split("ef_model")
    first = next(iter(comps))
    cop = [c.cop_distance_mm for c in comps.values()]
    out = {"p_max": ef_peak / fe_peak - 1.0, "area": ef_area / fe_area - 1.0,
           "split": split_ef[first] - split_fe[first],
           "cop_mm": float(np.nanmax(cop)) if np.isfinite(cop).any() else math.nan,
           "fe_s": time.perf_counter() - start}
    cal = calibrated_run(scene, overrides)
    if cal is None:
        return out | dict.fromkeys(CALIBRATED, math.nan)
    forces = {c: r.force_N for c, r in cal.compartments.items()}
    return out | {
        "p_max_cal": max(r.max_pressure_MPa for r in cal.compartments.values()) / fe_peak - 1,
        "area_cal": sum(r.area_mm2 for r in cal.compartments.values()) / fe_area - 1.0,
        "split_cal": forces[first] / sum(forces.values()) - split_fe[first]}


def calibrated_run(scene: Scene, overrides: Sequence[str]):
    """The calibrated EF's run at the point, beside the linear EF's (None when the scene's
    law is not the linear EF, or the calibrated law cannot run it)."""
    if spec_of(scene) is not law_spec("ef"):
        return None
    try:
        return run_scene(apply_overrides(scene, [*overrides, "contact.law='ef-calibrated'"]))
    except FecheckError:
        return None


def fe_on_worker(scene: Scene, overrides: tuple[str, ...], index: int) -> tuple[int, dict | str]:
    """`fe_errors` on a worker: (index, errors) or (index, the one-line failure)."""
    from fecheck.studies.sweep import describe_error

    try:
        return index, fe_errors(scene, overrides)
    except Exception as err:
        return index, describe_error(err)


def run_fe(scene: Scene, overrides: Sequence[tuple[str, ...]], indices: Sequence[int],
           executor: Executor | None, say: Callable[[str], None]) -> dict[int, dict | str]:
    """The FE at the given points (serially, or on `executor`), index → errors or failure."""
    out: dict[int, dict | str] = {}
    if executor is None:
        for i in indices:
            out[i] = fe_on_worker(scene, overrides[i], i)[1]
            say(_fe_line(i, out[i], len(out), len(indices)))
        return out
    futures = [executor.submit(fe_on_worker, scene, overrides[i], i) for i in indices]
    from fecheck.studies.sweep import finished_futures

    for future in finished_futures(futures):
        i, result = future.result()
        out[i] = result
        say(_fe_line(i, result, len(out), len(indices)))
    return out


def _fe_line(i: int, result: dict | str, done: int, total: int) -> str:
    if isinstance(result, str):
        return f"FE {done}/{total} at point {i}: failed: {result}"
    cal = ("" if not math.isfinite(result["p_max_cal"]) else
           f"; calibrated EF p_max {result['p_max_cal']:+.3f}, area {result['area_cal']:+.3f}")
    return (f"FE {done}/{total} at point {i}: EF p_max {result['p_max']:+.3f}, area "
            f"{result['area']:+.3f}, split {result['split']:+.4f}, CoP "
            f"{result['cop_mm']:.2f} mm{cal} ({result['fe_s']:.0f} s)")


@dataclass
class ErrorModel:
    """One Gaussian process per output on unit-cube inputs, and its cross-validated
    root-mean-square error (`cv_rmse`, the output's units)."""

    models: dict
    cv_rmse: dict[str, float]
    n_points: int

    def predict(self, u: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """{output: (mean, standard deviation)} at unit-cube points `u` (n, d)."""
        return {k: tuple(m.predict(u, return_std=True)) for k, m in self.models.items()}


def _gp(d: int, seed: int, restarts: int = 2):
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

    kernel = (ConstantKernel(1.0, (1e-3, 1e3)) * RBF(np.full(d, 0.5), (0.05, 20.0))
              + WhiteKernel(1e-4, (1e-8, 1e-1)))
    return GaussianProcessRegressor(kernel, normalize_y=True, n_restarts_optimizer=restarts,
                                    random_state=seed)


def fit_error_model(u: np.ndarray, errors: dict[str, np.ndarray], seed: int = 0,
                    cross_validate: bool = True) -> ErrorModel:
    """Fit one GP per output to the FE design points `u` (n, d) and their `errors`; the
    k-fold (`FOLDS`, or leave-one-out below that many points) cross-validated RMSE (the
    folds' processes fitted from one start, the final one from three); without
    `cross_validate` (while a design grows) the RMSEs are NaN.

    Raises
    ------
    FecheckError
        With fewer than 3 solved design points.
    """
    import warnings

    from sklearn.exceptions import ConvergenceWarning
    from sklearn.model_selection import KFold

    n, d = u.shape
    if n < 3:
        raise FecheckError(f"only {n} FE design points were solved: the error model needs 3")
    models, cv = {}, {}
    folds = KFold(min(FOLDS, n), shuffle=True, random_state=seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        for name, y in errors.items():
            ok = np.isfinite(y)
            if ok.sum() < 3:
                continue
            residuals = []
            for train, test in folds.split(u) if cross_validate else ():
                train, test = train[ok[train]], test[ok[test]]
                if train.size < 2 or test.size == 0:
                    continue
                gp = _gp(d, seed, restarts=0).fit(u[train], y[train])
                residuals.append(gp.predict(u[test]) - y[test])
            res = np.concatenate(residuals) if residuals else np.array([math.nan])
            cv[name] = float(np.sqrt(np.mean(res**2)))
            models[name] = _gp(d, seed).fit(u[ok], y[ok])
    return ErrorModel(models, cv, n)


def initial_design(n: int, d: int, seed: int) -> np.ndarray:
    """`n` space-filling points of the unit cube (a scrambled Sobol sequence, seeded
    apart from the EF samples')."""
    return sobol.base_matrix(n, d, "sobol", seed + 7919)


def least_sure(model: ErrorModel, candidates: np.ndarray, taken: np.ndarray, k: int
               ) -> np.ndarray:
    """The `k` candidate rows with the largest summed predictive deviation over the
    toleranced outputs (each over the spread of its predicted means), each at least 0.05
    (unit-cube distance) from the taken points and from each other."""
    pred = model.predict(candidates)
    score = sum(pred[o][1] / np.std(pred[o][0]) if np.std(pred[o][0]) > 0 else pred[o][1]
                for o in TOLERANCED if o in pred)
    order = np.argsort(-score)
    chosen: list[int] = []
    for i in order:
        near = np.vstack([taken, candidates[chosen]]) if chosen else taken
        if near.size and np.min(np.linalg.norm(near - candidates[i], axis=1)) < 0.05:
            continue
        chosen.append(int(i))
        if len(chosen) == k:
            break
    return np.array(chosen, dtype=int)


def within(pred: dict[str, tuple[np.ndarray, np.ndarray]], tolerance: float,
           outputs: Sequence[str] = TOLERANCED) -> np.ndarray:
    """(n,) True where every one of `outputs`' predicted |error| is within `tolerance`."""
    ok = None
    for name in outputs:
        inside = np.abs(pred[name][0]) <= tolerance
        ok = inside if ok is None else ok & inside
    return ok


def key_ranges(varied: Sequence[Varied], drawn: np.ndarray, inside: np.ndarray
               ) -> dict[str, dict[str, float]]:
    """Per key: the range of its drawn values over all samples and over those within the
    tolerance."""
    out = {}
    for j, v in enumerate(varied):
        col = drawn[:, j]
        sel = col[inside]
        out[v.name] = {"low": float(col.min()), "high": float(col.max()),
                       "within_low": float(sel.min()) if sel.size else math.nan,
                       "within_high": float(sel.max()) if sel.size else math.nan,
                       "within_share": float(inside.mean())}
    return out


def partial_dependence(model: ErrorModel, u: np.ndarray, j: int, grid: np.ndarray
                       ) -> dict[str, np.ndarray]:
    """{output: (len(grid),) mean prediction over the samples `u` with column j set to each
    grid value}."""
    out = {}
    for name, gp in model.models.items():
        values = []
        for g in grid:
            w = u.copy()
            w[:, j] = g
            values.append(float(np.mean(gp.predict(w))))
        out[name] = np.array(values)
    return out


def atlas_points(varied: Sequence[Varied], scene: Scene, u: np.ndarray
                 ) -> list[tuple[str, ...]]:
    """The overrides of unit-cube points `u`."""
    return overrides_for(varied, scene, u)
