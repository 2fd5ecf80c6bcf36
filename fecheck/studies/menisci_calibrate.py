"""Calibrate the meniscus EF on the FE of the same knee (`fecheck calibrate` on a scene
with menisci).

The EF knee with menisci (`fecheck.model.menisci`) gives each meniscus two EF interfaces,
femur ↔ meniscus and meniscus ↔ tibia, under one law. Uncalibrated that is the linear EF of
a lumped layer (menisci.youngs_MPa, smith2019's 1 MPa convention), which does not know how
a meniscus's hoop-stiff solid spreads load. The calibration fits, per meniscus, the
calibrated law p = C·d·(d + d_s)^(n − 1) of `fecheck.laws.calibrated` (its C and n) on
those two interfaces so that the EF equilibrium reproduces, at each calibration load, two
outputs of the FE with menisci (`fecheck.fe.knee.knee_menisci.knee_menisci_fe`, the scene's
mesh and ``fe.*`` settings) in that compartment:

* the meniscal share: the load into the tibia through the meniscus (its contact and its
  horn roots) over the compartment's load, weighted by `SPLIT_WEIGHT` as the cartilage
  calibration weighs its load share;
* the tibial contact area under the meniscus (FE: the zero-pressure contours of its
  anterior horn, body and posterior horn regions, summed; EF: the meniscus-tibia
  interface's area), on the log.

Least squares over both compartments at once (the tibia couples them); the cartilage-
cartilage law stays the scene's. The FE is solved once per load at the uncalibrated EF's
pose (the scene with menisci.calibration unset), which is how `fecheck fe` places it.
The EF is built once (`fecheck.model.menisci.build_knee`) and each trial law solved on it,
warm-started from the last answer at that load. Reported beside the FE and the
uncalibrated EF: per compartment the share, the tibial area under the cartilage and under
the meniscus and the p_max of each. Units: mm, N, MPa.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fecheck.errors import FecheckError
from fecheck.fe.knee.knee_menisci import knee_menisci_fe
from fecheck.laws import calibrated
from fecheck.laws.calibrated import MENISCI_INTERFACES, Calibration
from fecheck.model import menisci
from fecheck.scene import Scene, with_values
from fecheck.scene.provenance import provenance
from fecheck.studies.calibrate import FIT_TOLERANCE, SPLIT_WEIGHT, calibration_loads

LOAD_FACTORS = (1.0,)
"""Loads calibrated at by default, as multiples of load.force_N: the scene's load alone,
since one FE with menisci at full size takes minutes."""
QUANTITIES = ("share", "cartilage_area_mm2", "meniscus_area_mm2", "cartilage_p_max_MPa",
              "meniscus_p_max_MPa")
"""The outputs compared per compartment (the first and third are fitted)."""
FITTED = ("share", "meniscus_area_mm2")
"""The outputs the law is fitted to."""
MENISCUS_REGIONS = ("anterior horn", "body", "posterior horn")
"""The FE's tibial regions under the meniscus (`fecheck.fe.knee.knee_menisci.REGION_NAMES`)."""

Answer = dict[str, dict[str, float]]
"""Per compartment the `QUANTITIES` (share 0-1, areas mm², pressures MPa)."""


def fe_answer(result) -> Answer:
    """The `QUANTITIES` of an FE with menisci (`KneeMenisciFE`) per compartment."""
    out = {}
    for c, comp in result.fe.items():
        under = [comp.regions[r] for r in MENISCUS_REGIONS if r in comp.regions]
        cart = comp.regions["cartilage"]
        out[c] = {"share": comp.share, "cartilage_area_mm2": cart.area_mm2,
                  "meniscus_area_mm2": sum(r.area_mm2 for r in under),
                  "cartilage_p_max_MPa": cart.p_max_MPa,
                  "meniscus_p_max_MPa": max((r.p_max_MPa for r in under), default=0.0)}
    return out


def ef_answer(run) -> Answer:
    """The `QUANTITIES` of an EF run with menisci (`RunResult`) per compartment."""
    out = {}
    for c, comp in run.compartments.items():
        row = run.menisci["compartments"][c]
        out[c] = {"share": row["meniscal_share"], "cartilage_area_mm2": comp.area_mm2,
                  "meniscus_area_mm2": row.get("meniscus_tibia_area_mm2", 0.0),
                  "cartilage_p_max_MPa": comp.max_pressure_MPa,
                  "meniscus_p_max_MPa": row.get("meniscus_tibia_max_pressure_MPa", 0.0)}
    return out


