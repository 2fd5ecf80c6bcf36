"""Read and write meshes through meshio (STL, OBJ, VTK/VTU, Gmsh .msh, PLY, OFF, ...).

`load_mesh` returns a `TetMesh` when the file holds tetrahedra (10-node ones in Gmsh's
node order, as `geometry.layer` builds them), else a `TriMesh` of its
triangles. STL stores every triangle with its own three vertices: coincident vertices
are merged (coordinates equal to 1e-8 mm, as trimesh does) so that the surface is
connected.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np

from geometry.errors import FecheckError
from geometry.files import write_output
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


STL_HEADER_BYTES = 84
"""A binary STL: an 80-byte header and a uint32 triangle count, then 50 bytes per
triangle (normal, three vertices as float32, a uint16 attribute)."""


def _looks_binary(head: bytes) -> bool:
    """Whether an STL's first bytes are binary (an ASCII STL starts with "solid" and holds
    no NUL or non-ASCII byte)."""
    return not head.lstrip().startswith(b"solid") or any(b == 0 or b > 127 for b in head)


def stl_problem(path: str | Path) -> str | None:
    """Why an STL file cannot be whole, or None: empty, shorter than a binary header, or a
    binary STL whose size disagrees with the triangle count in its header (truncated,
    e.g. a copy or download cut short)."""
    path = Path(path)
    size = path.stat().st_size
    if size == 0:
        return "the file is empty (0 bytes)"
    with open(path, "rb") as fh:
        head = fh.read(STL_HEADER_BYTES)
    if not _looks_binary(head):
        return None
    if size < STL_HEADER_BYTES:
        return (f"the file has {size} bytes, fewer than the {STL_HEADER_BYTES}-byte header of "
                "a binary STL: it is truncated")
    count = int.from_bytes(head[80:84], "little")
    expected = STL_HEADER_BYTES + 50 * count
    if size == expected:
        return None
    whole = (size - STL_HEADER_BYTES) // 50
    how = "truncated" if size < expected else "longer than its header says (corrupt)"
    return (f"binary STL {how}: its header counts {count} triangles ({expected} bytes) but "
            f"the file has {size} bytes ({whole} whole triangles); copy or export it again")


_CHUNK = 1 << 24


def _count_in_file(path: Path, token: bytes) -> int:
    """Occurrences of `token` in the file, read in 16 MB chunks (0.1 s per 100 MB)."""
    count, tail = 0, b""
    with open(path, "rb") as fh:
        while chunk := fh.read(_CHUNK):
            data = tail + chunk
            count += data.count(token)
            tail = data[-(len(token) - 1):] if len(token) > 1 else b""   # a token split
    return count


def face_count(path: str | Path) -> int | None:
    """The number of faces a mesh file holds, read without loading it: a binary STL's
    header, an ASCII STL's 'endfacet' lines, an OBJ's 'f' lines, a PLY's or OFF's header;
    None for other formats (or a header that does not say).

    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "t.obj"
    >>> _ = p.write_text(chr(10).join(["v 0 0 0", "v 1 0 0", "v 0 1 0", "f 1 2 3", ""]))
    >>> face_count(p)
    1
    """
    path = Path(path)
    suffix = path.suffix.lower()
    with open(path, "rb") as fh:
        head = fh.read(4096)
    if suffix == ".stl":
        if _looks_binary(head[:STL_HEADER_BYTES]):
            return int.from_bytes(head[80:84], "little") if len(head) >= 84 else None
        return _count_in_file(path, b"endfacet")
    if suffix == ".obj":
        return _count_in_file(path, b"\nf ") + int(head.startswith(b"f "))
    if suffix == ".ply":
        found = re.search(rb"element\s+face\s+(\d+)", head)
        return int(found[1]) if found else None
    if suffix == ".off":
        words = [w for line in head.splitlines()[:4] for w in line.split()
                 if not line.lstrip().startswith(b"#")]
        return int(words[2]) if len(words) > 2 and words[2].isdigit() else None
    return None


def _ascii_stl_hint(path: Path) -> str:
    """A hint for an ASCII STL meshio could not read: truncated if it lacks 'endsolid'."""
    with open(path, "rb") as fh:
        fh.seek(max(path.stat().st_size - 4096, 0))
        tail = fh.read()
    return "" if b"endsolid" in tail else "; the ASCII STL has no 'endsolid' line: truncated?"


def _read(path: Path):
    """meshio's reading of `path`; `FecheckError` (one line naming the file) when the file
    is cut short (`stl_problem`) or meshio cannot read it."""
    import meshio

    stl = path.suffix.lower() == ".stl"
    problem = stl_problem(path) if stl else None
    if problem:
        raise FecheckError(f"{path}: cannot read mesh: {problem}")
    try:
        with warnings.catch_warnings():
            # meshio's STL reader probes binary/ASCII with arithmetic that may overflow
            warnings.simplefilter("ignore", RuntimeWarning)
            return meshio.read(path, **_format_option(path))
    except Exception as err:  # noqa: BLE001 - meshio raises many types on corrupt input
        hint = _ascii_stl_hint(path) if stl else ""
        reason = " ".join(f"{type(err).__name__}: {err}".split())[:200]
        raise FecheckError(f"{path}: cannot read mesh ({reason}){hint}") from None


def load_mesh(path: str | Path) -> TriMesh | TetMesh:
    """Read a surface or tetrahedral mesh (mm) from `path`.

    Raises
    ------
    FecheckError
        (one line naming the file) when the file is missing, its extension unknown, its
        content unreadable or cut short (`stl_problem`), or it holds no triangles or
        tetrahedra.
    """
    path = Path(path)
    if path.is_dir():
        raise FecheckError(f"{path} is a folder, not a mesh file; give the mesh files in it "
                           "(STL, OBJ, PLY, VTK/VTU, MSH)")
    if not path.is_file():
        raise FecheckError(f"{path}: mesh file not found")
    check_format(path)
    raw = _read(path)
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
    """Write `mesh` to `path` in the format its extension names (any meshio format), by
    `geometry.files.write_output` (a regular file replaced in one step)."""
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
        write_output(path, lambda tmp: meshio.write(tmp, meshio.Mesh(mesh.points,
                                                                     [(kind, cells)]), **extra))
    except FecheckError:
        raise
    except Exception as err:  # noqa: BLE001 - meshio: KeyError/ValueError/OSError on writes
        raise FecheckError(f"{path}: cannot write mesh ({type(err).__name__}: {err})") from None
    return path
