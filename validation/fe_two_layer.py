"""One deformable layer in series against two deformable layers on the scanned knee.

The FE of the scanned femur on the scanned tibia (scene femur_tibia, bone-distance
thickness, whole-joint load control) with ``fe.cartilage = "series"`` (the tibial sheet
extruded by the tibial plus femoral thickness under the rigid femoral sheet: the EF's
own assumption) and ``"two-layer"`` (each cartilage extruded toward its own bone by its
own thickness, frictionless contact between them), from the same EF equilibrium. Per
compartment: force, vertex p_max, p_max averaged on the EF faces, contact area, centre of
pressure (tibia frame) and its shift between the models; the medial/lateral split; the
largest penetration and the balance of the free DOFs (`fecheck.fe.knee.balance`); the FE
time (build, condense, contact) and the process's peak memory. Times are wall clock on
a shared machine.

    python validation/fe_two_layer.py [--quick] [--out DIR]

--quick: the surfaces decimated to about 1,500 tibial faces. Skipped (exit 0) when the
scanned knee data is absent. Writes DIR/fe_two_layer.csv.

Measured at full resolution (two-layer against series): face-averaged p_max -3.2 %
medial, -3.4 % lateral; vertex p_max -4.5 / -4.0 %; area +9.4 / +10.3 %; split within
0.03 points; centres of pressure 0.06 / 0.10 mm apart; both balance to 5e-15 of the load
and penetrate less than 1e-12 mm; 357k dofs and 2.6 GB peak against 197k and 1.6 GB.
"""

from __future__ import annotations

import csv
import math
import resource
import sys
import time
from pathlib import Path

import numpy as np

from fecheck.fe.knee.balance import free_dof_balance
from fecheck.fe.knee.crosscheck import cross_check
from fecheck.model.run import run_scene
from fecheck.scene import load_scene

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.studies.thesis.report import knee_scene, knee_script_args

SCENE = Path(__file__).resolve().parent / "scenes" / "femur_tibia.toml"
MODELS = ("series", "two-layer")


def rows_of(scene, check, model: str, wall_s: float) -> list[dict]:
    """One row per compartment of one model's cross-check."""
    split = check.split("fe")
    balance = free_dof_balance(scene, check, (math.radians(scene["dofs.flexion_deg"]),))
    out = []
    for name, chk in check.compartments.items():
        cop = chk.fe.center_of_pressure_mm
        out.append({"model": model, "compartment": name, "force_N": chk.fe.force_N,
                    "share": split[name], "p_max_vertex_MPa": chk.fe.max_pressure_MPa,
                    "p_max_faces_MPa": float(np.nanmax(chk.fe_face_pressure_MPa)),
                    "area_mm2": chk.fe.area_mm2, "cop_x_mm": cop[0], "cop_y_mm": cop[1],
                    "cop_z_mm": cop[2], "penetration_mm": chk.max_penetration_mm,
                    "balance": balance, "dofs": check.geometry["dofs"],
                    "fe_s": check.timing_s["fe"], "build_s": check.timing_s["fe_build"],
                    "condense_s": check.timing_s["fe_condense"],
                    "contact_s": check.timing_s["fe_contact"], "wall_s": wall_s,
                    "peak_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6})
    return out


def table(rows: list[dict]) -> list[str]:
    """The comparison as text lines (two-layer against series per compartment)."""
    lines = [f"{'model':10s} {'comp':8s} {'F N':>7s} {'share':>6s} {'p_vtx':>6s} "
             f"{'p_face':>6s} {'area':>6s} {'CoP x, y mm':>14s} {'pen mm':>8s} "
             f"{'balance':>8s} {'dofs':>7s} {'FE s':>6s} {'GB':>5s}"]
    for r in rows:
        lines.append(f"{r['model']:10s} {r['compartment']:8s} {r['force_N']:7.1f} "
                     f"{100 * r['share']:5.1f}% {r['p_max_vertex_MPa']:6.3f} "
                     f"{r['p_max_faces_MPa']:6.3f} {r['area_mm2']:6.1f} "
                     f"{r['cop_x_mm']:6.2f},{r['cop_y_mm']:6.2f} {r['penetration_mm']:8.1e} "
                     f"{r['balance']:8.1e} {r['dofs']:7d} {r['fe_s']:6.1f} {r['peak_gb']:5.2f}")
    by = {(r["model"], r["compartment"]): r for r in rows}
    for name in dict.fromkeys(r["compartment"] for r in rows):
        a, b = by[("series", name)], by[("two-layer", name)]
        shift = math.hypot(b["cop_x_mm"] - a["cop_x_mm"], b["cop_y_mm"] - a["cop_y_mm"])
        lines.append(f"{name}: two-layer vs series: p_max on faces "
                     f"{100 * (b['p_max_faces_MPa'] / a['p_max_faces_MPa'] - 1):+.1f}%, vertex "
                     f"{100 * (b['p_max_vertex_MPa'] / a['p_max_vertex_MPa'] - 1):+.1f}%, area "
                     f"{100 * (b['area_mm2'] / a['area_mm2'] - 1):+.1f}%, share "
                     f"{100 * (b['share'] - a['share']):+.2f} pp, CoP {shift:.2f} mm")
    return lines


def main(argv=None) -> int:
    args = knee_script_args(__doc__.splitlines()[0], "decimated surfaces (about 1,500 "
                            "tibial faces)", argv)
    if args is None:
        return 0
    knee_scene("femur_tibia.toml")
    sets = ["scanned.decimate_faces=1500"] if args.quick else []
    rows = []
    ef = None
    for model in MODELS:
        scene = load_scene(SCENE, [*sets, f"fe.cartilage='{model}'"])
        if ef is None:
            t0 = time.perf_counter()
            ef = (run_scene(scene), time.perf_counter() - t0)
        t0 = time.perf_counter()
        check = cross_check(scene, log=None, ef=ef)
        rows += rows_of(scene, check, model, time.perf_counter() - t0)
        print(f"{model}: FE {check.timing_s['fe']:.1f} s", file=sys.stderr, flush=True)
    for line in table(rows):
        print(line)
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "fe_two_layer.csv"
    with path.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
