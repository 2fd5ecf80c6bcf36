"""The calibrated EF against FE on held-out loads, beside the linear and Blankevoort EF.

For every scene of the EF-vs-FE study (fe_scenes.py: the flat baseline plateau at ν 0.3,
0.45, 0.49 and h 2, 6, 12 mm, inclined and polynomial plateaus, the scanned sphere-tibia and
femur-tibia), `fecheck calibrate` fits the calibrated law (`fecheck.laws.calibrated`, p =
C·d·(d + 0.01 mm)^(n−1) per compartment) to the scene's FE at 0.6 and 1.4 times its load and
its own load point; the answers are then compared at the scene's own load, 1.0 times, and at
that load with the load point moved 5 mm in x (several points of medial share), which no fit
saw (held out): FE (the cross-check, whole-joint load control) against EF linear, EF
Blankevoort, EF calibrated on the scene and, for condyle spheres on a uniform layer, EF
calibrated from the built-in table (axisymmetric FE, no fit to the scene at all); and on the
inclined and polynomial plateaus, the baseline's own calibration (fitted on the flat
plateau: another scene kind). Per case, compartment and law: the relative error of p_max,
p_mean and contact area, the medial share difference (percentage points) and the distance of
the centres of pressure (mm); and the time of each law's equilibrium solve against the
linear EF's and the FE's, and of the whole EF run against the FE (warmed up, one run; read
the ratios). Targets (issue): calibrated EF within 5 % of FE on p_max and area, 2 points on
the split; cost ≤ 2x the linear EF and ≤ 1 % of the FE.

    python validation/ef_calibrated.py [--quick] [--out DIR]

--quick: the baseline only, its plateau discs meshed at 1.4 mm under the contact and its
axisymmetric FE reference at 0.2 mm (both coarser than the defaults). Writes
DIR/ef_calibrated.csv and DIR/ef_calibrated.png.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from fecheck.errors import FecheckError
from fecheck.fe.bodies.pose import FramePose
from fecheck.fe.knee.crosscheck import cross_check, ef_metrics
from fecheck.model.run import run_scene
from fecheck.scene import load_scene, with_values
from fecheck.statics.newton import pose
from fecheck.studies.calibrate import calibrate, write

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.studies.thesis.report import Missing, require_knee_data, save_figure
from validation.fe_scenes import CASES, SCENES, Case

COMPARTMENTS = ("medial", "lateral")
FIT_FACTORS = (0.6, 1.4)
"""Loads the calibration sees (× load.force_N); 1.0 is held out."""
TARGET = {"rel": 0.05, "share_pp": 2.0}
DONOR_KINDS = ("inclined plateaus", "polynomial plateaus")
"""Scene kinds that also try the baseline's calibration (same material and thickness, other
plateau and condyle geometry): calibrated on one kind, verified on another."""
QUICK_OVERRIDES = ("mesh.plateau_refine_mm=1.4", "fe.axisym_size_mm=0.2")
"""--quick: the baseline's coarser meshes (under half the default's FE dofs)."""
POINT_SHIFT_MM = 5.0
"""The held-out load point: the scene's own moved by this in x (mm)."""


def _timed_run(scene):
    """The EF run, its wall time and its equilibrium solve's time (the second of two
    runs: no compiling; the solve without the scene's build, whose meshes are cached)."""
    run_scene(scene)
    t = time.perf_counter()
    result = run_scene(scene)
    return result, time.perf_counter() - t, result.timing_s["solve"]


def laws_of(scene, calibration: Path, donor: Path | None = None) -> dict:
    """{label: scene} of the EF variants compared; `donor`: another scene's calibration,
    tried here too (calibrated on one scene kind, verified on another)."""
    out = {"linear": with_values(scene, contact__law="ef"),
           "blankevoort": with_values(scene, contact__law="blankevoort"),
           "calibrated": with_values(scene, contact__law="ef-calibrated",
                                     contact__calibration=str(calibration))}
    uniform_spheres = (scene["model.kind"] == "sphere-plane"
                       or scene["scanned.thickness"] == "uniform"
                       and scene["model.kind"] == "sphere-tibia")
    if uniform_spheres:
        out["table"] = with_values(scene, contact__law="ef-calibrated")
    if scene["scanned.thickness"] == "bone-distance":
        del out["blankevoort"]           # a per-face thickness: the linear EF only
    if donor is not None:
        out["baseline's"] = with_values(scene, contact__law="ef-calibrated",
                                        contact__calibration=str(donor))
    return out


