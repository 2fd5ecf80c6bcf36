"""`fecheck flex SCENE --angles A:B:STEP`: driven knee flexion of a femur-tibia scene.

The tibia is turned about the knee's flexion axis (``--axis-point`` and ``--axis-dir``, or
the scene's flexion.axis_point_mm and flexion.axis_dir, or else the axis through the
centres of spheres fitted to the posterior condyles of the femoral surface) and its other
DOFs solved at each angle under the scene's load, ligaments and gravity, each angle from
the last (`fecheck.studies.flex`); ``--fe-at`` runs the FE cross-check at chosen angles
from their EF poses. Progress goes to standard error and a per-angle table (signs stated)
to standard output (to standard error when --csv or --json takes standard output); Ctrl-C,
or an angle that does not solve, stops the run and the angles solved so far are written.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from fecheck.cli import add_scene_arguments


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "flex", help="driven knee flexion: secondary kinematics, contact and ligaments",
        description="Turn the tibia about the knee flexion axis through a range of angles, "
                    "solving its other DOFs at each, and report the secondary kinematics, "
                    "compartment forces, centres of pressure, contact areas and ligament "
                    "forces per angle.")
    add_scene_arguments(p, "override a scene key, value as a TOML literal")
    p.add_argument("--angles", default="0:120:1", metavar="A:B:STEP",
                   help="knee flexion angles, deg: START:STOP:STEP (inclusive) or a comma "
                        "list (default 0:120:1); an angle not reached from the last in one "
                        "step is approached in 1° steps")
    p.add_argument("--axis-point", metavar="X,Y,Z",
                   help="a point of the flexion axis, mm (with --axis-dir; default: the scene's "
                        "flexion.axis_point_mm, else fitted)")
    p.add_argument("--axis-dir", metavar="X,Y,Z",
                   help="the flexion axis direction (with --axis-point)")
    p.add_argument("--fe-at", metavar="A,B,...",
                   help="run the FE cross-check at these angles of --angles, deg, from the EF "
                        "poses (the flexion held, the other DOFs free; with patella.dir the "
                        "patellar cartilage a layer too, the patella's six DOFs free): a table "
                        "on standard error and the JSON's 'fe'")
    p.add_argument("--csv", metavar="PATH", help="one row per angle ('-': stdout)")
    p.add_argument("--json", metavar="PATH", help="axis and every angle ('-': stdout)")
    p.add_argument("--plot", type=Path, metavar="DIR",
                   help="write DIR/kinematics.png and DIR/contact_paths.png")
    p.add_argument("--vtk", type=Path, metavar="DIR",
                   help="write DIR/flex.pvd (ParaView time series): per angle the tibial "
                        "surfaces and the ligament lines, and the femur; its size is "
                        "estimated first and refused above 2000 MB without --force")
    p.add_argument("--force", action="store_true",
                   help="write a --vtk series larger than the 2000 MB cap")
    p.set_defaults(run=run)


def _vector(text: str | None, option: str) -> list[float] | None:
    from fecheck.errors import FecheckError

    if text is None:
        return None
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise FecheckError(f"{option} {text!r}: give three finite numbers X,Y,Z")
    return values


def _axis(args: argparse.Namespace, scene):
    from fecheck.errors import FecheckError
    from fecheck.studies import flex

    point, direction = _vector(args.axis_point, "--axis-point"), _vector(args.axis_dir,
                                                                           "--axis-dir")
    if (point is None) != (direction is None):
        raise FecheckError("give both --axis-point and --axis-dir, or neither (fitted axis)")
    if point is not None:
        flex.check_kind(scene)
        return flex.given_axis(point, direction)
    return flex.scene_axis(scene)


def _progress(total: int, out):
    def show(i: int, p) -> None:
        c = p.compartments
        forces = "  ".join(f"{k} {v['force_N']:.0f} N" for k, v in c.items())
        print(f"flex [{i + 1}/{total}] {p.flexion_deg:g}°: internal rotation "
              f"{p.internal_rotation_deg:+.2f}°, adduction {p.adduction_deg:+.2f}°, {forces} "
              f"({p.seconds:.2f} s)",
              file=out, flush=True)
    return show


def _fe_table(rows: list[dict], out) -> None:
    """The FE-vs-EF table of the --fe-at angles, one line per angle and compartment."""
    if not rows:
        return
    print("FE vs EF at the --fe-at angles (p_max face-averaged MPa, area mm², split, centre "
          "of pressure x, y mm tibia frame; with the patella, PF: its contact force N and "
          "centre of pressure x, y, z mm patella frame):", file=out)
    for r in rows:
        if "fe_error" in r:
            print(f"  {r['flexion_deg']:5g}° FE failed: {r['fe_error']}", file=out)
            continue
        for c in ("medial", "lateral"):
            print(f"  {r['flexion_deg']:5g}° {c:8s} p_max {r[f'{c}_fe_p_max_MPa']:6.3f} vs "
                  f"{r[f'{c}_ef_p_max_MPa']:6.3f}  area {r[f'{c}_fe_area_mm2']:6.1f} vs "
                  f"{r[f'{c}_ef_area_mm2']:6.1f}  split {r[f'{c}_fe_split']:.3f} vs "
                  f"{r[f'{c}_ef_split']:.3f}  CoP ({r[f'{c}_fe_cop_x_mm']:.1f}, "
                  f"{r[f'{c}_fe_cop_y_mm']:.1f}) vs ({r[f'{c}_ef_cop_x_mm']:.1f}, "
                  f"{r[f'{c}_ef_cop_y_mm']:.1f})", file=out)
        if "PF_fe_force_N" in r:
            print(f"  {r['flexion_deg']:5g}° {'PF':8s} force {r['PF_fe_force_N']:6.1f} vs "
                  f"{r['PF_ef_force_N']:6.1f} N  p_max {r['PF_fe_p_max_MPa']:6.3f} vs "
                  f"{r['PF_ef_p_max_MPa']:6.3f}  area {r['PF_fe_area_mm2']:6.1f} vs "
                  f"{r['PF_ef_area_mm2']:6.1f}  CoP ({r['PF_fe_cop_x_mm']:.1f}, "
                  f"{r['PF_fe_cop_y_mm']:.1f}, {r['PF_fe_cop_z_mm']:.1f}) vs "
                  f"({r['PF_ef_cop_x_mm']:.1f}, {r['PF_ef_cop_y_mm']:.1f}, "
                  f"{r['PF_ef_cop_z_mm']:.1f}) patella frame", file=out)
        print(f"  {r['flexion_deg']:5g}° balanced to {r['balance']:.1e} of the load, FE "
              f"{r['fe_seconds']:.1f} s", file=out)


def _write_outputs(args: argparse.Namespace, scene, run_, out) -> None:
    from fecheck.io.outputs import write_text
    from fecheck.studies import flex, flex_outputs

    if not run_.points:
        print("no angle solved: nothing written", file=out)
        return
    taken = "-" in (str(args.csv), str(args.json))
    print(flex_outputs.table_text(run_), end="", file=out if taken else sys.stdout)
    for path, text in ((args.csv, flex_outputs.csv_text),
                       (args.json, lambda r: flex_outputs.json_text(r, scene))):
        if path is not None:
            write_text(path, text(run_))
            if str(path) != "-":
                print(f"wrote {path}", file=out)
    if args.vtk is not None:
        bone = flex.femur_bone(scene)
        size = flex_outputs.check_vtk_size(run_, bone, args.force)
        print(f"writing the VTK series to {args.vtk}: at most {size / 1e6:.1f} MB "
              f"({len(run_.points)} angles)", file=out, flush=True)
        pvd = flex_outputs.write_vtk_series(run_, args.vtk, bone)
        written = sum(f.stat().st_size for f in Path(args.vtk).glob("*.vt[up]"))
        print(f"wrote {pvd} ({written / 1e6:.1f} MB)", file=out)
    if args.plot is not None:
        for path in flex_outputs.write_plots(run_, args.plot):
            print(f"wrote {path}", file=out)


def run(args: argparse.Namespace) -> int:
    from fecheck.io.outputs import check_output
    from fecheck.scene import load_scene
    from fecheck.studies import flex

    angles = flex.parse_angles(args.angles)
    fe_at = flex.parse_fe_at(args.fe_at, angles)
    for attr in ("csv", "json"):
        check_output(getattr(args, attr))
    for attr in ("plot", "vtk"):
        check_output(getattr(args, attr), directory=True)
    if str(args.csv) == "-" and str(args.json) == "-":
        from fecheck.errors import FecheckError

        raise FecheckError("only one output can go to standard output ('-'): --csv or --json")
    scene = load_scene(args.scene, args.overrides)
    axis = _axis(args, scene)
    err = sys.stderr
    print(axis.describe(), file=err, flush=True)
    result = flex.run_flex(scene, angles, axis, _progress(len(angles), err), fe_at,
                           lambda message: print(f"flex FE: {message}", file=err, flush=True))
    solve = sum(p.seconds for p in result.points)
    print(f"{len(result.points)} of {len(angles)} angles solved; build {result.build_seconds:.2f}"
          f" s, then {result.sweep_seconds:.2f} s wall for the angles (Newton {solve:.2f} s)",
          file=err)
    _fe_table(result.fe, err)
    _write_outputs(args, scene, result, err)
    failed = [f"{r['flexion_deg']:g}°" for r in result.fe if "fe_error" in r]
    if result.stopped is None and failed:
        print(f"fecheck: error: the FE failed at {', '.join(failed)} (the reason in the table "
              "above); the other angles were written", file=err)
        return 1
    if result.stopped is None:
        return 0
    if result.stopped.startswith("interrupted"):
        print(f"fecheck: {result.stopped}; the finished angles were written", file=err)
        return 130
    print(f"fecheck: error: {result.stopped}", file=err)
    return 1
