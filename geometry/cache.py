"""On-disk mesh cache keyed by builder name and version, canonical parameters and gmsh;
and the in-process memo of what is derived from one mesh object (`per_mesh`).

Entries are ``.npz`` files under ``$FECHECK_CACHE_DIR`` (default ``~/.cache/fecheck``),
named by the sha256 of a JSON document holding the builder name, the builder's own
version (the ``version`` argument of `cached_build`: bump it in one builder when its meshes
change, and only that builder's entries are rebuilt), the parameters (floats rounded to 12
significant digits, keys sorted), the installed gmsh version (`gmsh_version`, read from
the package metadata without importing gmsh) and `FORMAT_VERSION`. Writes go to a
temporary file renamed into place (`geometry.files.write_output`), so parallel sweeps never
see half an entry. A damaged entry (cut short, unreadable, arrays of the wrong shape or
type) is removed and rebuilt, with a one-line warning naming it.

>>> cache_key("box", {"x": 1.0}, version=2) != cache_key("box", {"x": 1.0}, version=3)
True

`per_mesh` keeps ``fn(mesh, *args)`` for each `TriMesh` object (frozen: its arrays never
change) while that mesh lives, beside it rather than in it (a pickled mesh carries none of
it); for values that do not hold the mesh itself (a tree over the mesh would keep it alive).
"""

from __future__ import annotations

import functools
import hashlib
import importlib.metadata
import json
import os
import warnings
import weakref
import zipfile
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from geometry.errors import FecheckError
from geometry.files import write_output
from geometry.mesh import TetMesh, TriMesh

T = TypeVar("T")

#: Bump when the stored layout changes (a builder's output: its own `cached_build` version).
FORMAT_VERSION = 1

_warned_unwritable: set[str] = set()


@dataclass
class CacheStats:
    """Counts of cache hits and fresh builds in this process; `last` is the latest source."""

    hits: int = 0
    builds: int = 0
    last: str | None = None


#: Process-wide counters, updated by every `cached_build` call.
STATS = CacheStats()


def cache_dir() -> Path:
    """The cache folder: ``$FECHECK_CACHE_DIR`` or ``~/.cache/fecheck`` (not created)."""
    env = os.environ.get("FECHECK_CACHE_DIR")
    return Path(env).expanduser() if env else Path.home() / ".cache" / "fecheck"


