"""`fecheck fe [SCENE]`: FE cross-check of a scene's elastic-foundation answer.

Runs the scene's EF equilibrium, then per compartment a 3D quadratic-tetrahedron solve
of the cartilage layer pressed by the condyle sphere under the EF compartment force
(exact frictionless contact), beside the axisymmetric FE reference, EF, Hertz and
Donahue 2002. Only the standard library is imported here.

Every output path is checked before the solves (one-line error, exit 2; missing parent
folders are created); ``--json -`` writes the JSON to standard output and the report to
standard error. The comparison table sizes its columns to their values and prints an
undefined value as ``n/a`` with a numbered note saying why.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

STDOUT = "-"
QUANTITIES = (("p_max", "max_pressure_MPa", 3), ("p_mean", "mean_pressure_MPa", 3),
              ("area", "area_mm2", 1), ("depth", "depth_mm", 3))
"""Table columns per compartment: header, `ContactMetrics` field, decimals."""
ROWS = (("FE 3D", "fe"), ("FE axisymmetric", "axisym"), ("EF (closed form)", "ef"),
        ("EF model", "ef_model"), ("Hertz", "hertz"), ("Donahue 2002 (1 mm)", "donahue"))
"""Table rows: label, source (a `CompartmentCheck` attribute or Donahue 2002)."""


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "fe", help="FE cross-check of the EF contact answer (scikit-fem)",
        description="Per compartment: 3D FE layer solve under the EF load, the axisymmetric "
                    "FE reference, EF and Hertz closed forms and Donahue 2002. Scene keys "
                    "[fe] set sizes, gap convention and solver. Output paths are checked "
                    "before the solves.")
    p.add_argument("scene", nargs="?", type=Path,
                   help="scene TOML file (default: the packaged baseline scene)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scene key, e.g. --set fe.gap='deformed'")
    p.add_argument("--json", metavar="PATH",
                   help="write the comparison as JSON ('-': stdout, the report to stderr)")
    p.add_argument("--plot", type=Path, metavar="DIR",
                   help="write DIR/fe_pressure_map.png (FE, EF and FE - EF pressure of both "
                        "compartments seen from the contact side, FE and EF on one colour "
                        "scale) and DIR/fe_profile_<compartment>.png (radial profiles)")
    p.add_argument("--vtk", type=Path, metavar="DIR",
                   help="write DIR/medial.vtu and DIR/lateral.vtu: the FE top surfaces with "
                        "the FE and EF fields (meshio)")
    p.add_argument("--size", type=float, metavar="MM",
                   help="3D element size under the contact, mm (overrides fe.size_mm)")
    p.set_defaults(run=run)


# ---------------------------------------------------------------------- the table
def _number(value: float, decimals: int) -> str:
    """`value` with `decimals` decimals, or 3 significant digits where that would print a
    non-zero value as zero."""
    text = f"{value:.{decimals}f}"
    if value != 0 and float(text) == 0:
        text = f"{value:.3g}"
    return text


def _metrics(chk, source: str):
    """The `ContactMetrics` of one table row for one compartment (None if it has none)."""
    from fecheck.fe.results import FEContactResult
    from fecheck.reference.closed_forms import DONAHUE_2002

    if source == "donahue":
        return DONAHUE_2002[chk.name][1.0]
    m = getattr(chk, source)
    return m.metrics if isinstance(m, FEContactResult) else m


def _why_missing(label: str, source: str, chk, field: str) -> str:
    """Why a table cell has no value (its note)."""
    if source == "donahue" and field == "depth_mm":
        return "Donahue 2002 reports no indentation depth"
    if source == "axisym":
        return "the axisymmetric FE reference is run for flat (transverse) layers only"
    if source == "ef_model":
        return f"the EF model of this scene reports no {field} for the {chk.name} compartment"
    if source == "fe" and chk.fe.metrics.area_mm2 == 0:
        return (f"FE 3D {chk.name}: mean pressure undefined, the 3D FE resolved no contact "
                f"area ({int(chk.fe.active.sum())} node(s) in contact, no top triangle "
                f"under the contact): the contact is far smaller than the "
                f"{chk.fe.size_under_contact_mm:.2g} mm elements; refine with --size")
    return f"{label} {chk.name}: {field} is undefined for this case"


def _cells(label: str, source: str, chk, notes: list[str]) -> list[str]:
    """The formatted cells of one row for one compartment, adding notes as needed."""
    m = _metrics(chk, source)
    cells = []
    for _, field, decimals in QUANTITIES:
        value = math.nan if m is None else getattr(m, field)
        if value is not None and math.isfinite(value):
            cells.append(_number(value, decimals))
            continue
        note = _why_missing(label, source, chk, field)
        if note not in notes:
            notes.append(note)
        cells.append(f"n/a({notes.index(note) + 1})")
    return cells


def _fe_warnings(check) -> list[str]:
    """Notes on 3D FE answers that carry the load but resolve no contact."""
    out = []
    for name, chk in check.compartments.items():
        m = chk.fe.metrics
        if m.area_mm2 == 0 and chk.load_N > 0:
            out.append(f"FE 3D {name}: the whole {chk.load_N:.1f} N sits on "
                       f"{int(chk.fe.active.sum())} node(s) and no pressure is recovered "
                       f"(p_max {m.max_pressure_MPa:g} MPa, area 0): its row is not an answer")
    return out


def comparison_table(check) -> str:
    """The comparison table of a `CrossCheck`: per compartment p_max, p_mean (MPa), area
    (mm²) and depth (mm) for every row of `ROWS`; columns as wide as their widest value;
    undefined values as ``n/a(k)`` with note k below the table."""
    names = list(check.compartments)
    notes: list[str] = []
    body = [[label] + [c for n in names for c in _cells(label, src, check.compartments[n],
                                                          notes)]
            for label, src in ROWS]
    head = [""] + [q for _ in names for q, _, _ in QUANTITIES]
    widths = [max(len(r[i]) for r in body + [head]) for i in range(len(head))]
    span = [sum(widths[1 + 4 * k: 5 + 4 * k]) + 2 * 3 for k in range(len(names))]
    lines = [" " * widths[0] + "".join(f"  {n:^{w}s}" for n, w in zip(names, span,
                                                                         strict=True))]
    for row in [head] + body:
        lines.append(f"{row[0]:<{widths[0]}s}" + "".join(
            f"  {c:>{w}s}" for c, w in zip(row[1:], widths[1:], strict=True)))
    lines.append("units: p_max, p_mean MPa; area mm²; depth mm; loads " + ", ".join(
        f"{n} {check.compartments[n].load_N:.2f} N" for n in names))
    lines += [f"({k}) {note}" for k, note in enumerate(notes, start=1)]
    lines += [f"note: {w}" for w in _fe_warnings(check)]
    return "\n".join(lines)


def _timing_line(name: str, chk, t: dict) -> str:
    """One compartment's timing and 3D-vs-axisymmetric line."""
    line = (f"{name}: 3D FE {t['fe_3d']:.2f} s = {t['fe_3d_over_ef_equilibrium']:.0f}x the "
            f"EF equilibrium")
    dev = chk.deviation()
    if not dev:
        return line
    if chk.fe.metrics.area_mm2 == 0 or not all(math.isfinite(v) for v in dev.values()):
        return line + "; 3D vs axisymmetric: not compared (the 3D FE resolved no contact)"
    return line + (f"; 3D vs axisymmetric: p_max {100 * dev['max_pressure']:+.1f}%, "
                   f"area {100 * dev['area']:+.1f}% (the 3D discretization error)")