def held_out(label: str, scene) -> list[tuple[str, object]]:
    """(label, scene) of the held-out conditions: the scene's own load point, and that
    point moved by `POINT_SHIFT_MM` in x."""
    x, y, z = scene["load.point_mm"]
    return [(label, scene),
            (f"{label}, point x{POINT_SHIFT_MM:+g}",
             with_values(scene, load__point_mm=[x + POINT_SHIFT_MM, y, z]))]


def measure(case: Case, folder: Path, donor: Path | None = None) -> tuple[list[dict], Path]:
    """Rows of one case, one per held-out condition and EF law, and the case's
    calibration file."""
    path = None if case.scene is None else SCENES / case.scene
    scene = with_values(load_scene(path, list(case.overrides)), contact__law="ef")
    fit = calibrate(scene, FIT_FACTORS)
    calibration = write(fit, scene, folder / f"{case.label.replace(' ', '_')}.json")
    rows = []
    for label, held in held_out(case.label, scene):
        rows += _compare(label, case.kind, held, fit, calibration, donor)
    return rows, calibration


def _compare(label: str, kind: str, scene, fit, calibration: Path, donor: Path | None
             ) -> list[dict]:
    """One row per EF law: the scene's EF answers against its FE."""
    check = cross_check(scene, log=None)
    fe_share = check.split("fe")["medial"]
    rows = []
    for law, s in laws_of(scene, calibration, donor).items():
        try:
            result, seconds, solve = _timed_run(s)
        except FecheckError as err:
            print(f"  {label} {law}: {err}", file=sys.stderr)
            continue
        rot, t = pose(np.asarray(result.pose.q, dtype=float),
                      math.radians(scene["dofs.flexion_deg"]))
        row = {"case": label, "kind": kind, "law": law, "ef_s": seconds,
               "solve_s": solve, "fe_s": check.timing_s["fe"]}
        forces = {}
        for c in COMPARTMENTS:
            ef = ef_metrics(result.compartments[c], FramePose(rot, t, "W", "T"))
            fe = check.compartments[c].fe
            forces[c] = ef.force_N
            for key, attr in (("pmax", "max_pressure_MPa"), ("pmean", "mean_pressure_MPa"),
                              ("area", "area_mm2")):
                row[f"{c}_fe_{key}"] = getattr(fe, attr)
                row[f"{c}_ef_{key}"] = getattr(ef, attr)
                row[f"{c}_err_{key}"] = getattr(ef, attr) / getattr(fe, attr) - 1
            a, b = ef.center_of_pressure_mm, fe.center_of_pressure_mm
            row[f"{c}_cop_mm"] = (float(np.linalg.norm(np.asarray(a) - np.asarray(b)))
                                  if a is not None and b is not None else math.nan)
        row["share_diff_pp"] = 100 * (forces["medial"] / sum(forces.values()) - fe_share)
        if law == "calibrated":
            for c, p in fit.parameters.items():
                row[f"{c}_C"], row[f"{c}_n"] = p.C, p.n
        rows.append(row)
    base = next(r["solve_s"] for r in rows if r["law"] == "linear")
    for r in rows:
        r["cost_vs_linear"] = r["solve_s"] / base
        r["cost_vs_fe"] = r["solve_s"] / r["fe_s"]
        r["run_vs_fe"] = r["ef_s"] / r["fe_s"]
    return rows


