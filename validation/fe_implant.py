"""Closed tibial solid against the extruded layer: a sphere in a thick cylinder against
Hertz, and a generated total knee replacement.

1. Cylinder (radius 15 mm, height 15 mm, base fixed, wall free) under a rigid sphere
   (R 25.5 mm, E 20 MPa, ν 0.3, 18 N: Hertz contact radius 2.50 mm, a/h 0.17): the
   closed solid (`fecheck.fe.bodies.volume`, Gmsh tetrahedra), the layer extruded from the
   same top disc by the same 15 mm (`fecheck.fe.bodies.solid`), the axisymmetric FE of the same
   finite cylinder and Hertz.
2. The implant pair of `geometry.synthetic.implant` (toroidal condyles on a dished
   UHMWPE insert, E 463 MPa, ν 0.45, 2,000 N, z free), the condyles 0.5 and 1.5 mm
   anterior of the dwells (contact on 6° and 18° slopes), through `fecheck fe`: the
   insert as a closed solid (base fixed, walls free), as the layer of the solid's own
   thickness map (fe.body = 'layer'), and as a uniform layer of contact.thickness_mm
   (7 mm, no solid), with the EF. Per compartment p_max, area, centre of pressure y and
   a/h (contact radius over the insert's thickness under the centre of pressure), and
   each layer's deviation from the solid.

    python validation/fe_implant.py [--quick] [--out DIR]

--quick: a coarser cylinder and insert, one offset, no uniform layer. Writes
DIR/fe_implant.csv.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from pathlib import Path

import numpy as np

from fecheck.fe.bodies.indenter import SphereIndenter
from fecheck.fe.bodies.pose import FramePose
from fecheck.fe.bodies.solid import layer_solid
from fecheck.fe.bodies.volume import TibiaSolid, solid_layers
from fecheck.fe.knee.crosscheck import cross_check
from fecheck.fe.pressure.recovery import zero_contour_area
from fecheck.fe.reference.axisym import axisym_sphere_on_layer
from fecheck.fe.solve.joint import ContactLayer, JointContact
from fecheck.reference.closed_forms import hertz_sphere_on_plane
from fecheck.scene import load_scene
from fecheck.scene.tibia_solid import up_facing
from geometry.mesh import submesh

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from geometry.synthetic.implant import cylinder_solid, write_implant

R, E, NU, F, RC, H = 25.5, 20.0, 0.3, 18.0, 15.0, 15.0
UP = np.array([0.0, 0.0, 1.0])


def _press(solid, force: float) -> tuple[float, float, float]:
    """p_max (MPa), contact radius (mm) and depth (mm) of the sphere pushed into `solid`."""
    sphere = SphereIndenter(np.array([0.0, 0.0, R]), R)
    gap = sphere.gap(solid.surface.points, solid.normals).gap_mm
    joint = JointContact([ContactLayer("c", solid, sphere, np.flatnonzero(gap < 0.3))])
    sol = joint.solve(lambda q: FramePose(np.eye(3), q[0] * UP),
                      lambda q: np.concatenate([UP, np.zeros(3)])[:, None],
                      lambda q: np.array([force]), np.zeros(1))
    c = sol.layers[0]
    p = c.force_N / solid.tributary_mm2
    area = zero_contour_area(solid.surface.points, solid.surface.faces, p, c.active)
    return float(p.max()), math.sqrt(area / math.pi), float(sol.q[0])


def cylinder_rows(quick: bool) -> list[dict]:
    """Solid, layer, axisymmetric FE of the cylinder against Hertz."""
    hertz = hertz_sphere_on_plane(F, R, E, NU)
    a_h = math.sqrt(hertz.area_mm2 / math.pi)
    surface = cylinder_solid(RC, H, 1.2 if quick else 0.45, 1.5 * a_h, 4.0)
    top = up_facing(surface)
    rows = []
    t = time.perf_counter()
    solid = solid_layers(TibiaSolid(surface, {"top": top}, "cylinder"), E, NU)["top"]
    runs = {"closed solid": (solid, _press(solid, F), time.perf_counter() - t)}
    t = time.perf_counter()
    layer = layer_solid(submesh(surface, top), H, E, NU, layers=6, ratio=1.6)
    runs["extruded layer"] = layer, _press(layer, F), time.perf_counter() - t
    t = time.perf_counter()
    ax = axisym_sphere_on_layer(F, R, E, NU, H, layer_radius_mm=RC, size_mm=0.05).metrics
    runs["axisymmetric"] = None, (ax.max_pressure_MPa, math.sqrt(ax.area_mm2 / math.pi),
                                  ax.depth_mm), time.perf_counter() - t
    for name, (sol, (p, a, d), sec) in runs.items():
        rows.append({"case": "cylinder", "body": name, "compartment": "",
                     "dofs": sol.n_dofs if sol is not None else "",
                     "time_s": round(sec, 2), "p_max_MPa": p, "area_mm2": math.pi * a * a,
                     "contact_radius_mm": a, "depth_mm": d,
                     "vs_reference_p_max": p / hertz.max_pressure_MPa - 1,
                     "vs_reference_area": (a / a_h) ** 2 - 1, "reference": "Hertz"})
    return rows


def _thickness_at(check, point: np.ndarray) -> float:
    """The solid's thickness (its map on the EF sheet) nearest `point`, mm."""
    body = check.layer.body
    return float(body.thickness_mm[np.argmin(np.linalg.norm(body.surface.points - point,
                                                             axis=1))])


