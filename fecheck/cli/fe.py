"""`fecheck fe [SCENE]`: how far is the scene's elastic-foundation answer from an FE answer
of the same geometry, materials and load?

Runs the scene's EF equilibrium, then the FE of the same tibial surfaces (extruded into
bonded quadratic-tetrahedron layers) under the same femoral surfaces, with exact
frictionless contact: by default the whole joint under the scene's load (the FE finds
its own split), or per compartment under the EF forces (``--mode compartment``). Only
the standard library is imported here.

On a scene with menisci (``menisci.dir`` set) it runs the FE of the knee with menisci at
its EF equilibrium (`fecheck.fe.knee.knee_menisci`) instead: the tibial sheets follow
``fe.prepare`` and ``fe.size_mm``, the meniscus tetrahedra are `MENISCUS_PER_SHEET` times
``fe.size_mm``; the flags without a meaning there are refused in one line before any work.

Every output path is checked before the solves (one-line error, exit 2; missing folders
are made when their first file is written); ``--json -`` writes the JSON to standard
output and the report to standard error. An undefined value prints as ``n/a`` with a
note saying why.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from pathlib import Path

from fecheck.cli import add_scene_arguments

STDOUT = "-"
COLUMNS = (("F", "force_N", 1), ("F_axial", "axial_force_N", 1),
           ("p_max", "max_pressure_MPa", 3), ("p_mean", "mean_pressure_MPa", 3),
           ("area", "area_mm2", 1), ("depth", "depth_mm", 3))
"""Table columns per compartment: header, metric attribute, decimals."""


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "fe", help="FE cross-check of the EF contact answer on the scene's own geometry",
        description="The scene's EF equilibrium, then the FE of the same tibial surfaces, "
                    "thickness, femoral surfaces, material and load: per compartment force "
                    "(magnitude and axial), p_max, p_mean, area, depth and centre of pressure "
                    "of FE and EF, the split and the pose. Scene keys [fe] set the mode, "
                    "mesh and solver. Output paths are checked before the solves. On a scene "
                    "with menisci (menisci.dir): the FE of the knee with menisci at its EF "
                    "equilibrium, per compartment and tibial region.")
    add_scene_arguments(p, "override a scene key, e.g. --set fe.layers=3")
    p.add_argument("--mode", choices=("joint", "compartment"),
                   help="joint: the FE solves the tibia's equilibrium itself (default, "
                        "fe.mode); compartment: each compartment under its EF force")
    p.add_argument("--refine", type=int, metavar="N",
                   help="split the surface triangles in four N times before the FE "
                        "(overrides fe.refine)")
    p.add_argument("--force", action="store_true",
                   help="solve beyond 500,000 FE dofs or build meshes beyond the element "
                        "limits (never beyond the available memory)")
    p.add_argument("--json", metavar="PATH",
                   help="write the comparison as JSON ('-': stdout, the report to stderr)")
    p.add_argument("--no-estimate", action="store_true",
                   help="skip the error estimate (by default the FE is solved again on a "
                        "mesh coarsened by 2 for a Richardson value and a GCI band)")
    p.add_argument("--verify", action="store_true",
                   help="add a finer level to the error estimate (fe.refine + 1, twice the "
                        "levels: about 8 times the default's dofs, refused beyond the FE "
                        "limits without --force) and report the observed order")
    p.add_argument("--plot", type=Path, metavar="DIR",
                   help="write DIR/fe_pressure_map.png: EF and FE pressure on the tibial "
                        "surface in one colour scale, and FE - EF")
    p.add_argument("--vtk", type=Path, metavar="DIR",
                   help="write DIR/<compartment>.vtu: the tibial surfaces with the FE and EF "
                        "pressure fields (meshio)")
    p.set_defaults(run=run)


# ---------------------------------------------------------------------- the table
def _number(value: float | None, decimals: int) -> str | None:
    """`value` with `decimals` decimals (3 significant digits where that would print a
    non-zero value as zero); None when undefined."""
    if value is None or not math.isfinite(value):
        return None
    text = f"{value:.{decimals}f}"
    if value != 0 and float(text) == 0:
        text = f"{value:.3g}"
    return text


def _rows(check) -> list[tuple[str, dict, str]]:
    """(label, {compartment: metrics or None}, why a missing row is missing)."""
    from fecheck.reference.closed_forms import DONAHUE_2002

    comps = check.compartments
    flat = "only for a condyle sphere on a flat (transverse) uniform layer"

    def refs(attr):
        out = {}
        for c, chk in comps.items():
            m = getattr(chk, attr)
            out[c] = m.metrics if hasattr(m, "metrics") else m
        return out

    return [("FE", {c: chk.fe for c, chk in comps.items()}, ""),
            ("EF model", {c: chk.ef_model for c, chk in comps.items()}, ""),
            ("FE axisymmetric (FE load)", refs("axisym"), f"the axisymmetric FE runs {flat}"),
            ("EF closed form (FE load)", refs("ef_closed_form"), f"closed form {flat}"),
            ("Hertz (FE load)", refs("hertz"), f"closed form {flat}"),
            ("Donahue 2002 (1 mm)*", {c: DONAHUE_2002.get(c, {}).get(1.0) for c in comps},
             "Donahue 2002 reports the tibial compartments' force, pressures and area only")]


def _value(metrics, attr: str) -> float | None:
    if metrics is None:
        return None
    if attr == "axial_force_N" and not hasattr(metrics, attr):
        return None
    return getattr(metrics, attr, None)


SPIKE_NOTE = ("the FE p_max is a lone-vertex spike, not a physical pressure: its place and "
              "the FE p_max on the EF faces and smoothed follow the table")


def _spike(check, name: str) -> bool:
    peaks = check.compartments[name].peaks
    return peaks is not None and bool(peaks.spike)


def comparison_table(check) -> str:
    """Per compartment F, F_axial (N), p_max, p_mean (MPa), area (mm²), depth (mm) of
    every row that has values; undefined values as ``n/a(k)`` with note k below the
    table, rows without any value left out with a note saying why."""
    names = list(check.compartments)
    notes: list[str] = []
    skipped: list[str] = []
    body = []
    for label, metrics, why in _rows(check):
        if all(metrics[c] is None for c in names):
            skipped.append(f"no {label} row: {why}")
            continue
        row = [label]
        for c in names:
            for head, attr, decimals in COLUMNS:
                text = _number(_value(metrics[c], attr), decimals)
                if text is None:
                    reason = why or f"{label} gives no {head}"
                    if reason not in notes:
                        notes.append(reason)
                    text = f"n/a({notes.index(reason) + 1})"
                elif label == "FE" and attr == "max_pressure_MPa" and _spike(check, c):
                    if SPIKE_NOTE not in notes:
                        notes.append(SPIKE_NOTE)
                    text = f"{text}({notes.index(SPIKE_NOTE) + 1})"
                row.append(text)
        body.append(row)
    head = [""] + [h for _ in names for h, _, _ in COLUMNS]
    widths = [max(len(r[i]) for r in body + [head]) for i in range(len(head))]
    k = len(COLUMNS)
    span = [sum(widths[1 + k * j: 1 + k * (j + 1)]) + 2 * (k - 1) for j in range(len(names))]
    lines = [" " * widths[0] + "".join(f"  {n:^{w}s}" for n, w in zip(names, span,
                                                                         strict=True))]
    for row in [head] + body:
        lines.append(f"{row[0]:<{widths[0]}s}" + "".join(
            f"  {c:>{w}s}" for c, w in zip(row[1:], widths[1:], strict=True)))
    lines.append("units: F (magnitude), F_axial (along the tibia's axis) N; p MPa; area mm²; "
                 "depth mm")
    lines += [f"({i}) {note}" for i, note in enumerate(notes, start=1)] + skipped
    return "\n".join(lines)


def peak_lines(check) -> list[str]:
    """The FE p_max at three scales per compartment (vertex, averaged on the EF faces,
    smoothed over a stated length), the lone-spike and rough-feature flags, and the
    roughness of each tibial sheet and of the femoral sheet(s); [] when the check carries
    no peaks."""
    comps = {c: chk for c, chk in check.compartments.items() if chk.peaks is not None}
    if not comps:
        return []
    out = []
    for c, chk in comps.items():
        p = chk.peaks
        flag = ""
        if p.spike:
            x, y, z = p.vertex_at_mm
            flag = f"  LONE-VERTEX SPIKE at ({x:.1f}, {y:.1f}, {z:.1f}) mm"
        elif p.rough:
            flag = f"  on a rough feature ({p.feature_mm:.3f} mm)"
        out.append(f"FE p_max {c}: vertex {p.vertex_MPa:.3f}, on the EF faces {p.face_MPa:.3f}, "
                   f"smoothed over {p.length_mm:.2f} mm {p.smoothed_MPa:.3f} MPa{flag}")
    shared = len({id(chk.femoral_roughness) for chk in comps.values()}) == 1
    for i, (c, chk) in enumerate(comps.items()):
        if chk.roughness is not None:
            kind = "tibial" if c in check.split("fe") else "patellar"
            out.append(chk.roughness.summary(f"{c} {kind} sheet"))
        femur = chk.femoral_roughness
        if femur is not None and not (shared and i):         # a shared sheet: once
            out.append(femur.summary("femoral sheet" if shared else f"{c} femoral sheet"))
    return out


def geometry_line(g: dict) -> str:
    """The FE geometry line of the report from the JSON's ``fe_geometry`` `g` (the smallest
    surface edge to three significant digits: a CAD insert's can be micrometres)."""
    two = g["deformable_layers"] == 2
    return (f"FE geometry: tibial {g['tibial_surface']}, femoral {g['femoral_surface']} "
            f"({'deformable' if two else 'rigid'}); thickness {g['thickness_source']}; "
            f"{g['deformable_layers']} deformable layer{'s' if two else ''} (fe.cartilage "
            f"{g.get('cartilage', 'series')}); {g['elements']} elements, {g['dofs']} dofs, "
            f"smallest surface edge {g['smallest_size_mm']:.3g} mm")


