"""`fecheck mesh`: build icospheres, caps, plateaus and cartilage layers; check mesh files.

Only the standard library is imported here; geometry modules (and through them gmsh)
are imported inside the handlers, and `mesh info` never imports gmsh, pyvista or skfem.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def _coeffs(text: str) -> list:
    try:
        value = json.loads(text)
    except json.JSONDecodeError as err:
        raise argparse.ArgumentTypeError(
            f"coefficients must be a JSON nested list: {err}") from None
    return value


def _common(p: argparse.ArgumentParser, output: bool = True) -> None:
    if output:
        p.add_argument("-o", "--output", required=True, type=Path,
                       help="output file; format from the extension (.stl, .vtu, .msh, .obj, ...)")
    p.add_argument("--no-cache", action="store_true", help="always rebuild (do not use the cache)")
    p.add_argument("--force", action="store_true",
                   help="build beyond the element limits (2 million tetrahedra, 1 million "
                        "quadratic, 500,000 triangles), never beyond the available memory")


def _sphere_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--radius", type=float, required=True, help="sphere radius, mm")
    p.add_argument("--subdivisions", type=int, required=True,
                   help="icosphere level n (0..8): 20·4^n faces")
    p.add_argument("--center", type=float, nargs=3, default=(0.0, 0.0, 0.0),
                   metavar=("X", "Y", "Z"), help="sphere centre, mm")
    p.add_argument("--method", choices=("gmsh", "trimesh"), default="gmsh")


def _refine_options(p: argparse.ArgumentParser, n_point: int) -> None:
    meta = ("X", "Y", "Z")[:n_point]
    p.add_argument("--refine-point", type=float, nargs=n_point, metavar=meta,
                   help="refine the mesh around this point, mm")
    p.add_argument("--refine-size", type=float, help="element size near the point, mm")
    p.add_argument("--refine-radius", type=float, help="radius of the refined zone, mm")


def add_parser(subparsers) -> None:
    p = subparsers.add_parser("mesh", help="build meshes (icosphere, cap, plateau, layer) "
                              "or check mesh files (info)",
                              description="Build geometry meshes (mm) or report mesh checks.")
    sub = p.add_subparsers(dest="mesh_kind", metavar="KIND", required=True)

    q = sub.add_parser("icosphere", help="true icosphere (20·4^n faces)")
    _sphere_options(q)
    _common(q)

    q = sub.add_parser("cap", help="icosphere cut by a plane (kept side: normal points away)")
    _sphere_options(q)
    q.add_argument("--cut-point", type=float, nargs=3, required=True, metavar=("X", "Y", "Z"))
    q.add_argument("--cut-normal", type=float, nargs=3, required=True, metavar=("X", "Y", "Z"))
    q.add_argument("--closed", action="store_true", help="close the cut with a flat cap")
    _common(q)

    q = sub.add_parser("plateau", help="tibial plateau: box, flat disc patch or polynomial")
    q.add_argument("--kind", choices=("box", "patch", "polynomial"), default="box")
    q.add_argument("--center", type=float, nargs=3, default=(0.0, 0.0, 0.0),
                   metavar=("X", "Y", "Z"), help="box: top-face centre; patch: disc centre, mm")
    q.add_argument("--size-x", type=float, default=80.0, help="box top extent along x, mm")
    q.add_argument("--size-y", type=float, default=60.0, help="box top extent along y, mm")
    q.add_argument("--thickness", type=float, default=10.0,
                   help="box/polynomial solid depth below the top, mm (polynomial: 0 = top only)")
    q.add_argument("--sagittal", type=float, default=0.0, help="box sagittal angle λ, degrees")
    q.add_argument("--frontal", type=float, default=0.0, help="box frontal angle γ, degrees")
    q.add_argument("--mesh-size", type=float, help="box element size, mm (default: 12 faces)")
    q.add_argument("--normal", type=float, nargs=3, default=(0.0, 0.0, 1.0),
                   metavar=("X", "Y", "Z"), help="patch normal")
    q.add_argument("--radius", type=float, default=20.0, help="patch disc radius, mm")
    q.add_argument("--size", type=float, default=2.0, help="patch/polynomial element size, mm")
    q.add_argument("--coeffs", type=_coeffs, help="polynomial coeffs[i][j] of x^i y^j (JSON)")
    q.add_argument("--footprint", choices=("rectangle", "ellipse"), default="rectangle")
    q.add_argument("--center-xy", type=float, nargs=2, default=(0.0, 0.0), metavar=("X", "Y"))
    q.add_argument("--half-x", type=float, default=20.0, help="polynomial half-extent x, mm")
    q.add_argument("--half-y", type=float, default=20.0, help="polynomial half-extent y, mm")
    _refine_options(q, 3)
    _common(q)

    q = sub.add_parser("layer", help="cartilage layer tetrahedral mesh (geometry.layer)")
    q.add_argument("--footprint", choices=("rectangle", "ellipse"), default="rectangle")
    q.add_argument("--center-xy", type=float, nargs=2, default=(0.0, 0.0), metavar=("X", "Y"))
    q.add_argument("--half-x", type=float, default=30.0, help="half-extent along x, mm")
    q.add_argument("--half-y", type=float, default=30.0, help="half-extent along y, mm")
    q.add_argument("--thickness", type=float, default=6.0, help="layer thickness, mm")
    q.add_argument("--coeffs", type=_coeffs, help="polynomial top z = f(x, y) (JSON)")
    q.add_argument("--sagittal", type=float, default=0.0, help="sagittal angle, degrees")
    q.add_argument("--frontal", type=float, default=0.0, help="frontal angle, degrees")
    q.add_argument("--size", type=float, default=5.0, help="element size, mm")
    q.add_argument("--order", type=int, choices=(1, 2), default=1, help="tet order")
    _refine_options(q, 2)
    _common(q)

    q = sub.add_parser("info", help="mesh checks (thesis Table 3.1) for mesh files")
    q.add_argument("files", nargs="+", type=Path, help="mesh files (STL, OBJ, VTK/VTU, MSH, ...)")
    q.add_argument("--json", type=Path, metavar="PATH",
                   help="also write the rows as JSON ('-': standard output)")
    p.set_defaults(run=run)


def _refine(args) -> dict:
    return {"refine_point": args.refine_point, "refine_size": args.refine_size,
            "refine_radius": args.refine_radius}


KEYS = {"size": "--size", "mesh_size": "--mesh-size", "refine_size": "--refine-size",
        "subdivisions": "--subdivisions"}
"""Builder parameter → option, for the size guards' messages."""