def _canonical(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {str(k): _canonical(v) for k, v in sorted(value.items(), key=lambda kv: str(kv[0]))}
    if isinstance(value, np.ndarray):
        return _canonical(value.tolist())
    if isinstance(value, (list, tuple)):
        return [_canonical(v) for v in value]
    if value is None or isinstance(value, str):
        return value
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        v = float(value)
        if not np.isfinite(v):
            raise FecheckError(f"mesh parameter {value!r} is not finite")
        return float(f"{v:.12g}") + 0.0
    if hasattr(value, "coeffs"):
        return {"coeffs": _canonical(np.asarray(value.coeffs))}
    raise FecheckError(f"cannot use {type(value).__name__} as a mesh cache parameter")


@functools.cache
def gmsh_version() -> str:
    """The installed gmsh package's version (``"none"`` without gmsh), from its metadata:
    gmsh itself is not imported."""
    try:
        return importlib.metadata.version("gmsh")
    except importlib.metadata.PackageNotFoundError:
        return "none"


def cache_key(name: str, params: Mapping[str, Any], version: int = 1) -> str:
    """The hex sha256 identifying a build of `name` at builder `version` with `params`,
    under the installed gmsh and `FORMAT_VERSION`."""
    doc = {"builder": name, "builder_version": version, "params": _canonical(params),
           "gmsh": gmsh_version(), "version": FORMAT_VERSION}
    return hashlib.sha256(json.dumps(doc, sort_keys=True).encode()).hexdigest()


def _to_arrays(mesh: TriMesh | TetMesh) -> dict[str, np.ndarray]:
    if isinstance(mesh, TriMesh):
        out = {"kind": np.array("tri"), "points": mesh.points, "cells": mesh.faces}
        groups = mesh.regions
    else:
        out = {"kind": np.array("tet"), "points": mesh.points, "cells": mesh.tets}
        groups = mesh.boundaries
    out.update({f"group__{k}": np.asarray(v) for k, v in groups.items()})
    return out


_CELL_WIDTHS = {"tri": (3,), "tet": (4, 10)}
"""Vertices per cell of each stored mesh kind."""


def _check_arrays(data: Mapping[str, np.ndarray]) -> None:
    """Raise `FecheckError` saying what is wrong when a stored mesh's arrays do not make a
    mesh: (n, 3) finite float points, (m, 3) triangles or (m, 4|10) tets of integer
    indices below n, groups of indices below m (triangle regions: faces) or n (tet
    boundaries: vertices)."""
    kind, points, cells = str(data["kind"]), data["points"], data["cells"]
    if kind not in _CELL_WIDTHS:
        raise FecheckError(f"unknown mesh kind {kind!r}")
    widths = _CELL_WIDTHS[kind]
    if points.dtype.kind != "f" or points.ndim != 2 or points.shape[1] != 3:
        raise FecheckError(f"points of shape {points.shape} ({points.dtype}), not (n, 3) "
                           "floats")
    if not np.isfinite(points).all():
        raise FecheckError("points not finite")
    if cells.dtype.kind not in "iu" or cells.ndim != 2 or cells.shape[1] not in widths:
        raise FecheckError(f"cells of shape {cells.shape} ({cells.dtype}), not (m, "
                           f"{'|'.join(map(str, widths))}) integers")
    limits = {"cells": len(points)}
    limits |= {k: len(cells) if kind == "tri" else len(points)
               for k in data if k.startswith("group__")}
    for name, limit in limits.items():
        index = data[name]
        if index.dtype.kind not in "iu":
            raise FecheckError(f"{name} of type {index.dtype}, not integers")
        if index.size and (index.min() < 0 or index.max() >= limit):
            raise FecheckError(f"{name} index {index.max()} out of range 0..{limit - 1}")


def _from_arrays(data: Mapping[str, np.ndarray]) -> TriMesh | TetMesh:
    _check_arrays(data)
    groups = {k[len("group__"):]: data[k] for k in data if k.startswith("group__")}
    if str(data["kind"]) == "tri":
        return TriMesh(data["points"], data["cells"], groups)
    return TetMesh(data["points"], data["cells"], groups)


def _writable_dir() -> Path | None:
    folder = cache_dir()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        if not os.access(folder, os.W_OK):
            raise PermissionError(f"{folder} is not writable")
    except OSError as err:
        if str(folder) not in _warned_unwritable:
            _warned_unwritable.add(str(folder))
            warnings.warn(f"mesh cache disabled ({err}); set FECHECK_CACHE_DIR to a writable "
                          "folder to reuse meshes between runs", stacklevel=3)
        return None
    return folder


def cached_build(name: str, params: Mapping[str, Any],
                 build: Callable[[], TriMesh | TetMesh], use_cache: bool = True,
                 info: dict | None = None, *, version: int = 1) -> TriMesh | TetMesh:
    """Return ``build()``, read from the cache when an entry for (name, version, params)
    built under the installed gmsh exists.

    Parameters
    ----------
    name : builder name, e.g. ``"icosphere"``
    params : everything the result depends on (numbers, strings, lists, Polynomial2D)
    build : makes the mesh when it is not cached
    use_cache : False to always build (and not store)
    info : if given, receives ``{"source": "cache" | "built", "key": ..., "path": ...}``
    version : the builder's version; bump it when the builder's meshes change, so that its
        old entries (and no other builder's) are rebuilt

    A cache hit returns arrays identical to those stored from the fresh build.
    """
    key = cache_key(name, params, version)
    path = _entry(name, key) if use_cache else None
    if info is not None:
        info.update({"key": key, "path": str(path) if path else None})
    mesh = _load(path, _from_arrays)
    if mesh is not None:
        if info is not None:
            info["source"] = "cache"
        STATS.hits += 1
        STATS.last = "cache"
        return mesh
    mesh = build()
    if info is not None:
        info["source"] = "built"
    STATS.builds += 1
    STATS.last = "built"
    if path is not None:
        _store(path, _to_arrays(mesh))
    return mesh


def _entry(name: str, key: str) -> Path | None:
    """The entry file of `key` (None when the cache folder cannot be written)."""
    folder = _writable_dir()
    return folder / f"{name}-{key[:32]}.npz" if folder is not None else None


_DAMAGED = (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile, FecheckError)
"""What reading a damaged entry raises: cut short (BadZipFile, EOFError), not an npz
(ValueError), missing arrays (KeyError), arrays that make no mesh (FecheckError)."""


def _load(path: Path | None, convert: Callable[[dict[str, np.ndarray]], Any]) -> Any:
    """`convert` of a stored entry's arrays, or None for no entry; a damaged one is
    removed with a one-line warning (and rebuilt by the caller)."""
    if path is None or not path.is_file():
        return None
    try:
        with open(path, "rb") as fh:
            data = np.load(fh, allow_pickle=False)
            if not hasattr(data, "files"):
                raise ValueError("a single array, not an npz archive")
            with data:
                return convert({k: data[k] for k in data.files})
    except _DAMAGED as err:
        reason = " ".join(f"{type(err).__name__}: {err}".split())[:160]
        warnings.warn(f"mesh cache entry {path} was damaged ({reason}); rebuilt",
                      stacklevel=3)
        path.unlink(missing_ok=True)
        return None


def _store(path: Path, arrays: Mapping[str, np.ndarray]) -> None:
    """Write an entry by `write_output` (a temporary file renamed into place)."""
    try:
        write_output(path, lambda tmp: np.savez(tmp, **arrays))
    except FecheckError as err:
        warnings.warn(f"could not write mesh cache entry ({err})", stacklevel=3)


def content_digest(items: list[TriMesh | np.ndarray]) -> str:
    """sha256 of the arrays of meshes and arrays (their values, shapes and types)."""
    h = hashlib.sha256()
    for item in items:
        arrays = (item.points, item.faces) if isinstance(item, TriMesh) else (item,)
        for a in arrays:
            a = np.ascontiguousarray(a)
            h.update(f"{a.dtype.str}{a.shape}".encode())
            h.update(a.tobytes())
    return h.hexdigest()


def cached_arrays(name: str, inputs: list[TriMesh | np.ndarray],
                  build: Callable[[], tuple[np.ndarray, ...]], *, version: int = 1
                  ) -> tuple[np.ndarray, ...]:
    """``build()``, arrays computed from `inputs` alone (meshes, arrays), read from the
    cache when an entry for (name, version, the inputs' content) exists."""
    path = _entry(name, cache_key(name, {"inputs": content_digest(inputs)}, version))
    out = _load(path, lambda data: tuple(data[f"value_{i}"] for i in range(len(data))))
    if out is not None:
        STATS.hits += 1
        return out
    out = tuple(np.asarray(a) for a in build())
    STATS.builds += 1
    if path is not None:
        _store(path, {f"value_{i}": a for i, a in enumerate(out)})
    return out


def per_mesh(fn: Callable[..., T]) -> Callable[..., T]:
    """`fn(mesh, *args)` computed once per `TriMesh` object and hashable `args`, kept while
    the mesh lives (a sweep reads the same sheets at every point; a mesh that is dropped
    takes its values with it). The value is shared by every caller: it must not hold
    `mesh` (that would keep it alive; `mesh` itself as the value is not kept) and is not
    to be changed (return read-only arrays)."""
    memo: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()

    @functools.wraps(fn)
    def cached(mesh: TriMesh, *args) -> T:
        values = memo.setdefault(mesh, {})
        if args in values:
            return values[args]
        value = fn(mesh, *args)
        if value is not mesh:
            values[args] = value
        return value
    return cached
