"""FE accuracy near incompressibility: the mixed (P2 / element-constant pressure) form
against the pure-displacement P2, on the baseline scene.

1. The reference: the axisymmetric solve (`fecheck.fe.reference.axisym`, mixed form) of the baseline
   medial compartment (323.71 N, R 25.5 mm, E 20 MPa, h 6 mm) at two fine sizes under the
   contact, for ν 0.3, 0.45, 0.49, 0.4999 (its convergence: the two sizes' change), with
   the displacement form beside it (equal at ν 0.3, locking at ν 0.4999).
2. Hertz on a thick block (60 mm, a/h ≈ 0.04) at ν 0.49 and 0.4999, both forms.
3. `fecheck fe` on the baseline scene (compartment mode; the whole run, at the default
   levels through the thickness) per ν and formulation: p_max and area against the
   axisymmetric mixed reference at each compartment's FE load and the finest size, dofs,
   CPU time of the FE (build and solve) and per dof.

    python validation/fe_incompressible.py [--quick] [--out DIR]

--quick: reference sizes 0.1 and 0.05 mm, the Hertz block at 0.1 mm (full: 0.05 mm), no 3D
runs (a run of every code path, not of the numbers). Writes DIR/fe_incompressible.csv.
The constants of tests/fe/test_fe_mixed.py come from section 1 of the full run (0.0125 mm).
"""

from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numpy as np

from fecheck.errors import FecheckError
from fecheck.fe.reference.axisym import axisym_sphere_on_layer
from fecheck.reference.closed_forms import hertz_sphere_on_plane

E_MPA, H_MM = 20.0, 6.0
MEDIAL = (323.71, 25.5)
RADII = {"medial": 25.5, "lateral": 31.8}
POISSON = (0.3, 0.45, 0.49, 0.4999)
FORMS = ("displacement", "mixed")


def reference_rows(sizes: tuple[float, float]) -> list[dict]:
    """Section 1: the axisymmetric medial compartment per ν, form and size."""
    rows = []
    for nu in POISSON:
        for form in FORMS:
            last = None
            for size in sizes:
                t = time.process_time()
                res = axisym_sphere_on_layer(*MEDIAL, E_MPA, nu, H_MM, size_mm=size,
                                             formulation=form)
                m = res.metrics
                row = {"section": "reference", "nu": nu, "formulation": form,
                       "size_mm": size, "max_pressure_MPa": m.max_pressure_MPa,
                       "area_mm2": m.area_mm2, "n_dofs": res.n_dofs,
                       "cpu_s": time.process_time() - t}
                if last is not None:
                    row["change_max_pressure"] = m.max_pressure_MPa / last[0] - 1
                    row["change_area"] = m.area_mm2 / last[1] - 1
                last = (m.max_pressure_MPa, m.area_mm2)
                rows.append(row)
                print(f"axisym ν {nu:<6} {form:12s} {size:6.4f} mm: p_max "
                      f"{m.max_pressure_MPa:.5f} MPa, area {m.area_mm2:.4f} mm², "
                      f"{res.n_dofs} dofs" + (
                          f" (change {100 * row['change_max_pressure']:+.3f} %, "
                          f"{100 * row['change_area']:+.3f} %)" if "change_area" in row
                          else ""), flush=True)
    return rows


def hertz_rows(size_mm: float) -> list[dict]:
    """Section 2: a 60 mm block under 20 N against Hertz (element size `size_mm` under the
    contact)."""
    rows = []
    for nu in (0.49, 0.4999):
        hz = hertz_sphere_on_plane(20.0, 25.5, E_MPA, nu)
        for form in FORMS:
            res = axisym_sphere_on_layer(20.0, 25.5, E_MPA, nu, 60.0, layer_radius_mm=80.0,
                                         size_mm=size_mm, formulation=form)
            m = res.metrics
            row = {"section": "hertz block", "nu": nu, "formulation": form, "size_mm": size_mm,
                   "max_pressure_MPa": m.max_pressure_MPa, "area_mm2": m.area_mm2,
                   "err_max_pressure": m.max_pressure_MPa / hz.max_pressure_MPa - 1,
                   "err_area": np.sqrt(m.area_mm2 / hz.area_mm2) - 1}
            rows.append(row)
            print(f"Hertz block ν {nu:<6} {form:12s}: p_max "
                  f"{100 * row['err_max_pressure']:+.2f} %, contact radius "
                  f"{100 * row['err_area']:+.2f} %", flush=True)
    return rows


def scene_rows(reference_size: float) -> list[dict]:
    """Section 3: `fecheck fe` (compartment mode) on the baseline per ν and form."""
    import fecheck.fe.knee.crosscheck as cc
    from fecheck.scene import load_scene

    rows = []
    for nu in POISSON:
        for form in FORMS:
            scene = load_scene(None, [f"contact.poisson={nu}", f"fe.formulation={form}"])
            try:
                t = time.process_time()
                res = cc.cross_check(scene, mode="compartment", log=None)
                cpu = time.process_time() - t
            except FecheckError as exc:                 # a refusal is a result here
                rows.append({"section": "fecheck fe", "nu": nu, "formulation": form,
                             "note": str(exc)})
                print(f"fecheck fe ν {nu:<6} {form:12s}: {exc}", flush=True)
                continue
            dofs = sum(c.layer.solid.n_dofs for c in res.compartments.values())
            fe_wall = res.timing_s["fe"]
            fe_cpu = cpu * fe_wall / res.timing_s["total"]    # the FE's share (by wall time)
            for name, chk in res.compartments.items():
                ref = axisym_sphere_on_layer(chk.fe.force_N, RADII[name], E_MPA, nu, H_MM,
                                             size_mm=reference_size,
                                             formulation="mixed").metrics
                row = {"section": "fecheck fe", "nu": nu, "formulation": form,
                       "compartment": name, "levels": res.settings.levels(nu),
                       "max_pressure_MPa": chk.fe.max_pressure_MPa,
                       "area_mm2": chk.fe.area_mm2,
                       "err_max_pressure": chk.fe.max_pressure_MPa / ref.max_pressure_MPa - 1,
                       "err_area": chk.fe.area_mm2 / ref.area_mm2 - 1, "n_dofs": dofs,
                       "cpu_s": fe_cpu, "cpu_us_per_dof": 1e6 * fe_cpu / dofs}
                rows.append(row)
                print(f"fecheck fe ν {nu:<6} {form:12s} {name:8s}: p_max "
                      f"{100 * row['err_max_pressure']:+.2f} %, area "
                      f"{100 * row['err_area']:+.2f} %, {dofs} dofs, FE {fe_cpu:.1f} s CPU "
                      f"({row['cpu_us_per_dof']:.0f} µs/dof)", flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--out", type=Path, default=Path("out/fe"))
    args = parser.parse_args()
    sizes = (0.1, 0.05) if args.quick else (0.025, 0.0125)
    rows = reference_rows(sizes) + hertz_rows(0.1 if args.quick else 0.05)
    if not args.quick:
        rows += scene_rows(sizes[-1])
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "fe_incompressible.csv"
    fields = list(dict.fromkeys(k for row in rows for k in row))
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