def _build(args):
    if args.mesh_kind == "icosphere":
        from geometry.icosphere import icosphere

        return icosphere(args.radius, args.subdivisions, args.center, method=args.method,
                         cache=not args.no_cache)
    if args.mesh_kind == "cap":
        from geometry.cap import spherical_cap

        return spherical_cap(args.radius, args.subdivisions, args.center,
                             cut_point=args.cut_point, cut_normal=args.cut_normal,
                             closed=args.closed, method=args.method, cache=not args.no_cache)
    if args.mesh_kind == "plateau":
        from geometry import plateau

        if args.kind == "box":
            return plateau.plateau_box(args.center, args.size_x, args.size_y, args.thickness,
                                       sagittal_deg=args.sagittal, frontal_deg=args.frontal,
                                       mesh_size=args.mesh_size, cache=not args.no_cache)
        if args.kind == "patch":
            return plateau.plane_patch(args.center, args.normal, radius=args.radius,
                                       size=args.size, cache=not args.no_cache, **_refine(args))
        poly = _polynomial(args.coeffs, required=True)
        common = {"footprint": args.footprint, "center_xy": args.center_xy,
                  "half_x": args.half_x, "half_y": args.half_y, "size": args.size,
                  "cache": not args.no_cache, **_refine(args)}
        if args.thickness == 0:
            return plateau.polynomial_patch(poly, **common)
        return plateau.polynomial_plateau(poly, thickness=args.thickness, **common)
    from fecheck.errors import FecheckError

    try:
        from geometry.layer import cartilage_layer
    except ImportError as err:
        raise FecheckError(f"cartilage layers are not available ({err})") from None
    return cartilage_layer(args.footprint, args.center_xy, args.half_x, args.half_y,
                           args.thickness, top=_polynomial(args.coeffs, required=False),
                           sagittal_deg=args.sagittal, frontal_deg=args.frontal,
                           size=args.size, order=args.order, cache=not args.no_cache,
                           **_refine(args))


