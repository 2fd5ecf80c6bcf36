"""How EF, Hertz and FE differ with the cartilage's material and thickness.

1. Materials (thesis Tables 5.4, 5.5): ν = 0.15, 0.3, 0.45, 0.49 at E 20 MPa and E = 9,
   15, 20, 30 MPa at ν 0.3, both baseline compartments under the rigid Table 5.1 loads
   (medial 323.71 N on R 25.5 mm, lateral 456.67 N on R 31.8 mm), h 6 mm: the
   axisymmetric FE (0.1 mm, validated against the 3D model by tests/fe/test_fe_sphere_layer.py
   and validation/fe_convergence.py), the EF law and Hertz at the same load.
2. Thickness: the medial load on layers from 1.5 to 40 mm (ν 0.3 and 0.45), to show when
   EF can be trusted as a function of contact radius / h.

    python validation/fe_materials.py [--quick] [--out DIR]

--quick: ν 0.3 and 0.49, E 20, h 3, 6, 12. Writes DIR/fe_materials.csv,
DIR/fe_thickness.csv and DIR/fe_thickness.png, and prints a summary.
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import numpy as np

from fecheck.fe.reference.axisym import axisym_sphere_on_layer
from fecheck.reference.closed_forms import ef_sphere_on_plane, hertz_sphere_on_plane

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.studies.thesis.report import save_figure

COMPARTMENTS = {"medial": (323.71, 25.5), "lateral": (456.67, 31.8)}
SIZE_MM = 0.1


def compare(load: float, radius: float, E: float, nu: float, h: float) -> dict:
    """FE (axisymmetric), EF and Hertz at one load; relative EF and Hertz deviations."""
    fe = axisym_sphere_on_layer(load, radius, E, nu, h, size_mm=min(SIZE_MM, h / 10),
                                layer_radius_mm=max(30.0, 2 * h)).metrics
    ef = ef_sphere_on_plane(load, radius, E, nu, h)
    hz = hertz_sphere_on_plane(load, radius, E, nu)
    row = {"E_MPa": E, "nu": nu, "h_mm": h, "load_N": load, "radius_mm": radius,
           "a_fe_over_h": np.sqrt(fe.area_mm2 / np.pi) / h}
    for name, m in (("fe", fe), ("ef", ef), ("hertz", hz)):
        row[f"{name}_max_pressure_MPa"] = m.max_pressure_MPa
        row[f"{name}_area_mm2"] = m.area_mm2
        row[f"{name}_depth_mm"] = m.depth_mm
    for name in ("ef", "hertz"):
        row[f"{name}_vs_fe_max_pressure"] = (row[f"{name}_max_pressure_MPa"]
                                             / fe.max_pressure_MPa - 1)
        row[f"{name}_vs_fe_area"] = row[f"{name}_area_mm2"] / fe.area_mm2 - 1
    return row


def write(rows: list[dict], path: Path) -> None:
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {path}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--out", type=Path, default=Path("out/fe"))
    args = parser.parse_args()
    nus = (0.3, 0.49) if args.quick else (0.15, 0.3, 0.45, 0.49)
    youngs = (20.0,) if args.quick else (9.0, 15.0, 20.0, 30.0)
    thick = (3.0, 6.0, 12.0) if args.quick else (1.5, 2.0, 3.0, 4.0, 6.0, 9.0, 12.0, 20.0, 40.0)
    cases = sorted({(20.0, nu) for nu in nus} | {(E, 0.3) for E in youngs})
    materials = []
    print(f"{'':8s}{'E':>5s}{'ν':>6s}{'a/h':>6s} | p_max MPa: {'FE':>6s}{'EF':>7s}{'Hertz':>7s}"
          f" | area mm²: {'FE':>6s}{'EF':>7s}{'Hertz':>7s}")
    for comp, (load, radius) in COMPARTMENTS.items():
        for E, nu in cases:
            row = {"compartment": comp, **compare(load, radius, E, nu, 6.0)}
            materials.append(row)
            print(f"{comp:8s}{E:5.0f}{nu:6.2f}{row['a_fe_over_h']:6.2f} | {'':11s}"
                  f"{row['fe_max_pressure_MPa']:6.2f}{row['ef_max_pressure_MPa']:7.2f}"
                  f"{row['hertz_max_pressure_MPa']:7.2f} | {'':10s}{row['fe_area_mm2']:6.0f}"
                  f"{row['ef_area_mm2']:7.0f}{row['hertz_area_mm2']:7.0f}")
    args.out.mkdir(parents=True, exist_ok=True)
    write(materials, args.out / "fe_materials.csv")
    load, radius = COMPARTMENTS["medial"]
    thickness = [compare(load, radius, 20.0, nu, h) for nu in (0.3, 0.45) for h in thick]
    write(thickness, args.out / "fe_thickness.csv")
    print("\nmedial load on layers of thickness h (E 20 MPa): EF and Hertz vs FE")
    for row in thickness:
        print(f"  ν {row['nu']:.2f} h {row['h_mm']:5.1f} mm  a/h {row['a_fe_over_h']:5.2f}: "
              f"EF p_max {100 * row['ef_vs_fe_max_pressure']:+6.1f}% area "
              f"{100 * row['ef_vs_fe_area']:+6.1f}%; Hertz p_max "
              f"{100 * row['hertz_vs_fe_max_pressure']:+6.1f}% area "
              f"{100 * row['hertz_vs_fe_area']:+6.1f}%")
    summary(materials, thickness)
    plot(thickness, args.out / "fe_thickness.png")


def summary(materials: list[dict], thickness: list[dict]) -> None:
    print("\nsummary (FE = axisymmetric bonded layer, the reference)")
    for nu in sorted({r["nu"] for r in materials}):
        sub = [r for r in materials if r["nu"] == nu]
        p = [100 * r["ef_vs_fe_max_pressure"] for r in sub]
        a = [100 * r["ef_vs_fe_area"] for r in sub]
        print(f"- h 6 mm, ν {nu}: EF p_max {min(p):+.0f}% to {max(p):+.0f}%, EF area "
              f"{min(a):+.0f}% to {max(a):+.0f}% against FE ({len(sub)} runs)")
    print("  EF's k = (1-ν)E/((1+ν)(1-2ν)h) is the confined-compression stiffness of a column "
          "that cannot bulge; a bonded layer bulges at the contact edge, so EF over-stiffens "
          "as ν → 0.5 and, at ν ≤ 0.3, spreads the load over a wider area than the layer.")
    for nu in sorted({r["nu"] for r in thickness}):
        rows = [r for r in thickness if r["nu"] == nu]
        good = [r["a_fe_over_h"] for r in rows
                if abs(r["ef_vs_fe_max_pressure"]) <= 0.1 and abs(r["ef_vs_fe_area"]) <= 0.1]
        hz = [r["a_fe_over_h"] for r in rows
              if abs(r["hertz_vs_fe_max_pressure"]) <= 0.1 and abs(r["hertz_vs_fe_area"]) <= 0.1]
        text = (f"a/h ≥ {min(good):.2f}" if good else "none of the thicknesses tried")
        text_h = (f"a/h ≤ {max(hz):.2f}" if hz else "none of the thicknesses tried")
        print(f"- ν {nu}: EF within 10% of FE on p_max and area for {text}; "
              f"Hertz within 10% for {text_h}")


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharex=True)
    for nu, style in ((0.3, "o-"), (0.45, "s--")):
        sub = [r for r in rows if r["nu"] == nu]
        x = [r["a_fe_over_h"] for r in sub]
        for ax, key in ((axes[0], "max_pressure"), (axes[1], "area")):
            ax.plot(x, [100 * r[f"ef_vs_fe_{key}"] for r in sub], style, color="C3",
                    label=f"EF, ν {nu}")
            ax.plot(x, [100 * r[f"hertz_vs_fe_{key}"] for r in sub], style, color="C2",
                    label=f"Hertz, ν {nu}")
    for ax, key in ((axes[0], "p_max"), (axes[1], "contact area")):
        ax.axhline(0, color="k", lw=0.8)
        ax.axhspan(-10, 10, color="grey", alpha=0.15)
        ax.set_xscale("log")
        ax.set_xlabel("FE contact radius / layer thickness")
        ax.set_ylabel(f"{key}: deviation from FE (%)")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    print(f"wrote {save_figure(fig, path)}")


if __name__ == "__main__":
    main()
