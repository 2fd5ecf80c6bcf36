"""Read and write meshes through meshio (STL, OBJ, VTK/VTU, Gmsh .msh, PLY, OFF, ...).

`load_mesh` returns a `TetMesh` when the file holds tetrahedra (10-node ones in Gmsh's
node order, as `geometry.layer` builds them), else a `TriMesh` of its
triangles. STL stores every triangle with its own three vertices: coincident vertices
are merged (coordinates equal to 1e-8 mm, as trimesh does) so that the surface is
connected.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from geometry.errors import FecheckError
from geometry.mesh import TetMesh, TriMesh

#: Gmsh orders the last two edge nodes of a 10-node tet (2-3, 1-3); meshio/VTK (1-3, 2-3).
_TET10_SWAP = [0, 1, 2, 3, 4, 5, 6, 7, 9, 8]
#: Coordinates closer than this (mm) are the same vertex when merging.
MERGE_DECIMALS = 8


def check_format(path: str | Path) -> None:
    """Raise FecheckError unless meshio knows the extension of `path`."""
    from meshio import ReadError
    from meshio._helpers import _filetypes_from_path, extension_to_filetypes

    path = Path(path)
    try:
        _filetypes_from_path(path)
    except (KeyError, ValueError, ReadError):
        known = ", ".join(sorted(extension_to_filetypes))
        raise FecheckError(f"{path}: unknown mesh format '{path.suffix}'; "
                           f"use one of {known}") from None


def _format_option(path: Path) -> dict:
    """meshio reads and writes .msh as ANSYS first; fecheck means Gmsh's format."""
    return {"file_format": "gmsh"} if path.suffix.lower() == ".msh" else {}


def merge_vertices(points: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge coincident vertices (to `MERGE_DECIMALS` decimals of a mm); drop unused ones."""
    used = np.unique(faces)
    keys = np.round(points[used], MERGE_DECIMALS) + 0.0
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    remap = np.empty(len(points), dtype=np.int64)
    remap[used] = inverse.ravel()
    return points[used][first], remap[faces]


def load_mesh(path: str | Path) -> TriMesh | TetMesh:
    """Read a surface or tetrahedral mesh (mm) from `path`.

    Raises
    ------
    FecheckError
        when the file is missing, its extension unknown, its content unreadable, or it
        holds no triangles or tetrahedra.
    """
    import meshio

    path = Path(path)
    if not path.is_file():
        raise FecheckError(f"{path}: mesh file not found")
    check_format(path)
    try:
        with warnings.catch_warnings():
            # meshio's STL reader probes binary/ASCII with arithmetic that may overflow
            warnings.simplefilter("ignore", RuntimeWarning)
            raw = meshio.read(path, **_format_option(path))
    except Exception as err:  # noqa: BLE001 - meshio raises many types on corrupt input
        raise FecheckError(f"{path}: cannot read mesh ({type(err).__name__}: {err})") from None
    points = np.asarray(raw.points, dtype=float)
    if points.ndim != 2 or points.shape[1] not in (2, 3) or len(points) == 0:
        raise FecheckError(f"{path}: the file holds no 3D points")
    if points.shape[1] == 2:
        points = np.column_stack([points, np.zeros(len(points))])
    if not np.all(np.isfinite(points)):
        raise FecheckError(f"{path}: the mesh has NaN or infinite coordinates")
    blocks = {}
    for block in raw.cells:
        blocks.setdefault(block.type, []).append(np.asarray(block.data, dtype=np.int64))
    if "tetra10" in blocks:
        tets = np.concatenate(blocks["tetra10"])[:, _TET10_SWAP]
        bounds = {"triangles": np.concatenate(blocks["triangle6"])} if "triangle6" in blocks else {}
        return TetMesh(points, tets, bounds)
    if "tetra" in blocks:
        tets = np.concatenate(blocks["tetra"])
        bounds = {"triangles": np.concatenate(blocks["triangle"])} if "triangle" in blocks else {}
        return TetMesh(points, tets, bounds)
    if "triangle" not in blocks:
        found = ", ".join(sorted(blocks)) or "no cells"
        raise FecheckError(f"{path}: no triangles in the mesh (found {found})")
    faces = np.concatenate(blocks["triangle"])
    if len(faces) == 0:
        raise FecheckError(f"{path}: no triangles in the mesh")
    if path.suffix.lower() == ".stl":
        points, faces = merge_vertices(points, faces)
    return TriMesh(points, faces)


def save_mesh(mesh: TriMesh | TetMesh, path: str | Path) -> Path:
    """Write `mesh` to `path` in the format its extension names (any meshio format)."""
    import meshio

    path = Path(path)
    check_format(path)
    if isinstance(mesh, TriMesh):
        kind, cells = "triangle", mesh.faces
    elif mesh.tets.shape[1] == 4:
        kind, cells = "tetra", mesh.tets
    else:
        kind, cells = "tetra10", mesh.tets[:, _TET10_SWAP]
    if len(mesh.points) < 2**31:
        cells = cells.astype(np.int32)
    extra = {"binary": True} if path.suffix.lower() == ".stl" else _format_option(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        meshio.write(path, meshio.Mesh(mesh.points, [(kind, cells)]), **extra)
    except Exception as err:  # noqa: BLE001 - meshio: KeyError/ValueError/OSError on writes
        raise FecheckError(f"{path}: cannot write mesh ({type(err).__name__}: {err})") from None
    return path