def summary_lines(check) -> list[str]:
    """Split, centres of pressure, pose, geometry, timing and notes below the table."""
    fe_split, ef_split = check.split("fe"), check.split("ef_model")
    names = list(fe_split)
    out = ["medial/lateral split: FE " + " / ".join(f"{100 * fe_split[c]:.1f}%" for c in names)
           + ", EF " + " / ".join(f"{100 * ef_split[c]:.1f}%" for c in names)]
    cop = []
    for c, chk in check.compartments.items():
        d = chk.cop_distance_mm
        cop.append(f"{c} {d:.2f} mm" if math.isfinite(d) else f"{c} n/a (point contact)")
    out.append("centre of pressure, FE to EF: " + ", ".join(cop))
    fe, ef = check.pose["fe"], check.pose["ef"]
    out.append(f"pose FE - EF ({check.settings.mode} mode): "
               + ", ".join(f"{k} {fe[k] - ef[k]:+.4f}" for k in fe))
    if check.extra is not None:
        out += check.extra.lines()
    out.append(geometry_line(check.geometry))
    for name, chk in check.compartments.items():
        dev = chk.deviation()
        if dev:
            out.append(f"{name}: FE vs axisymmetric FE at the same load: p_max "
                       f"{100 * dev['max_pressure']:+.2f}%, area {100 * dev['area']:+.2f}% "
                       "(the 3D discretisation error)")
    t = check.timing_s
    out.append(f"time: EF equilibrium {t['ef_equilibrium']:.2f} s, FE {t['fe']:.1f} s "
               f"(build {t['fe_build']:.1f}, condense {t['fe_condense']:.1f}, contact "
               f"{t['fe_contact']:.2f}); EF = {100 * t['ef_over_fe']:.2f}% of the FE time")
    out += [f"note: {n}" for n in check.notes]
    return out


