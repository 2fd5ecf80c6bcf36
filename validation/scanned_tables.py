"""Scanned-knee scenes beside thesis Tables 5.9, 5.10 and 5.11, with pressure maps.

Runs ``validation/scenes/{inclined,polynomial,sphere_tibia,femur_tibia}{,_ligaments}.toml``
(the lenhart2015 knee: spheres and plateaus fitted to it, its own meshes and ligament
bundles, 800 N at its ankle centre), checks each equilibrium by hand statics (contact +
ligaments + load + weight = 0 along the free DOFs, relative to the load), prints the
inclined, polynomial and femur/tibia results beside the thesis's tables, and writes
off-screen pyvista PNGs of the tibial cartilage pressure (MPa) for the scanned models
(thesis Figs. 5.18, 5.21), the tibia bone drawn grey around it so that the eminence shows.

Why the numbers differ from the thesis: another subject (lenhart2015, a young adult
female, against the thesis's scans), the landmarks and load point of that subject (the
load on its mechanical axis at x = -1.8 mm, medial of the plateau centre, where the
thesis put it 7.9 mm lateral: the medial compartment carries more here), exact clipped
contact areas (the thesis counted whole faces: area up, depth down), and for the scanned
models the cartilage thickness from the meshes (tibial + femoral ≈ 3.5 mm in series)
instead of the thesis's uniform 6 mm. Extra femur_tibia rows switch to the thesis's
choices one at a time: ``uniform h = 6``; ``thesis lever`` (the load point that splits
the load between the scanned contact points in the thesis's rigid-lever ratio, 58 %
lateral); and all of them with whole-face area counting. A last row runs the thesis's
ray-parity detection on the open femoral sheet, to show how it fails there.

    python validation/scanned_tables.py [--quick] [--out DIR]

--quick decimates the scanned meshes to 2,000 tibial faces and leaves out the ray-parity
row. Writes DIR/scanned_tables.csv and DIR/<scene>_pressure.png.
"""

from __future__ import annotations

import csv
import os
import sys
from pathlib import Path

import numpy as np

from fecheck.model.assembly import ContactModel
from fecheck.model.run import run_scene
from fecheck.model.scanned import build_compartments, bundle_springs
from fecheck.scene import apply_overrides, load_scene, surfaces
from fecheck.statics.newton import pose

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.scene import lenhart
from fecheck.studies.thesis import thesis_values as tv
from fecheck.studies.thesis.report import knee_script_args

SCENES = Path(__file__).resolve().parent / "scenes"
NAMES = ("inclined", "polynomial", "sphere_tibia", "femur_tibia")
THESIS = {"inclined": ("Table 5.9", tv.TABLE_5_9_INCLINED),
          "polynomial": ("Table 5.10", tv.TABLE_5_10_POLYNOMIAL),
          "sphere_tibia": ("Table 5.9 (the thesis: 'very similar')", tv.TABLE_5_9_INCLINED),
          "femur_tibia": ("Table 5.11", tv.TABLE_5_11_SCANNED)}
SCANNED_TIBIA = ("sphere-tibia", "femur-tibia")
"""Model kinds that read the scanned tibial cartilage (and so its decimation)."""
PLOTTED = ("sphere_tibia", "femur_tibia", "femur_tibia_ligaments")
RAY_PARITY = " with the thesis's ray parity (open sheet: expected to fail)"
"""A demonstration, not an acceptance case: parity rays escape through the open femoral
sheet, so inside tibial vertices are missed (tests/model/test_scanned.py)."""


def balance(scene, result) -> float:
    """|Σ forces on the tibia| along the free translations / load (hand statics)."""
    rot, t = pose(np.asarray(result.pose.q), 0.0)
    model = ContactModel(build_compartments(scene))
    total = sum(w[:3] for w in model.wrenches(rot, t).values())
    d = np.asarray(scene["load.direction"], dtype=float)
    total = total + scene["load.force_N"] * d / np.linalg.norm(d)
    total = total + np.array([0.0, 0.0, -9.81 * scene["tibia.mass_kg"]])
    for spring in bundle_springs(scene)[1]:
        total = total + spring(rot, t)[0][:3]
    free = [i for i, n in enumerate("xyz") if n in scene["dofs.free"]]
    return float(np.linalg.norm(total[free]) / scene["load.force_N"])


def pressure_png(result, scene, path: Path) -> Path:
    """Top view of the tibial cartilage pressure (MPa, face means; the colour bar up to
    the larger printed p_max) on the grey tibia bone."""
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    from fecheck.io.plots import printed_max_pressure

    def poly(points, faces):
        return pv.PolyData(points, np.hstack([np.full((len(faces), 1), 3), faces]).ravel())

    rot, t = pose(np.asarray(result.pose.q), 0.0)
    bone = surfaces.bone(scene, "tibia")
    plotter = pv.Plotter(off_screen=True, window_size=(1000, 800))
    plotter.add_mesh(poly(bone.points @ rot.T + t, bone.faces), color="lightgrey")
    top = printed_max_pressure(result)[0]
    for name, comp in result.compartments.items():
        sheet = poly(comp.slave_points + 0.05 * np.array([0.0, 0.0, 1.0]), comp.slave_faces)
        sheet.cell_data["face pressure (MPa)"] = comp.face_pressure_MPa
        plotter.add_mesh(sheet, scalars="face pressure (MPa)", cmap="viridis", clim=(0.0, top),
                         scalar_bar_args={"title": "face pressure (MPa)", "position_x": 0.25,
                                          "position_y": 0.02, "width": 0.5, "fmt": "%.2f"},
                         show_scalar_bar=name == "medial")
    plotter.view_xy()
    plotter.camera.zoom(1.25)
    c = result.compartments
    plotter.add_text(f"{result.scene}: medial {c['medial'].force_N:.0f} N, p_max "
                     f"{c['medial'].max_pressure_MPa:.2f} MPa | lateral "
                     f"{c['lateral'].force_N:.0f} N, p_max {c['lateral'].max_pressure_MPa:.2f}"
                     f" MPa  (top view, x right = lateral, y up = anterior)", font_size=9)
    plotter.screenshot(str(path))
    plotter.close()
    return path