def fe_answers(scene: Scene, loads_N: Sequence[float], log: Callable[[str], None]
               ) -> list[Answer]:
    """The FE with menisci at each load (the scene's mesh; meniscus tetrahedra 1.25 times
    fe.size_mm, as `fecheck fe` meshes them)."""
    size = 1.25 * float(scene["fe.size_mm"])
    out = []
    for load in loads_N:
        log(f"calibrate: FE with menisci at {load:g} N")
        out.append(fe_answer(knee_menisci_fe(with_values(scene, load__force_N=float(load)),
                                             meniscus_size_mm=size)))
    return out


class EFRuns:
    """EF equilibria of a knee with menisci at `loads_N`, built once, for given meniscus
    laws ({side: Calibration}), each warm-started from its load's last answer."""

    def __init__(self, scene: Scene, loads_N: Sequence[float]):
        self.scenes = [with_values(scene, load__force_N=float(f)) for f in loads_N]
        self.knee = menisci.build_knee(scene)
        self.start: list = [None] * len(self.scenes)
        self.count = 0

    def __call__(self, parameters: dict[str, Calibration]) -> list[Answer]:
        knee = self.knee.with_laws({s: menisci.calibrated_meniscus_law(p)
                                    for s, p in parameters.items()})
        out = []
        for i, s in enumerate(self.scenes):
            start = knee if self.start[i] is None else knee.with_start(self.start[i])
            run = menisci.solve_knee(s, start)
            self.count += 1
            if not run.converged:
                raise FecheckError(f"calibrate: the EF with menisci did not converge at "
                                   f"{s['load.force_N']:g} N under the trial law "
                                   f"{_describe(parameters)}")
            self.start[i] = [run.coordinates.get(b.name, b.q_start) for b in knee.bodies]
            out.append(ef_answer(run))
        return out


def _describe(parameters: dict[str, Calibration]) -> str:
    return ", ".join(f"{s} C = {p.C:.4g}, n = {p.n:.4g}" for s, p in parameters.items())


def residuals(ef: list[Answer], fe: list[Answer], sides: Sequence[str]) -> np.ndarray:
    """Per load and meniscus: `SPLIT_WEIGHT` × (EF share − FE share) and the log of the EF
    over the FE area under the meniscus."""
    r = []
    for a, b in zip(ef, fe, strict=True):
        for s in sides:
            r.append(SPLIT_WEIGHT * (a[s]["share"] - b[s]["share"]))
            r.append(math.log(max(a[s]["meniscus_area_mm2"], 1e-9)
                              / b[s]["meniscus_area_mm2"]))
    return np.asarray(r)


def unpack(x: np.ndarray, sides: Sequence[str]) -> dict[str, Calibration]:
    """{side: Calibration} of the fit's unknowns (log C, n per side)."""
    return {s: Calibration(float(math.exp(x[2 * i])), float(x[2 * i + 1]))
            for i, s in enumerate(sides)}


def fit_law(runs: Callable[[dict[str, Calibration]], list[Answer]], targets: list[Answer],
            sides: Sequence[str], start: dict[str, Calibration],
            log: Callable[[str], None] = lambda s: None) -> dict[str, Calibration]:
    """C and n per meniscus such that `runs` (the EF at the calibration loads) reproduces
    `targets` (`residuals`), from `start`."""
    from scipy.optimize import least_squares

    lo, hi = calibrated.EXPONENT_RANGE
    x0 = np.array([v for s in sides for v in (math.log(start[s].C), start[s].n)])
    bounds = ([-np.inf, lo] * len(sides), [np.inf, hi] * len(sides))
    log(f"calibrate: fitting C and n per meniscus to the FE at {len(targets)} load(s)")
    fit = least_squares(lambda x: residuals(runs(unpack(x, sides)), targets, sides), x0,
                        bounds=bounds, diff_step=1e-3, x_scale=1.0, xtol=1e-6, ftol=1e-8,
                        max_nfev=40)
    return unpack(fit.x, sides)


@dataclass(frozen=True)
class MenisciFit:
    """Fitted meniscus laws, the FE answers they were fitted to, and the EF answers
    (uncalibrated and calibrated) at the same loads."""

    parameters: dict[str, Calibration]
    loads_N: list[float]
    fe: list[Answer]
    linear: list[Answer]
    fitted: list[Answer]
    seconds: dict[str, float]
    fingerprint: str = ""

    def worst_share_points(self) -> tuple[float, float, str]:
        """(largest |EF − FE| share of the calibrated EF, in points; its load; side)."""
        return max((100 * abs(ef[s]["share"] - fe[s]["share"]), load, s)
                   for load, fe, ef in zip(self.loads_N, self.fe, self.fitted, strict=True)
                   for s in self.parameters)


