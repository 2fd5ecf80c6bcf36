"""Read and write meshes through meshio (STL, OBJ, VTK/VTU, Gmsh .msh, PLY, OFF, ...).

`load_mesh` returns a `TetMesh` when the file holds tetrahedra, else a `TriMesh` of its
triangles. STL stores every triangle with its own three vertices: coincident vertices
are merged (coordinates equal to 1e-8 mm, as trimesh does) so that the surface is
connected.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from geometry.errors import FecheckError
from geometry.mesh import TetMesh, TriMesh

#: Coordinates closer than this (mm) are the same vertex when merging.
MERGE_DECIMALS = 8


def _meshio_format(path: Path) -> None:
    from meshio._helpers import _filetypes_from_path, extension_to_filetypes

    try:
        _filetypes_from_path(path)
    except (KeyError, ValueError):
        known = ", ".join(sorted(extension_to_filetypes))
        raise FecheckError(f"{path}: unknown mesh format '{path.suffix}'; "
                           f"use one of {known}") from None


def merge_vertices(points: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge coincident vertices (to `MERGE_DECIMALS` decimals of a mm); drop unused ones."""
    used = np.unique(faces)
    keys = np.round(points[used], MERGE_DECIMALS) + 0.0
    unique_keys, first, inverse = np.unique(keys, axis=0, return_index=True,
                                            return_inverse=True)
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
    _meshio_format(path)
    try:
        raw = meshio.read(path)
    except Exception as err:  # meshio raises many types on corrupt input
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
    _meshio_format(path)
    if isinstance(mesh, TriMesh):
        cells = [("triangle", mesh.faces)]
    else:
        cells = [("tetra", mesh.tets)]
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        meshio.write(path, meshio.Mesh(mesh.points, cells))
    except OSError as err:
        raise FecheckError(f"{path}: cannot write mesh ({err})") from None
    return path
