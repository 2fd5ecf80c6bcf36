"""FE of a knee that looks like a segmentation, against the FE of the smooth knee it was
voxelized from (`fecheck fe` with ``fe.prepare``).

The smooth knee is `geometry.synthetic.knee`'s (two ellipsoidal condyle caps on two
dished, bumped tibial patches); the voxel knee (`geometry.synthetic.voxel_knee`) draws its
cartilage and bone labels on a grid and takes the sheets back by marching cubes (voxel
terraces, slivers, rims curled over the cartilage edge). Both are imported with
``fecheck knee import`` (uniform 6 mm layer, the import's default scene) and solved by
``fecheck fe`` in joint mode with ``fe.prepare = "on"`` at three element sizes
``fe.size_mm`` (ratio 2 in full mode): the FE meshes each prepared sheet (rims trimmed,
remeshed as a smoothed height field), so both knees are meshed the same way and differ
only by their source surface. The raw voxel sheet itself cannot be extruded (that is the
failure this path removes). The smooth knee on its own faces (fe.prepare = "off", 0.8 mm
tibial and 0.9 mm femoral grids) is the "exact" row, the reference of every deviation:
the smooth knee prepared shows what the preparation (fe.smooth_mm) changes on a smooth
surface, the voxel knees what the segmentation adds.

Per knee, size and compartment: FE p_max on the FE surface's faces (vertex pressures
averaged over each face, the face-averaged peak), the vertex p_max and the contact area;
per quantity the observed order and extrapolation from the three sizes (generalised
Richardson, as validation/fe_scanned_convergence.py) and each knee's deviation
from the smooth knee's own FE (the "exact" row) at each size.

    python validation/fe_segmented.py [--quick] [--spacing MM] [--terraces] [--out DIR]

--quick: voxels of 0.6 mm, sizes 2 / 1.41 / 1 mm, raw variant only. Full: voxels of
0.5 mm, sizes 2 / 1 / 0.5 mm, and the noisy and decimated variants at the default size.
--terraces: every prepared knee with fe.terraces = 'on' (the smooth knee has no staircase:
its rows do not change).
Writes DIR/fe_segmented.csv.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import io
import sys
import time
from pathlib import Path

import numpy as np

from fecheck.cli import main as cli
from fecheck.fe.knee.crosscheck import cross_check
from fecheck.scene import load_scene

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from geometry.synthetic.knee import femur_mesh, tibia_mesh, write_mesh
from geometry.synthetic.voxel_knee import write_voxel_knee
from validation.fe_scanned_convergence import richardson

PLAN = {"quick": {"spacing": 0.6, "sizes": (2.0, 1.41, 1.0), "variants": ()},
        "full": {"spacing": 0.5, "sizes": (2.0, 1.0, 0.5), "variants": ("noisy", "decimated")}}
DEFAULT_SIZE_MM = 1.0


def import_knee(folder: Path, files: dict[str, Path]) -> Path:
    """`fecheck knee import` of a femur and a tibia file; the scene path."""
    scene = folder / "knee.toml"
    with contextlib.redirect_stdout(io.StringIO()):
        code = cli(["knee", "import", "--femur", str(files["femur"]), "--tibia",
                    str(files["tibia"]), "--units", "mm", "--side", "right", "-o", str(scene)])
    if code:
        raise SystemExit(f"knee import failed in {folder}")
    return scene


def smooth_knee(folder: Path) -> dict[str, Path]:
    folder.mkdir(parents=True, exist_ok=True)
    return {"femur": write_mesh(femur_mesh(), folder / "femur.stl"),
            "tibia": write_mesh(tibia_mesh(), folder / "tibia.stl")}


def solve(scene: Path, size: float | None, terraces: str = "off") -> list[dict]:
    """The FE at element size `size` (mm; None: fe.prepare = 'off', the EF faces), with
    fe.terraces = `terraces`: one row per compartment."""
    t0 = time.perf_counter()
    keys = (["fe.prepare=off"] if size is None
            else [f"fe.size_mm={size}", "fe.prepare=on", f"fe.terraces={terraces}"])
    chk = cross_check(load_scene(scene, keys), log=None)
    seconds = time.perf_counter() - t0
    rows = []
    for name, c in chk.compartments.items():
        faces = c.layer.surface.faces
        rows.append({"compartment": name, "size_mm": size,
                     "p_face_MPa": float(c.fe_pressure_MPa[faces].mean(axis=1).max()),
                     "p_max_MPa": c.fe.max_pressure_MPa, "area_mm2": c.fe.area_mm2,
                     "force_N": c.fe.force_N, "dofs": chk.geometry["dofs"],
                     "seconds": seconds})
    return rows


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="0.6 mm voxels, sizes 2/1.41/1 mm")
    p.add_argument("--out", type=Path, default=Path("out/validation"), help="output folder")
    p.add_argument("--spacing", type=float, help="voxel size, mm (default: the plan's)")
    p.add_argument("--terraces", action="store_true",
                   help="fe.terraces = 'on': voxel staircases fitted as a whole")
    args = p.parse_args(argv)
    plan = dict(PLAN["quick" if args.quick else "full"])
    if args.spacing:
        plan["spacing"] = args.spacing
    work = args.out / "fe_segmented"
    knees = {"smooth": import_knee(work / "smooth", smooth_knee(work / "smooth"))}
    for variant in ("raw", *plan["variants"]):
        folder = work / variant
        knees[variant] = import_knee(folder, write_voxel_knee(folder, plan["spacing"], variant,
                                                              bones=False))
    rows = [{"knee": "exact", **row} for row in solve(knees["smooth"], None)]
    for knee, scene in knees.items():
        sizes = plan["sizes"] if knee in ("smooth", "raw") else (DEFAULT_SIZE_MM,)
        for size in sizes:
            for row in solve(scene, size, "on" if args.terraces else "off"):
                rows.append({"knee": knee, **row})
                print(f"{knee:<9} {row['compartment']:<7} size {size:<4} p_face "
                      f"{row['p_face_MPa']:.3f} p_max {row['p_max_MPa']:.3f} area "
                      f"{row['area_mm2']:.1f} F {row['force_N']:.1f} dofs {row['dofs']} "
                      f"{row['seconds']:.1f} s", flush=True)
    print_table(rows, plan["sizes"])
    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / "fe_segmented.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    return 0


def print_table(rows: list[dict], sizes: tuple[float, ...]) -> None:
    """Per compartment and quantity: the voxel knees against the smooth one, per size, and
    the observed order and extrapolation of each three-size series."""
    def value(knee, comp, size, q):
        return next((r[q] for r in rows if r["knee"] == knee and r["compartment"] == comp
                     and r["size_mm"] == size), np.nan)

    for q in ("p_face_MPa", "p_max_MPa", "area_mm2"):
        for comp in ("medial", "lateral"):
            for knee in ("smooth", "raw"):
                vals = [value(knee, comp, s, q) for s in sizes]
                r = richardson(list(sizes), vals)
                print(f"{q:<10} {comp:<7} {knee:<6} " + " ".join(f"{v:8.3f}" for v in vals)
                      + f"  order {r['order']:.2f} extrapolated {r['extrapolated']:.3f}")
            exact = next(r[q] for r in rows if r["knee"] == "exact" and r["compartment"] == comp)
            print(f"{q:<10} {comp:<7} exact {exact:.3f} (the smooth knee's own FE: its own "
                  "faces, not prepared)")
            for knee in ("smooth", "raw"):
                print(f"{q:<10} {comp:<7} {knee}/exact-1 " + " ".join(
                    f"{100 * (value(knee, comp, s, q) / exact - 1):+.1f}%" for s in sizes))
            for knee in sorted({r["knee"] for r in rows} - {"smooth", "raw", "exact"}):
                d = value(knee, comp, DEFAULT_SIZE_MM, q) / exact - 1
                print(f"{q:<10} {comp:<7} {knee}/exact-1 at {DEFAULT_SIZE_MM:g} mm "
                      f"{100 * d:+.1f}%")


if __name__ == "__main__":
    sys.exit(main())