def summary(rows: list[dict]) -> None:
    """One line per case and law: the worst errors, and the verdict against the targets."""
    print(f"{'case':34} {'law':12} {'p_max':>14} {'area':>14} {'p_mean':>14} {'share pp':>9} "
          f"{'CoP mm':>7} {'cost/lin':>8} {'cost/FE':>8} {'run/FE':>7}")
    for r in rows:
        cells = []
        for key in ("pmax", "area", "pmean"):
            cells.append(" ".join(f"{100 * r[f'{c}_err_{key}']:+6.1f}" for c in COMPARTMENTS))
        cop = max(r[f"{c}_cop_mm"] for c in COMPARTMENTS)
        print(f"{r['case']:34} {r['law']:12} {cells[0]:>14} {cells[1]:>14} {cells[2]:>14} "
              f"{r['share_diff_pp']:+9.2f} {cop:7.2f} {r['cost_vs_linear']:8.2f} "
              f"{100 * r['cost_vs_fe']:7.2f}% {100 * r['run_vs_fe']:6.2f}%")
    cal = [r for r in rows if r["law"] == "calibrated"]
    worst = max(cal, key=lambda r: max(abs(r[f"{c}_err_{k}"]) for c in COMPARTMENTS
                                        for k in ("pmax", "area")))
    w = max(abs(worst[f"{c}_err_{k}"]) for c in COMPARTMENTS for k in ("pmax", "area"))
    share = max(abs(r["share_diff_pp"]) for r in cal)
    print(f"calibrated EF on held-out loads: worst p_max/area error {100 * w:.1f} % "
          f"({worst['case']}; target {100 * TARGET['rel']:.0f} %), worst split "
          f"{share:.2f} points (target {TARGET['share_pp']:g}); cost "
          f"{max(r['cost_vs_linear'] for r in cal):.2f}x the linear EF at most, "
          f"{100 * max(r['cost_vs_fe'] for r in cal):.2f} % of the FE at most")
    print("errors: EF/FE - 1 in %, medial then lateral; share: EF - FE medial share, points; "
          "cost: the equilibrium solve's time against the linear EF's and the FE's; run/FE: "
          "the whole EF run (scene build from cached meshes included) against the FE")


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = list(dict.fromkeys(r["case"] for r in rows))
    laws = list(dict.fromkeys(r["law"] for r in rows))
    fig, axes = plt.subplots(1, 3, figsize=(16, 0.5 * len(cases) + 3), sharey=True)
    y = np.arange(len(cases))
    width = 0.8 / len(laws)
    for ax, key, title in ((axes[0], "pmax", "p_max"), (axes[1], "area", "contact area")):
        for i, law in enumerate(laws):
            err = [max((abs(r[f"{c}_err_{key}"]) for r in rows
                        if r["case"] == case and r["law"] == law for c in COMPARTMENTS),
                       default=np.nan) for case in cases]
            ax.barh(y + i * width, 100 * np.asarray(err), width, label=law)
        ax.axvline(100 * TARGET["rel"], color="k", ls="--", lw=1)
        ax.set_xlabel(f"worst |EF/FE - 1| of {title}, % (held out)")
    for i, law in enumerate(laws):
        share = [next((abs(r["share_diff_pp"]) for r in rows
                       if r["case"] == case and r["law"] == law), np.nan) for case in cases]
        axes[2].barh(y + i * width, share, width, label=law)
    axes[2].axvline(TARGET["share_pp"], color="k", ls="--", lw=1)
    axes[2].set_xlabel("|medial share EF - FE|, percentage points")
    axes[0].set_yticks(y + 0.4 - width / 2, cases)
    axes[0].invert_yaxis()
    axes[0].legend(loc="lower right")
    for ax in axes:
        ax.grid(alpha=0.3, axis="x")
    fig.suptitle("EF laws against the FE of the same scene, at a load and a load point no "
                 "calibration saw (dashed: targets)")
    save_figure(fig, path)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--out", type=Path, default=Path("out/ef_calibrated"))
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    cases = list(CASES)
    if args.quick:
        base = CASES[0]
        cases = [replace(base, overrides=(*base.overrides, *QUICK_OVERRIDES))]
    rows: list[dict] = []
    donor = None
    with tempfile.TemporaryDirectory() as folder:
        for case in cases:
            if case.scanned:
                try:
                    require_knee_data()
                except Missing as why:
                    print(f"skipped {case.label}: {why}")
                    continue
            print(f"{case.label} ...", flush=True)
            transfer = donor if case.kind in DONOR_KINDS else None
            new, calibration = measure(case, Path(folder), transfer)
            rows += new
            if case is CASES[0]:
                donor = calibration
    path = args.out / "ef_calibrated.csv"
    fields = list(dict.fromkeys(k for r in rows for k in r))
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)
    summary(rows)
    plot(rows, args.out / "ef_calibrated.png")
    print(f"wrote {path} and {args.out / 'ef_calibrated.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