def estimate_lines(est, mode: str = "joint") -> list[str]:
    """The error-estimate table: per compartment and quantity the value at each level,
    the extrapolated value and the GCI band of the finest level; the method, ratios and
    cost below it."""
    from fecheck.studies.estimate import QUANTITIES

    labels = [lv.label for lv in est.levels]
    head = ["", "quantity"] + labels + ["extrapolated", "GCI band"]
    rows = []
    for c, bands in est.bands.items():
        for key, label, decimals in QUANTITIES:
            b = bands[key]
            low, high = _number(b.low, decimals), _number(b.high, decimals)
            rows.append([c, label] + [_number(v, decimals) or "n/a" for v in b.values]
                        + [_number(b.extrapolated, decimals) or "n/a",
                           f"{low} to {high}" if low and high else "n/a"])
    widths = [max(len(r[i]) for r in rows + [head]) for i in range(len(head))]
    out = ["error estimate (discretization):"]
    out += ["  ".join(f"{v:<{w}s}" if i < 2 else f"{v:>{w}s}"
                      for i, (v, w) in enumerate(zip(r, widths, strict=True))).rstrip()
            for r in [head] + rows]
    levels = "; ".join(f"{lv.label} {lv.dofs} dofs, {sum(lv.faces.values())} surface faces, "
                       f"{lv.levels} levels" for lv in est.levels)
    ratios = ", ".join(f"{r:.2f}" for r in est.ratios)
    if len(est.levels) == 2:
        method = "order 2 assumed, safety factor 3 (Roache's GCI with two levels)"
    else:
        orders = [b.order for bands in est.bands.values() for b in bands.values()]
        method = ("observed order (per quantity "
                  + ", ".join(_number(p, 2) or "n/a" for p in orders)
                  + "), safety factor 1.25 (Roache's GCI with three levels)")
    out.append(f"levels: {levels}; ratio r = (dofs ratio)^(1/3) = {ratios}; {method}; the "
               "band is the finest value ± GCI; p_max faces on the default run's EF faces")
    if mode == "compartment":
        out.append("the force shares are the EF's at every level (compartment mode): no error "
                   "there")
    return out