def calibrate_menisci(scene: Scene, load_factors: Sequence[float] = LOAD_FACTORS,
                      log: Callable[[str], None] = lambda s: None) -> MenisciFit:
    """Fit the meniscus laws of `scene` to its FE at `load_factors` × load.force_N."""
    loads = calibration_loads(scene, load_factors)
    scene = with_values(scene, menisci__calibration="")
    sides = menisci.present_sides(scene)
    if not sides:
        raise FecheckError("calibrate: the scene's menisci are all removed (menisci.sides, "
                           "menisci.remove): no meniscus law to calibrate")
    t0 = time.perf_counter()
    fe = fe_answers(scene, loads, log)
    t1 = time.perf_counter()
    runs = EFRuns(scene, loads)
    k = menisci.meniscus_stiffness(scene)
    start = dict.fromkeys(sides, Calibration(k, 1.0))
    linear = runs(start)
    parameters = fit_law(runs, fe, sides, start, log)
    fitted = runs(parameters)
    log(f"calibrate: {runs.count} EF equilibria")
    return MenisciFit(parameters, loads, fe, linear, fitted,
                      {"fe": t1 - t0, "fit": time.perf_counter() - t1},
                      menisci.menisci_fingerprint(scene))


def fit_warnings(fit: MenisciFit, scene_name: str) -> list[str]:
    """One line for an exponent on its bound, and one when the calibrated EF's share misses
    the FE's by more than `FIT_TOLERANCE` (10 points)."""
    out = []
    lo, hi = calibrated.EXPONENT_RANGE
    for s, p in fit.parameters.items():
        if min(abs(p.n - lo), abs(p.n - hi)) <= 1e-3:
            out.append(f"calibrate {scene_name}: the {s} meniscus exponent n = {p.n:.4g} sits "
                       f"on its bound ({lo:g} <= n <= {hi:g}): the law cannot follow this FE")
    worst, load, side = fit.worst_share_points()
    if worst > 100 * FIT_TOLERANCE:
        out.append(f"calibrate {scene_name}: the calibrated EF's {side} meniscal share misses "
                   f"the FE's by {worst:.1f} points at {load:g} N (more than "
                   f"{100 * FIT_TOLERANCE:g}): do not use it as a stand-in for the FE here")
    return out


def write(fit: MenisciFit, scene: Scene, path: str | Path) -> Path:
    """The calibration file of `fit` (menisci.calibration reads it), with the FE, the
    uncalibrated and the calibrated EF tables."""
    info = {"interfaces": MENISCI_INTERFACES, "scene": scene.label,
            "fingerprint": fit.fingerprint, "loads_N": fit.loads_N,
            "fitted_to": list(FITTED),
            "tables": [{"load_N": load, "fe": fe, "ef_uncalibrated": lin, "ef_calibrated": cal}
                       for load, fe, lin, cal in zip(fit.loads_N, fit.fe, fit.linear,
                                                     fit.fitted, strict=True)],
            "seconds": fit.seconds, "provenance": provenance(scene)}
    return calibrated.write_calibration(path, fit.parameters, info)


def table(load_N: float, rows: dict[str, Answer]) -> list[str]:
    """The side-by-side table at one load: per compartment and model (`rows`: name →
    `Answer`) the share (%), tibial areas under cartilage and meniscus (mm²) and p_max
    of each (MPa)."""
    lines = [f"{load_N:.0f} N {'':18} {'share %':>8} {'area cart':>9} {'area men':>9} "
             f"{'p_max cart':>10} {'p_max men':>10}"]
    for c in next(iter(rows.values())):
        for name, answer in rows.items():
            v = answer[c]
            lines.append(f"  {c:8} {name:15} {100 * v['share']:8.1f} "
                         f"{v['cartilage_area_mm2']:9.1f} {v['meniscus_area_mm2']:9.1f} "
                         f"{v['cartilage_p_max_MPa']:10.3f} {v['meniscus_p_max_MPa']:10.3f}")
    return lines


def report(fit: MenisciFit) -> str:
    """The FE, the uncalibrated and the calibrated EF side by side per load, and the laws."""
    lines = []
    for load, fe, lin, cal in zip(fit.loads_N, fit.fe, fit.linear, fit.fitted, strict=True):
        lines += table(load, {"FE": fe, "EF uncalibrated": lin, "EF calibrated": cal})
    for s, p in fit.parameters.items():
        lines.append(f"{s} meniscus: p = {p.C:.4g} · d · (d + {calibrated.SOFT_DEPTH_MM:g})"
                     f"^({p.n:.4f} - 1) MPa (d in mm), on its femoral and tibial interfaces")
    lines.append("fitted to the meniscal share and the tibial area under the meniscus; the "
                 "rest is reported, not fitted")
    return "\n".join(lines)
