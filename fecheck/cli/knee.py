"""`fecheck knee import`: check a knee's surface files and write a documented scene
(`fecheck.studies.knee_import`: the checks, the split, the scene writer).

Only the standard library is imported here (and the roles of the files); the import
inside `run`.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from fecheck.studies.knee_import import ROLES


def _option(role: str) -> str:
    return "--" + role.replace("_", "-")


def add_parser(subparsers) -> None:
    p = subparsers.add_parser("knee", help="import a knee's surface files as a checked "
                              "femur-tibia scene", description="Knee surface files.")
    sub = p.add_subparsers(dest="knee_action", metavar="ACTION", required=True)
    q = sub.add_parser(
        "import", help="check femoral and tibial surface files; write a documented "
        "femur-tibia scene and a preview PNG",
        description="Read and check the femoral and tibial articular surfaces (and bones), "
        "print one line per check, repair inverted normals (a corrected copy beside the "
        "scene), and write a documented femur-tibia scene TOML and <scene-stem>_preview.png. "
        "Meshes must be in the thesis frame (mm or m; x right, y anterior, z superior) at "
        "the rest pose.")
    files = {"femur": "femoral articular surface: an open cartilage sheet (normals down) "
                      "or a closed implant component (normals outward)",
             "tibia": "tibial articular surface: both compartments in one file (see "
                      "--split), or the medial one with --tibia-lateral",
             "tibia_lateral": "lateral tibial compartment (one compartment per file)",
             "femur_bone": "femoral bone surface (with --tibia-bone: bone-distance "
                           "cartilage thickness)",
             "tibia_bone": "tibial bone surface (with --femur-bone)"}
    for role, text in files.items():
        q.add_argument(_option(role), dest=role, type=Path, metavar="FILE", help=text,
                       required=role in ("femur", "tibia"))
    q.add_argument("--units", choices=("mm", "m"), default="mm",
                   help="length unit of every file (default mm)")
    q.add_argument("--side", choices=("right", "left"), default="right",
                   help="knee side: the medial compartment is at -x in a right knee, +x in a "
                        "left one (default right)")
    q.add_argument("--split", choices=("components", "sagittal"),
                   help="split of one tibia file: its two connected pieces (default) or the "
                        "two sides of the plane x = --split-x")
    q.add_argument("--split-x", type=float, metavar="MM",
                   help="x of the sagittal split plane, mm (implies --split sagittal; "
                        "default 0)")
    q.add_argument("--load-N", dest="load_N", type=float, default=800.0, metavar="N",
                   help="axial load on the tibia, N (default 800)")
    q.add_argument("-o", "--output", type=Path, required=True, metavar="SCENE.toml",
                   help="scene file to write; the preview and repaired meshes go beside it")
    p.set_defaults(run=run)


def _split_mode(args: argparse.Namespace) -> str:
    from fecheck.errors import FecheckError

    if args.tibia_lateral is not None:
        if args.split is not None or args.split_x is not None:
            raise FecheckError("--split and --split-x split one tibia file; with "
                               "--tibia-lateral each file is one compartment")
        return "files"
    if args.split == "components" and args.split_x is not None:
        raise FecheckError("--split-x is the plane of --split sagittal, not of components")
    return args.split or ("sagittal" if args.split_x is not None else "components")



def run(args: argparse.Namespace) -> int:
    from fecheck.cli import package_version
    from fecheck.errors import FecheckError
    from fecheck.studies.knee_import import Options, import_knee

    if args.knee_action != "import":
        raise FecheckError(f"unknown knee action {args.knee_action!r}")
    opts = Options(args.units, args.side, _split_mode(args), args.split_x, args.load_N,
                   package_version())
    files = {r: getattr(args, r) for r in ROLES if getattr(args, r) is not None}
    import_knee(files, args.output, opts)
    return 0