def thesis_lever_load_point() -> list[float]:
    """Load point (mm) splitting the load between the scanned contact points as the
    thesis's x = +7.9 mm splits it between its own (-20.4 and 28.3 mm): 58.1 % lateral
    for a rigid lever."""
    lm = lenhart.landmarks()
    share = (7.9 - (-20.4)) / (28.3 - (-20.4))
    x_m, x_l = lm.contact_point["medial"][0], lm.contact_point["lateral"][0]
    return [round(float(x_m + share * (x_l - x_m)), 3), *map(float, lenhart.ANKLE_CENTRE_MM[1:])]


def run_all(quick: bool, out: Path) -> list[dict]:
    """Every scene, then femur_tibia with the thesis's choices one by one, with the
    balance of each and the PNGs."""
    cases = [(n + s, "", []) for n in NAMES for s in ("", "_ligaments")]
    uniform, lever = "scanned.thickness='uniform'", f"load.point_mm={thesis_lever_load_point()}"
    cases += [("sphere_tibia", " full spheres (Fig. 5.13)", ["scanned.condyle='sphere'"]),
              ("femur_tibia", " uniform h = 6", [uniform]),
              ("femur_tibia", " thesis lever", [lever]),
              ("femur_tibia", " as the thesis (h = 6, lever, whole faces)",
               [uniform, lever, "contact.area='whole-face'"])]
    if not quick:
        cases.append(("femur_tibia", RAY_PARITY, ["contact.detection='ray-parity'"]))
    rows = []
    for name, suffix, over in cases:
        scene = load_scene(SCENES / f"{name}.toml", over)
        if quick and scene["model.kind"] in SCANNED_TIBIA:
            scene = apply_overrides(scene, ["scanned.decimate_faces=2000"])
        result = run_scene(scene)
        label = name + suffix
        deepest = max(result.compartments.values(), key=lambda c: c.max_depth_mm)
        row = {"scene": label, "converged": result.converged,
               "iterations": result.iterations, "solve_s": result.timing_s["solve"],
               "balance_rel": balance(scene, result)}
        for side, comp in result.compartments.items():
            for key in tv.METRICS:
                row[f"{side}_{key}"] = getattr(comp, key)
        row["ligament_tension_N"] = sum(max(v.force_N, 0.0) for v in result.ligaments.values())
        hot = np.argmax(deepest.face_pressure_MPa)
        row["peak_x_mm"] = float(deepest.slave_points[deepest.slave_faces[hot]].mean(axis=0)[0])
        rows.append(row)
        if name in PLOTTED and not over:
            pressure_png(result, scene, out / f"{name}_pressure.png")
    return rows


def print_beside_thesis(rows: list[dict]) -> None:
    for row in rows:
        base = row["scene"].split(" ")[0].removesuffix("_ligaments")
        title, ref = THESIS[base]
        print(f"\n{row['scene']}: converged {row['converged']} in {row['iterations']} "
              f"iterations, solve {row['solve_s']:.2f} s, |ΣF|/load {row['balance_rel']:.1e}, "
              f"ligament tension {row['ligament_tension_N']:.0f} N, deepest patch's peak at "
              f"x = {row['peak_x_mm']:.1f} mm — beside {title}")
        for key in tv.METRICS:
            cells = []
            for side in ("medial", "lateral"):
                got, th = row[f"{side}_{key}"], ref[side][key]
                cells.append(f"{got:8.2f} | {th:7.2f} ({100 * (got - th) / th:+5.0f}%)")
            print(f"  {tv.METRIC_LABELS[key]:18s} " + "   ".join(cells))


def main(argv: list[str] | None = None) -> int:
    args = knee_script_args(__doc__.splitlines()[0], "scanned meshes decimated to 2,000", argv)
    if args is None:
        return 0
    args.out.mkdir(parents=True, exist_ok=True)
    rows = run_all(args.quick, args.out)
    with (args.out / "scanned_tables.csv").open("w", newline="") as fh:
        w = csv.DictWriter(fh, list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print("fecheck | thesis (deviation); medial then lateral")
    print_beside_thesis(rows)
    bad = [r["scene"] for r in rows if (not r["converged"] or r["balance_rel"] > 1e-6)
           and not r["scene"].endswith(RAY_PARITY)]
    print("\nacceptance: every scene converged with |ΣF|/load < 1e-6:", not bad, bad or "")
    return 0 if not bad else 1


if __name__ == "__main__":
    raise SystemExit(main())
