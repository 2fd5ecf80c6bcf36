"""`fecheck run [SCENE]`: solve one scene's equilibrium and report it.

Only the standard library is imported here; the solver is imported inside `run`, pyvista
only with ``--plot`` and meshio only with ``--vtk``. Every output path is checked before
the solve (a bad path stops the run at once with a one-line error, exit 2; missing
folders are made when their first file is written). ``-`` as the path of ``--json``,
``--csv`` or ``--faces-csv`` writes to standard output; the human-readable report then
goes to standard error.

The rigid model has no pressure map (point contacts): with it, ``--plot``, ``--vtk`` and
``--faces-csv`` print one line saying so and write nothing (no folder either); the run
itself goes ahead.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from fecheck.cli import add_scene_arguments

STDOUT = "-"
PER_FACE = (("plot", "--plot"), ("vtk", "--vtk"), ("faces_csv", "--faces-csv"))
"""Outputs drawn from the per-face results (attribute, option)."""


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "run", help="solve a scene (default: the packaged baseline) and print the result",
        description="Static equilibrium of the tibia for one scene (TOML). Prints a table; "
                    "optionally writes JSON, CSV, per-face tables, VTK surfaces and a "
                    "pressure map. Output paths are checked before the solve; '-' writes "
                    "JSON or CSV to standard output (the table then goes to standard error).")
    add_scene_arguments(p, "override a scene key, value as a TOML literal "
                           "(e.g. --set contact.poisson=0.4 --set contact.law=hertz)")
    p.add_argument("--from", dest="from_json", type=Path, metavar="RESULT.json",
                   help="run again the scene a result JSON of `fecheck run --json` recorded "
                        "(every key's value, with its --set overrides); refused when an "
                        "input file it read has changed since (its sha256)")
    p.add_argument("--json", metavar="PATH", help="write the result as JSON ('-': stdout); "
                   "it records the fecheck version, the resolved scene, the sha256 of "
                   "every input file and the run's wall and CPU time (provenance)")
    p.add_argument("--csv", metavar="PATH", help="write the result as a CSV row ('-': stdout)")
    p.add_argument("--faces-csv", metavar="PATH",
                   help="write one CSV row per slave face: compartment, face, centroid x/y/z "
                        "mm, pressure MPa, in-contact area mm², depth mm ('-': stdout)")
    p.add_argument("--plot", type=Path, metavar="DIR",
                   help="write DIR/pressure_map.png: both compartments seen from the contact "
                        "side (+x right), face-mean pressures, colour bar 0 to the printed "
                        "p_max (pyvista, off-screen)")
    p.add_argument("--vtk", type=Path, metavar="DIR",
                   help="write DIR/medial.vtu and DIR/lateral.vtu: the contact surfaces with "
                        "cell data pressure_MPa, contact_area_mm2 and depth_mm (meshio)")
    p.add_argument("--explain", action="store_true",
                   help="print the plan first (meshes built or cached, detection path per "
                        "contact pair, optional parts) and check after the run that it kept "
                        "to it")
    p.set_defaults(run=run)


def _report_stream(args: argparse.Namespace):
    """Standard error when a machine-readable output goes to standard output, else
    standard output. Raises `FecheckError` when more than one output asks for it."""
    from fecheck.errors import FecheckError

    to_stdout = [opt for attr, opt in (("json", "--json"), ("csv", "--csv"),
                                       ("faces_csv", "--faces-csv"))
                 if getattr(args, attr) is not None and str(getattr(args, attr)) == STDOUT]
    if len(to_stdout) > 1:
        raise FecheckError(f"only one output can go to standard output ('-'), got "
                           f"{' and '.join(to_stdout)}")
    return sys.stderr if to_stdout else sys.stdout


def has_no_pressure_map(scene) -> bool:
    """Whether the scene runs the rigid point-contact model (no per-face results)."""
    return scene["model.kind"] == "rigid" and scene["scanned.ligaments"] == "none"


def _drop_per_face_outputs(args: argparse.Namespace, out) -> None:
    """Clear the per-face outputs (rigid model), saying so on one line."""
    asked = [opt for attr, opt in PER_FACE if getattr(args, attr) is not None]
    if asked:
        print(f"note: the rigid model has no pressure map (point contacts): "
              f"{', '.join(asked)} write nothing", file=out)
    for attr, _ in PER_FACE:
        setattr(args, attr, None)


def check_outputs(args: argparse.Namespace) -> None:
    """`check_output` on every output path of the run (files and folders)."""
    from fecheck.io.outputs import check_output

    for attr in ("json", "csv", "faces_csv"):
        check_output(getattr(args, attr))
    for attr in ("plot", "vtk"):
        check_output(getattr(args, attr), directory=True)


def _csv_row_text(result) -> str:
    """`RunResult.flat_row()` as a one-row CSV with its header."""
    import csv
    import io

    buf = io.StringIO()
    row = result.flat_row()
    writer = csv.DictWriter(buf, fieldnames=list(row), lineterminator="\n")
    writer.writeheader()
    writer.writerow(row)
    return buf.getvalue()


def _write(path, text: str, out) -> None:
    """Write `text` atomically (or to stdout for '-') and say where, on `out`."""
    from fecheck.io.outputs import write_text

    write_text(path, text)
    if str(path) != STDOUT:
        print(f"wrote {path}", file=out)


def write_text_outputs(args: argparse.Namespace, result, out, scene=None) -> None:
    """The --json (with the provenance of `scene`), --csv and --faces-csv outputs (no
    faces CSV without per-face results: `write_surface_outputs` says so)."""
    import json

    from fecheck.io.plots import has_pressure_map
    from fecheck.scene.provenance import with_provenance

    if args.json is not None:
        data = with_provenance(result.as_dict(), scene)
        _write(args.json, json.dumps(data, indent=2) + "\n", out)
    if args.csv is not None:
        _write(args.csv, _csv_row_text(result), out)
    if args.faces_csv is not None and has_pressure_map(result):
        from fecheck.io.vtk import faces_csv_text

        _write(args.faces_csv, faces_csv_text(result), out)


def write_surface_outputs(args: argparse.Namespace, result, out) -> None:
    """The --vtk and --plot outputs, with notes on fields the result lacks."""
    from fecheck.io.plots import has_pressure_map

    if (args.plot or args.vtk or args.faces_csv) and not has_pressure_map(result):
        print(f"note: the {result.model} model has no pressure map: nothing written for "
              f"--plot, --vtk or --faces-csv", file=out)
        return
    if args.vtk or args.faces_csv:
        from fecheck.io.vtk import field_notes

        for note in field_notes(result):
            print(f"note: {note}", file=out)
    if args.vtk:
        from fecheck.io.vtk import write_run_vtk

        for path in write_run_vtk(result, args.vtk):
            print(f"wrote {path}", file=out)
    if args.plot:
        from fecheck.io.plots import write_pressure_plots

        for path in write_pressure_plots(result, args.plot):
            print(f"wrote {path}", file=out)


def recorded_scene(args: argparse.Namespace):
    """The scene `args.from_json` recorded; `FecheckError` with a scene or ``--set`` beside
    it, or when an input file it read changed (the numbers would not be reproduced); a
    warning when another fecheck version wrote it."""
    import json
    import warnings

    from fecheck.errors import FecheckError
    from fecheck.scene import provenance

    path = args.from_json
    if args.scene is not None or args.overrides:
        raise FecheckError("--from runs the scene a result recorded: give no SCENE and no "
                           "--set with it (run the scene itself to change it)")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as err:
        raise FecheckError(f"--from {path}: cannot read a result JSON "
                           f"({type(err).__name__}: {err})") from None
    scene = provenance.recorded_scene(data, str(path))
    changed = provenance.changed_inputs(data, scene)
    if changed:
        raise FecheckError(f"--from {path}: the inputs differ from the recorded run, so its "
                           f"numbers would not be reproduced: {'; '.join(changed)}; restore "
                           "them, or run the scene itself to use today's files")
    then = data["provenance"].get("fecheck_version")
    if then != provenance.fecheck_version():
        warnings.warn(f"--from {path}: written by fecheck {then}, this is "
                      f"{provenance.fecheck_version()}: the numbers may differ", stacklevel=2)
    return scene


def run(args: argparse.Namespace) -> int:
    from fecheck.model.plausibility import check_ef_poisson
    from fecheck.model.run import run_scene
    from fecheck.scene import load_scene

    out = _report_stream(args)
    scene = (load_scene(args.scene, args.overrides) if args.from_json is None
             else recorded_scene(args))
    check_ef_poisson(scene)
    if scene["patella.dir"]:
        print("note: patella.dir is read by `fecheck flex` only: this run solves the tibia "
              "without the patella", file=out)
    if has_no_pressure_map(scene):
        _drop_per_face_outputs(args, out)
    check_outputs(args)
    if args.explain:
        from fecheck.model.explain import plan_scene

        plan = plan_scene(scene, plot=bool(args.plot))
        print(plan.text(), file=out, flush=True)
    result = run_scene(scene)
    print(result.table(), file=out, flush=True)
    write_text_outputs(args, result, out, scene)
    write_surface_outputs(args, result, out)
    if args.explain:
        deviations = plan.audit()
        print("audit: " + ("the run kept to the plan" if not deviations
                           else "; ".join(deviations)), file=out)
    return 0 if result.converged else 1
