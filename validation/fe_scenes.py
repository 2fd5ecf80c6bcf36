"""EF against the FE of the same scene, on every kind of scene (`fecheck fe`).

`fecheck.fe.knee.crosscheck.cross_check` solves the scene's EF equilibrium, then the FE of the
same geometry, materials and load (the EF run's tibial surfaces extruded into bonded P2
layers under the rigid femoral surfaces, whole-joint load control: the FE finds its own
medial/lateral split). This study runs it on

* the flat plateau (baseline: E 20 MPa, ν 0.3, h 6 mm), and on the baseline ν 0.45 and
  0.49 and h 2 and 12 mm;
* condyle spheres on inclined and on polynomial plateaus (inclined.toml, polynomial.toml);
* condyle hemispheres on the scanned tibia (sphere_tibia.toml) and the scanned femur on
  the scanned tibia (femur_tibia.toml), both with the bone-distance thickness, on the
  lenhart2015 knee packaged with fecheck.

Per case and compartment: EF and FE p_max; the largest pressure on the EF run's faces
(the EF's face pressure against the FE's averaged over each EF face: like for like; on a
meshed surface the FE's vertex p_max grows under refinement, see
fe_scanned_convergence.py); contact area and p_mean, each with the relative error
EF/FE − 1; the distance between the EF and FE centres of pressure, and the distance from
the FE's p_max vertex to its own centre of pressure (large where the FE peak sits at an
edge of the contact, e.g. at the rim of the sphere-tibia hemispheres' cut, which the EF's
depth-only law does not see). Per case: the medial share of the force (EF and FE), the
FE dofs, levels through the thickness (fe.layers auto: 3 from ν 0.45, else 2) and
smallest surface edge, and the EF and FE times (EF warmed up, so without JIT compiling;
FE = layer build + contact solve) with their ratio. The sphere-plane scenes mesh their
plateau discs finer where the expected contact is smaller (the default
mesh.plateau_refine_mm), so ν 0.45 / 0.49 and h 2 mm get finer FE meshes. It ends with
one sentence per scene kind on when the EF answer can be trusted, from these numbers
(tolerances `TRUST`). Times are wall clock on a shared machine: read the ratios.

    python validation/fe_scenes.py [--quick] [--out DIR]

--quick: the baseline (its plateau discs meshed at 1.4 mm under the contact, its
axisymmetric FE reference at 0.2 mm: coarser than the defaults) and, when the knee data is
there, the scanned femur-tibia decimated to about 1,500 tibial faces (else the inclined
plateaus). Writes
DIR/fe_scenes.csv and DIR/fe_scenes.png.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from fecheck.errors import FecheckError
from fecheck.fe.knee.crosscheck import cross_check
from fecheck.model.run import run_scene
from fecheck.scene import load_scene

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.studies.thesis.report import Missing, require_knee_data, save_figure

SCENES = Path(__file__).resolve().parent / "scenes"
COMPARTMENTS = ("medial", "lateral")
METRICS = {"pmax": "max_pressure_MPa", "pmax_faces": None, "area": "area_mm2",
           "pmean": "mean_pressure_MPa"}
"""SideMetrics attributes; pmax_faces (None) = the largest face pressure on the EF run's
faces: the EF's own, and the FE's averaged over each EF face (like for like)."""
LABELS = {"pmax": "p_max", "pmax_faces": "p_max on EF faces", "area": "area",
          "pmean": "p_mean"}
TRUST = {"rel": 0.10, "share_pp": 2.0, "cop_mm": 1.0}
"""EF trusted when within 10 % of FE (p_max, area, p_mean), 2 percentage points of the
medial share and 1 mm of the centre of pressure."""
QUICK_FACES = 1500
QUICK_BASELINE = ("mesh.plateau_refine_mm=1.4", "fe.axisym_size_mm=0.2")
"""--quick: the baseline's coarser meshes (under half the default's FE dofs)."""


@dataclass(frozen=True)
class Case:
    """One scene: label, kind (the group of the trust sentence), TOML file (None =
    baseline), overrides, whether it reads the scanned knee."""

    label: str
    kind: str
    scene: str | None
    overrides: tuple[str, ...] = ()
    scanned: bool = False


FLAT = "flat plateau (baseline knee)"
CASES = (
    Case("baseline", FLAT, None),
    Case("baseline ν 0.45", FLAT, None, ("contact.poisson=0.45",)),
    Case("baseline ν 0.49", FLAT, None, ("contact.poisson=0.49",)),
    Case("baseline h 2", FLAT, None, ("contact.thickness_mm=2",)),
    Case("baseline h 12", FLAT, None, ("contact.thickness_mm=12",)),
    Case("inclined", "inclined plateaus", "inclined.toml"),
    Case("polynomial", "polynomial plateaus", "polynomial.toml"),
    Case("sphere-tibia", "condyles on the scanned tibia", "sphere_tibia.toml", scanned=True),
    Case("femur-tibia", "scanned femur on scanned tibia", "femur_tibia.toml", scanned=True),
)


def quick_cases(have_knee: bool) -> list[Case]:
    """The baseline, and the decimated femur-tibia (or the inclined plateaus without data)."""
    base = replace(CASES[0], overrides=(*CASES[0].overrides, *QUICK_BASELINE))
    if not have_knee:
        return [base, next(c for c in CASES if c.label == "inclined")]
    ft = next(c for c in CASES if c.label == "femur-tibia")
    return [base, Case(f"femur-tibia ~{QUICK_FACES} faces", ft.kind, ft.scene,
                       (f"scanned.decimate_faces={QUICK_FACES}",), True)]


def measure(case: Case) -> dict:
    """Cross-check one case: the row of the table."""
    path = None if case.scene is None else SCENES / case.scene
    scene = load_scene(path, list(case.overrides))
    run_scene(scene)                          # warm-up: the EF time without JIT compiling
    check = cross_check(scene, log=None)
    row: dict = {"case": case.label, "kind": case.kind,
                 "overrides": " ".join(case.overrides)}
    for c in COMPARTMENTS:
        chk = check.compartments[c]
        for key, attr in METRICS.items():
            ef, fe = ((getattr(chk.ef_model, attr), getattr(chk.fe, attr)) if attr else
                      (_largest(chk.ef_face_pressure_MPa), _largest(chk.fe_face_pressure_MPa)))
            row[f"{c}_ef_{key}"] = ef
            row[f"{c}_fe_{key}"] = fe
            row[f"{c}_err_{key}"] = ef / fe - 1 if fe and math.isfinite(fe) else math.nan
        row[f"{c}_ef_force_N"] = chk.ef_model.force_N
        row[f"{c}_fe_force_N"] = chk.fe.force_N
        row[f"{c}_cop_mm"] = chk.cop_distance_mm
        row[f"{c}_fe_pmax_offset_mm"] = _pmax_offset(chk)
        row[f"{c}_fe_vs_axisym_pmax"] = chk.deviation().get("max_pressure", math.nan)
    ef_split, fe_split = check.split("ef_model"), check.split("fe")
    row["medial_share_ef"] = ef_split["medial"]
    row["medial_share_fe"] = fe_split["medial"]
    row["share_diff_pp"] = 100 * (ef_split["medial"] - fe_split["medial"])
    row["fe_dofs"] = check.geometry["dofs"]
    row["fe_levels"] = check.geometry.get("levels", math.nan)
    row["fe_smallest_mm"] = check.geometry["smallest_size_mm"]
    row["fe_thickness"] = check.geometry["thickness_source"]
    row["fe_s"] = check.timing_s["fe"]
    row["ef_s"] = check.timing_s["ef_equilibrium"]
    row["ef_over_fe"] = check.timing_s["ef_over_fe"]
    return row


def _largest(values) -> float:
    """The largest finite value of an array (NaN for None or no finite value)."""
    if values is None or not np.isfinite(values).any():
        return math.nan
    return float(np.nanmax(values))


def _pmax_offset(chk) -> float:
    """Distance from the FE's p_max vertex to the FE centre of pressure, mm: large where
    the FE peak sits at an edge of the contact rather than at its centre."""
    cop = chk.fe.center_of_pressure_mm
    if cop is None:
        return math.nan
    peak = chk.layer.surface.points[int(np.argmax(chk.fe_pressure_MPa))]
    return float(np.linalg.norm(peak - np.asarray(cop)))


def run_cases(cases: list[Case], have_knee: bool, knee_why: str) -> tuple[list[dict], int]:
    """Every case that can run: the rows and the number of failures (skips excluded)."""
    rows, failed = [], 0
    for case in cases:
        if case.scanned and not have_knee:
            print(f"skipped {case.label}: {knee_why}")
            continue
        print(f"{case.label}: solving EF and FE ...", flush=True)
        try:
            rows.append(measure(case))
        except FecheckError as err:
            failed += 1
            print(f"failed {case.label}: {err}")
    return rows, failed


def print_table(rows: list[dict]) -> None:
    print(f"\n{'case':24s}{'':8s} | {'p_max MPa EF':>12s}{'FE':>6s}{'err':>8s} | "
          f"{'on EF faces EF':>14s}{'FE':>6s}{'err':>8s} | {'area mm² EF':>11s}{'FE':>6s}"
          f"{'err':>8s} | {'p_mean EF':>9s}{'FE':>6s}{'err':>8s} | {'CoP mm':>6s}{'peak-CoP':>9s}")
    for r in rows:
        for c in COMPARTMENTS:
            cells = []
            for key, width, fmt in (("pmax", 12, ".2f"), ("pmax_faces", 14, ".2f"),
                                    ("area", 11, ".0f"),
                                    ("pmean", 9, ".2f")):
                cells.append(f"{r[f'{c}_ef_{key}']:{width}{fmt}}{r[f'{c}_fe_{key}']:6{fmt}}"
                             f"{100 * r[f'{c}_err_{key}']:+7.1f}%")
            print(f"{r['case'] if c == 'medial' else '':24s}{c:8s} | " + " | ".join(cells)
                  + f" | {r[f'{c}_cop_mm']:6.2f}{r[f'{c}_fe_pmax_offset_mm']:9.2f}")
    print(f"\n{'case':24s} | {'medial share EF':>15s}{'FE':>7s}{'Δ pp':>7s} | {'FE dofs':>8s}"
          f"{'levels':>7s}{'min edge':>9s} | {'FE s':>6s}{'EF s':>6s}{'EF/FE':>7s}")
    for r in rows:
        print(f"{r['case']:24s} | {r['medial_share_ef']:15.3f}{r['medial_share_fe']:7.3f}"
              f"{r['share_diff_pp']:+7.2f} | {r['fe_dofs']:8d}{r['fe_levels']:7g}"
              f"{r['fe_smallest_mm']:9.2f} | "
              f"{r['fe_s']:6.1f}{r['ef_s']:6.2f}{r['ef_over_fe']:7.3f}")


def _worst(rows: list[dict], key: str) -> tuple[float, str]:
    """The signed relative error of largest magnitude over both compartments, and its case."""
    best = (0.0, "")
    for r in rows:
        for c in COMPARTMENTS:
            v = r[f"{c}_err_{key}"]
            if math.isfinite(v) and abs(v) >= abs(best[0]):
                best = (v, f"{r['case']}, {c}")
    return best


def _cases_within(rows: list[dict], ok) -> tuple[list[str], list[str]]:
    good = [r["case"] for r in rows if ok(r)]
    return good, [r["case"] for r in rows if r["case"] not in good]


def trust_sentence(kind: str, rows: list[dict]) -> str:
    """One sentence: per quantity the worst EF deviation from FE over the kind's cases,
    and which quantities (and, when the kind has several cases, in which cases) pass the
    `TRUST` tolerances."""
    parts, trusted, partly, not_trusted = [], [], [], []
    for key in METRICS:
        worst, where = _worst(rows, key)
        parts.append(f"{LABELS[key]} {100 * worst:+.0f} %" + (f" ({where})" if len(rows) > 1
                                                             else ""))
        good, bad = _cases_within(rows, lambda r, k=key: all(
            abs(r[f"{c}_err_{k}"]) <= TRUST["rel"] for c in COMPARTMENTS))
        if not bad:
            trusted.append(LABELS[key])
        elif good:
            partly.append(f"{LABELS[key]} only in {', '.join(good)}")
        else:
            not_trusted.append(LABELS[key])
    share = max(abs(r["share_diff_pp"]) for r in rows)
    cop = max(r[f"{c}_cop_mm"] for r in rows for c in COMPARTMENTS)
    parts += [f"medial share within {share:.1f} pp", f"CoP within {cop:.2f} mm"]
    (trusted if share <= TRUST["share_pp"] else not_trusted).append("the split")
    (trusted if cop <= TRUST["cop_mm"] else not_trusted).append("the CoP")
    cases = ", ".join(r["case"] for r in rows)
    verdict = "; ".join([f"trust EF for {', '.join(trusted) or 'nothing'}", *partly]
                        + ([f"not for {', '.join(not_trusted)}"] if not_trusted else []))
    return (f"- {kind} [{cases}]: worst EF vs FE {'; '.join(parts)}: {verdict} "
            f"(within {100 * TRUST['rel']:.0f} %, {TRUST['share_pp']:g} pp, "
            f"{TRUST['cop_mm']:g} mm).")


def write_csv(rows: list[dict], path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {path}")


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(rows)
    fig, axes = plt.subplots(1, 3, figsize=(14, max(2.8, 1.2 + 0.55 * n)), sharey=True,
                             gridspec_kw={"width_ratios": [2.2, 1, 1]})
    y = np.arange(n)
    ax = axes[0]
    for k, (key, color) in enumerate(zip(METRICS, ("C3", "C1", "C0", "C2"), strict=True)):
        for c, marker, dy in (("medial", "o", -0.12), ("lateral", "s", 0.12)):
            ax.scatter([100 * r[f"{c}_err_{key}"] for r in rows], y + dy + (k - 1.5) * 0.04,
                       marker=marker, color=color, s=28,
                       facecolors=color if c == "medial" else "none",
                       label=f"{LABELS[key]}, {c}")
    ax.axvspan(-100 * TRUST["rel"], 100 * TRUST["rel"], color="grey", alpha=0.15)
    ax.set_xlabel("EF / FE − 1 (%)")
    ax.legend(fontsize=7, ncol=4, loc="lower center", bbox_to_anchor=(0.5, 1.0),
              frameon=False)
    axes[1].barh(y, [r["share_diff_pp"] for r in rows], color="C4", height=0.5)
    axes[1].axvspan(-TRUST["share_pp"], TRUST["share_pp"], color="grey", alpha=0.15)
    axes[1].set_xlabel("medial share EF − FE (percentage points)")
    for c, dy, color in (("medial", -0.15, "C1"), ("lateral", 0.15, "C5")):
        axes[2].barh(y + dy, [r[f"{c}_cop_mm"] for r in rows], height=0.3, color=color,
                     label=c)
    axes[2].axvline(TRUST["cop_mm"], color="grey", ls="--", lw=0.8)
    axes[2].set_xlabel("EF–FE centre of pressure distance (mm)")
    axes[2].legend(fontsize=7)
    for a in axes:
        a.axvline(0, color="k", lw=0.8)
        a.grid(axis="x", alpha=0.3)
    axes[0].set_yticks(y, [r["case"] for r in rows])
    axes[0].invert_yaxis()
    fig.suptitle("EF against the FE of the same scene (grey: the trust tolerances)")
    print(f"wrote {save_figure(fig, path)}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="baseline and a decimated scanned femur-tibia (or inclined)")
    parser.add_argument("--out", type=Path, default=Path("out/fe"), help="output folder")
    args = parser.parse_args(argv)
    try:
        require_knee_data()
        have_knee, why = True, ""
    except Missing as err:
        have_knee, why = False, str(err)
    cases = quick_cases(have_knee) if args.quick else list(CASES)
    if args.quick and not have_knee:
        print(f"skipped the scanned femur-tibia (inclined plateaus instead): {why}")
    rows, failed = run_cases(cases, have_knee, why)
    if not rows:
        print("no case ran")
        return 1
    print_table(rows)
    write_csv(rows, args.out / "fe_scenes.csv")
    plot(rows, args.out / "fe_scenes.png")
    print("\nwhen the EF answer can be trusted (FE of the same scene as the reference):")
    for kind in dict.fromkeys(r["kind"] for r in rows):
        print(trust_sentence(kind, [r for r in rows if r["kind"] == kind]))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