def implant_rows(out: Path, quick: bool) -> list[dict]:
    """Solid, solid-thickness layer and uniform layer of the implant pair, and the EF."""
    rows = []
    offsets = (0.5,) if quick else (0.5, 1.5)
    bodies = {"closed solid": ["fe.body='solid'"],
              "layer, solid's thickness": ["fe.body='layer'"]}
    if not quick:
        bodies["layer, uniform 7 mm"] = ["geometry.tibia_solid=''"]
    for offset in offsets:
        scene_path = write_implant(out / f"implant_y{offset:g}", offset,
                                   fine_mm=2.0 if quick else 1.0)
        solid = {}
        for name, overrides in bodies.items():
            check = cross_check(load_scene(scene_path, overrides), log=None)
            for c, chk in check.compartments.items():
                fe = chk.fe
                a = math.sqrt(fe.area_mm2 / math.pi)
                h = _thickness_at(chk, fe.center_of_pressure_mm) if name != \
                    "layer, uniform 7 mm" else 7.0
                row = {"case": f"implant, condyles {offset:g} mm anterior", "body": name,
                       "compartment": c, "dofs": check.geometry["dofs"],
                       "time_s": round(check.timing_s["fe"], 2),
                       "p_max_MPa": fe.max_pressure_MPa, "area_mm2": fe.area_mm2,
                       "contact_radius_mm": a, "a_over_h": a / h,
                       "cop_y_mm": fe.center_of_pressure_mm[1], "force_N": fe.force_N,
                       "ef_p_max_MPa": chk.ef_model.max_pressure_MPa,
                       "ef_area_mm2": chk.ef_model.area_mm2,
                       "ef_cop_y_mm": chk.ef_model.center_of_pressure_mm[1],
                       "reference": "closed solid"}
                if name == "closed solid":
                    solid[c] = row
                base = solid[c]
                row["vs_reference_p_max"] = row["p_max_MPa"] / base["p_max_MPa"] - 1
                row["vs_reference_area"] = row["area_mm2"] / base["area_mm2"] - 1
                row["cop_y_shift_mm"] = row["cop_y_mm"] - base["cop_y_mm"]
                rows.append(row)
    return rows


def _print(rows: list[dict]) -> None:
    print(f"{'case':34s} {'body':25s} {'comp':8s} {'dofs':>7s} {'FE s':>6s} {'p_max':>7s} "
          f"{'area':>7s} {'a/h':>5s} {'CoP y':>6s} | {'dp_max':>7s} {'darea':>7s} "
          f"{'dCoP':>6s}")
    for r in rows:
        print(f"{r['case']:34s} {r['body']:25s} {r['compartment']:8s} {str(r['dofs']):>7s} "
              f"{r['time_s']:6.1f} {r['p_max_MPa']:7.3f} {r['area_mm2']:7.1f} "
              f"{r.get('a_over_h', math.nan):5.2f} {r.get('cop_y_mm', math.nan):6.2f} | "
              f"{100 * r['vs_reference_p_max']:+6.1f}% {100 * r['vs_reference_area']:+6.1f}% "
              f"{r.get('cop_y_shift_mm', math.nan):+6.2f}   (vs {r['reference']})")
    efs = [r for r in rows if r["body"] == "closed solid" and "ef_p_max_MPa" in r]
    for r in efs:
        print(f"EF, {r['case']}, {r['compartment']}: p_max {r['ef_p_max_MPa']:.3f} MPa, area "
              f"{r['ef_area_mm2']:.1f} mm², CoP y {r['ef_cop_y_mm']:.2f} mm")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--out", type=Path, default=Path("out/fe_implant"))
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    rows = cylinder_rows(args.quick) + implant_rows(args.out, args.quick)
    _print(rows)
    keys = list(dict.fromkeys(k for r in rows for k in r))
    path = args.out / "fe_implant.csv"
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=keys)
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