# ---------------------------------------------------------------------- the verb
def _report_stream(args: argparse.Namespace):
    return sys.stderr if args.json is not None and str(args.json) == STDOUT else sys.stdout


def check_outputs(args: argparse.Namespace) -> None:
    """`check_output` on every output path (before any solve)."""
    from fecheck.io.outputs import check_output

    check_output(args.json)
    check_output(args.plot, directory=True)
    check_output(args.vtk, directory=True)


def write_outputs(args: argparse.Namespace, check, scene, out, est=None) -> None:
    """The --json (with the error estimate `est` under ``error_estimate``; null when
    skipped), --vtk and --plot outputs."""
    import json

    from fecheck.io.outputs import write_text
    from fecheck.scene.provenance import with_provenance

    if args.json is not None:
        data = with_provenance(check.as_dict() | {
            "error_estimate": None if est is None else est.as_dict()}, scene)
        write_text(args.json, json.dumps(data, indent=2) + "\n")
        if str(args.json) != STDOUT:
            print(f"wrote {args.json}", file=out)
    if args.vtk:
        from fecheck.io.vtk import write_fe_vtk

        for path in write_fe_vtk(check, args.vtk):
            print(f"wrote {path}", file=out)
    if args.plot:
        from fecheck.io.fe_plots import write_fe_plots

        tibial = {c: chk for c, chk in check.compartments.items() if c in check.split("fe")}
        if len(tibial) < len(check.compartments):
            print("the pressure map shows the tibial compartments, seen from above; the "
                  "patellofemoral contact is in --json and --vtk", file=out)
        for path in write_fe_plots(dataclasses.replace(check, compartments=tibial), args.plot,
                                   scene.label):
            print(f"wrote {path}", file=out)


def _estimate(args: argparse.Namespace, scene, check, estimate, log):
    """The error estimate (None: a check without its EF run, or a closed tibial solid), or
    None with a one-line warning when its coarse level fails (with --verify the failure is
    the command's)."""
    import warnings

    from fecheck.errors import FecheckError

    if check.ef_run is None:
        return None
    try:
        return estimate(scene, check, check.ef_run, verify=args.verify, log=log)
    except FecheckError as err:
        if args.verify:
            raise
        warnings.warn(f"no error estimate: its coarse level failed: {err}", stacklevel=2)
        return None


SOLID_NO_ESTIMATE = (
    "error estimate: none for a closed tibial solid (geometry.tibia_solid): the estimate "
    "solves a second, coarser mesh of the same geometry, and the solid's tetrahedra are "
    "Gmsh's fill of the given surface, which is not coarsened here; for an estimate run "
    "fe.body = 'layer' (a layer with the solid's thickness map) or compare fe.refine 0 and 1")
"""What `fecheck fe` prints instead of the error estimate of a closed tibial solid."""


