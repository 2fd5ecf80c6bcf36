"""FE on a thick block against Hertz (acceptance: p_max and contact radius to 3%).

Scene `validation/scenes/fe_hertz_block.toml`: the medial condyle sphere pressed with
load.force_N on a layer of thickness contact.thickness_mm (60 mm: contact radius / h ≈
0.04) over a disc of mesh.plateau_radius_mm, bonded at its base. The axisymmetric FE and
the general 3D path of `fecheck fe` (`fecheck.fe.reference.sphere_layer.sphere_on_flat_layer`:
mesh.plateau_refine_mm under the contact, mesh.plateau_size_mm away from it, fe.layers
levels graded by fe.grading) are compared with Hertz (rigid sphere on an elastic
half-space). The depth is reported but not judged: a finite block's displacement under
the contact depends on its far field (the half-space's decays like 1/r), so it sits a
few percent below Hertz.

    python validation/fe_hertz_block.py [--quick] [--out DIR]

--quick skips the 3D solve. Writes DIR/fe_hertz_block.csv and DIR/fe_hertz_block.png.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

import numpy as np

from fecheck.fe.bodies.settings import FESettings
from fecheck.fe.reference.axisym import axisym_sphere_on_layer
from fecheck.fe.reference.sphere_layer import sphere_on_flat_layer
from fecheck.reference.closed_forms import hertz_sphere_on_plane
from fecheck.scene import load_scene

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.studies.thesis.report import save_figure

SCENE = Path(__file__).resolve().parent / "scenes" / "fe_hertz_block.toml"
TOLERANCE = 0.03


def solves(scene, quick: bool) -> dict:
    """{model: (FE result, wall time s)}: axisymmetric, and 3D unless `quick`."""
    fe = FESettings.from_scene(scene)
    load = scene["load.force_N"]
    radius = scene.knee.radius_mm("medial")
    mat = (scene["contact.youngs_MPa"], scene["contact.poisson"], scene["contact.thickness_mm"])
    disc = scene["mesh.plateau_radius_mm"]
    runs = {}
    t = time.perf_counter()
    res = axisym_sphere_on_layer(load, radius, *mat, layer_radius_mm=disc,
                                 size_mm=fe.axisym_size_mm, solver=fe.solver)
    runs["axisymmetric"] = res, time.perf_counter() - t
    if not quick:
        t = time.perf_counter()
        res = sphere_on_flat_layer(load, radius, *mat,
                                   refine_size_mm=scene["mesh.plateau_refine_mm"],
                                   size_mm=scene["mesh.plateau_size_mm"], disc_radius_mm=disc,
                                   layers=fe.layers, grading=fe.grading, solver=fe.solver)
        runs["3d"] = res, time.perf_counter() - t
    return runs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--out", type=Path, default=Path("out/fe"))
    args = parser.parse_args()
    scene = load_scene(SCENE)
    load, radius = scene["load.force_N"], scene.knee.radius_mm("medial")
    E, nu, h = (scene["contact.youngs_MPa"], scene["contact.poisson"],
                scene["contact.thickness_mm"])
    hertz = hertz_sphere_on_plane(load, radius, E, nu)
    a_hertz = np.sqrt(hertz.area_mm2 / np.pi)
    print(f"Hertz: {load} N, R {radius:.1f} mm: p0 {hertz.max_pressure_MPa:.4f} MPa, "
          f"a {a_hertz:.4f} mm, d {hertz.depth_mm:.4f} mm; a/h = {a_hertz / h:.3f}")
    runs = solves(scene, args.quick)
    rows = []
    for name, (res, sec) in runs.items():
        m = res.metrics
        a = np.sqrt(m.area_mm2 / np.pi)
        row = {"model": name, "n_dofs": res.n_dofs, "time_s": round(sec, 3),
               "max_pressure_MPa": m.max_pressure_MPa, "contact_radius_mm": a,
               "depth_mm": m.depth_mm,
               "err_max_pressure": m.max_pressure_MPa / hertz.max_pressure_MPa - 1,
               "err_contact_radius": a / a_hertz - 1, "err_depth": m.depth_mm / hertz.depth_mm - 1}
        ok = max(abs(row["err_max_pressure"]), abs(row["err_contact_radius"])) <= TOLERANCE
        row["within_3pct"] = ok
        rows.append(row)
        print(f"{name:13s} {res.n_dofs:7d} dofs {sec:6.2f} s: p_max "
              f"{100 * row['err_max_pressure']:+.2f}%, contact radius "
              f"{100 * row['err_contact_radius']:+.2f}%, depth {100 * row['err_depth']:+.2f}% "
              f"-> {'PASS' if ok else 'FAIL'} (3% on p_max and radius)")
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "fe_hertz_block.csv"
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {path}")
    plot(runs, hertz, a_hertz, args.out / "fe_hertz_block.png")


def plot(runs: dict, hertz, a_hertz: float, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for name, (res, _) in runs.items():
        r = np.hypot(res.points[:, 0], res.points[:, 1])
        style = "-" if name == "axisymmetric" else "."
        order = np.argsort(r) if name == "axisymmetric" else slice(None)
        ax.plot(r[order], res.pressure_MPa[order], style, ms=3, label=f"FE {name}")
    r = np.linspace(0, 1.5 * a_hertz, 300)
    ax.plot(r, hertz.max_pressure_MPa * np.sqrt(np.clip(1 - (r / a_hertz) ** 2, 0, None)),
            "--k", label="Hertz")
    ax.set_xlim(0, 1.5 * a_hertz)
    ax.set_xlabel("r (mm)")
    ax.set_ylabel("contact pressure (MPa)")
    ax.set_title("thick block vs Hertz")
    ax.grid(alpha=0.3)
    ax.legend()
    print(f"wrote {save_figure(fig, path)}")


if __name__ == "__main__":
    main()