# ---------------------------------------------------------------------- the verb
def _report_stream(args: argparse.Namespace):
    return sys.stderr if args.json is not None and str(args.json) == STDOUT else sys.stdout


def check_outputs(args: argparse.Namespace) -> None:
    """`check_output` on every output path (before any solve)."""
    from fecheck.io.outputs import check_output

    check_output(args.json)
    check_output(args.plot, directory=True)
    check_output(args.vtk, directory=True)


def write_outputs(args: argparse.Namespace, check, scene, out) -> None:
    """The --json, --vtk and --plot outputs."""
    import json

    from fecheck.io.outputs import write_text

    if args.json is not None:
        write_text(args.json, json.dumps(check.as_dict(), indent=2) + "\n")
        if str(args.json) != STDOUT:
            print(f"wrote {args.json}", file=out)
    points = scene.knee.contact_point
    if args.vtk:
        from fecheck.io.vtk import write_fe_vtk

        for path in write_fe_vtk(check, points, args.vtk):
            print(f"wrote {path}", file=out)
    if args.plot:
        from fecheck.io.fe_plots import write_fe_plots

        paths = write_fe_plots(check, points, args.plot, scene["name"] or str(scene.source))
        if not any(p.name == "fe_pressure_map.png" for p in paths):
            print("note: no 3D FE top surface under the contact to draw: no pressure map",
                  file=out)
        for path in paths:
            print(f"wrote {path}", file=out)


def run(args: argparse.Namespace) -> int:
    from fecheck.errors import FecheckError
    from fecheck.fe.crosscheck import cross_check
    from fecheck.scene import load_scene

    if args.size is not None and not (0 < args.size <= 10):
        raise FecheckError(f"--size must be in (0, 10] mm, got {args.size}")
    out = _report_stream(args)
    scene = load_scene(args.scene, args.overrides)
    check_outputs(args)
    check = cross_check(scene, size_mm=args.size)
    print(comparison_table(check), file=out)
    for name, chk in check.compartments.items():
        print(_timing_line(name, chk, check.timing_s[name]), file=out)
    write_outputs(args, check, scene, out)
    return 0