# ---------------------------------------------------------------------- menisci scenes
MENISCUS_PER_SHEET = 1.25
"""Meniscus tetrahedron size over the tibial sheet size ``fe.size_mm``."""
UNSUPPORTED = (("mode", None, "--mode compartment (the FE with menisci loads the "
                                       "whole joint)"),
               ("refine", None, "--refine (set fe.size_mm with fe.prepare = 'on')"),
               ("verify", False, "--verify (no error estimate of the FE with menisci)"))
"""(argument, the value that asks nothing, what is refused)."""


def refuse_unsupported(args: argparse.Namespace) -> None:
    """A one-line `FecheckError` naming the first flag the FE with menisci does not take."""
    from fecheck.errors import FecheckError

    for name, idle, what in UNSUPPORTED:
        value = getattr(args, name, idle)
        if value is not None and value != idle and not (name == "mode" and value == "joint"):
            raise FecheckError(f"fecheck fe on a scene with menisci does not take {what}")


def run_menisci_fe(args: argparse.Namespace, scene, out) -> int:
    """Run the FE with menisci of `scene`, print the report to `out`, write --json."""
    import json
    import time

    from fecheck.fe.knee import knee_menisci
    from fecheck.fe.knee.crosscheck import stderr_log
    from fecheck.fe.knee.knee_menisci_report import (
        as_dict,
        choice_lines,
        comparison_dict,
        published_lines,
        report_lines,
    )
    from fecheck.io.outputs import write_text
    from fecheck.scene.provenance import with_provenance
    from geometry.budget import policy

    refuse_unsupported(args)
    check_outputs(args)
    size = MENISCUS_PER_SHEET * float(scene["fe.size_mm"])
    name = scene.label
    t0 = time.perf_counter()
    with policy("fecheck fe", force=args.force, force_hint="--force"):
        result = knee_menisci.knee_menisci_fe(scene, meniscus_size_mm=size, log=stderr_log,
                                              without=True)
    wall = time.perf_counter() - t0
    print(f"{name}: FE with menisci at the EF pose, load on the tibia {result.load_N:.2f} N, "
          f"meniscus tetrahedra {size:g} mm", file=out)
    for line in report_lines(result, wall) + published_lines(result) + choice_lines(scene):
        print(line, file=out)
    print("error estimate: none (not made for the FE with menisci)", file=out)
    if args.json is not None:
        data = with_provenance(as_dict(result, name) | comparison_dict(result, scene), scene)
        write_text(args.json, json.dumps(data, indent=2) + "\n")
        if str(args.json) != "-":
            print(f"wrote {args.json}", file=out)
    if args.vtk or args.plot:
        from fecheck.io.menisci_outputs import write_menisci_plots, write_menisci_vtk

        paths = (write_menisci_vtk(result, args.vtk) if args.vtk else []) + (
            write_menisci_plots(result, args.plot, name) if args.plot else [])
        for path in paths:
            print(f"wrote {path}", file=out)
    return 0


def run(args: argparse.Namespace) -> int:
    from fecheck.fe.knee.crosscheck import cross_check, stderr_log
    from fecheck.scene import load_scene
    from fecheck.studies.estimate import estimate
    from geometry.budget import policy

    out = _report_stream(args)
    scene = load_scene(args.scene, args.overrides)
    if scene["menisci.dir"]:
        return run_menisci_fe(args, scene, out)
    check_outputs(args)
    est = None
    with policy("fecheck fe", force=args.force, force_hint="--force"):
        check = cross_check(scene, mode=args.mode, refine=args.refine)
        if not args.no_estimate:
            est = _estimate(args, scene, check, estimate, stderr_log)
    print(comparison_table(check), file=out)
    for line in peak_lines(check) + summary_lines(check):
        print(line, file=out)
    if est is not None:
        for line in estimate_lines(est, check.settings.mode):
            print(line, file=out)
        print(f"time: error estimate {est.extra_seconds:.1f} s = {est.cost:.2f} × the "
              "default FE time", file=out)
    elif args.no_estimate:
        print("error estimate: skipped (--no-estimate)", file=out)
    elif any(c.layer.body.solid is not None for c in check.compartments.values()):
        print(SOLID_NO_ESTIMATE, file=out)
    elif check.ef_run is None:
        print("error estimate: none (a check without its EF run)", file=out)
    else:
        print("error estimate: none (its coarse level failed: see the warning)", file=out)
    write_outputs(args, check, scene, out, est)
    return 0