def _polynomial(coeffs, required: bool):
    from fecheck.errors import FecheckError
    from geometry.polynomial import Polynomial2D

    if coeffs is None:
        if required:
            raise FecheckError("--kind polynomial needs --coeffs, e.g. '[[-8, 0], [0.05, 0]]'")
        return None
    try:
        return Polynomial2D(coeffs)
    except (ValueError, TypeError) as err:
        raise FecheckError(f"--coeffs must be a rectangular list of numbers: {err}") from None


COLUMNS = [("file", "name", "{}"), ("faces", "faces", "{}"), ("verts", "vertices", "{}"),
           ("χ", "euler", "{}"), ("consistent", "winding_consistent", "{}"),
           ("convex", "convex", "{}"), ("watertight", "watertight", "{}"),
           ("empty", "empty", "{}"), ("area mm²", "area_mm2", "{:.4g}"),
           ("volume mm³", "volume_mm3", "{:.6g}"), ("edge min/mean/max mm", None, ""),
           ("degen", "degenerate_faces", "{}"), ("dup", "duplicate_faces", "{}"),
           ("parts", "components", "{}"), ("boundary", "boundary_edges", "{}")]


def format_table(rows: list[dict]) -> str:
    """Rows of `MeshReport.as_dict()` as an aligned text table."""
    table = [[c[0] for c in COLUMNS]]
    for r in rows:
        line = []
        for _, key, fmt in COLUMNS:
            if key is None:
                line.append(f"{r['edge_min_mm']:.3g}/{r['edge_mean_mm']:.3g}/{r['edge_max_mm']:.3g}")
            elif r[key] is None:
                line.append("-")
            else:
                line.append(fmt.format(r[key]))
        table.append(line)
    widths = [max(len(row[i]) for row in table) for i in range(len(COLUMNS))]
    return "\n".join("  ".join(v.ljust(w) for v, w in zip(row, widths, strict=True)).rstrip()
                     for row in table)


def _info(args) -> int:
    from fecheck.errors import FecheckError
    from fecheck.io.outputs import STDOUT, check_output, write_text
    from fecheck.scene.provenance import provenance
    from geometry.checks import mesh_report, tet_surface
    from geometry.io import load_mesh
    from geometry.mesh import TetMesh

    check_output(args.json)
    rows = []
    for path in args.files:
        mesh = load_mesh(path)
        if isinstance(mesh, TetMesh):
            mesh = tet_surface(mesh)
        report = mesh_report(mesh, name=str(path))
        if report.empty:
            raise FecheckError(f"{path}: the mesh is empty (no faces)")
        rows.append(report.as_dict())
    to_stdout = args.json is not None and str(args.json) == STDOUT
    print(format_table(rows), file=sys.stderr if to_stdout else sys.stdout)
    if args.json is not None:
        stamp = provenance(files=[("mesh", path) for path in args.files])
        rows = [row | {"sha256": rec["sha256"], "provenance": stamp}
                for row, rec in zip(rows, stamp["input_files"], strict=True)]
        write_text(args.json, json.dumps(rows, indent=2) + "\n")
    return 0


def run(args) -> int:
    if args.mesh_kind == "info":
        return _info(args)
    from fecheck.io.outputs import check_output
    from geometry.budget import policy
    from geometry.cache import STATS
    from geometry.io import check_format, save_mesh
    from geometry.mesh import TetMesh

    check_format(args.output)
    check_output(args.output)                   # before meshing, not after
    with policy(f"fecheck mesh {args.mesh_kind}", KEYS, force=args.force, force_hint="--force"):
        mesh = _build(args)
    save_mesh(mesh, args.output)
    count = f"{len(mesh.tets)} tets" if isinstance(mesh, TetMesh) else f"{mesh.n_faces} faces"
    print(f"wrote {args.output}: {count}, {len(mesh.points)} vertices "
          f"({'from cache' if STATS.last == 'cache' else 'built'})")
    return 0
