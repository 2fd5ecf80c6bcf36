"""Provenance of a result file: what made it, from what, and in how long.

Every ``--json`` output (and the calibration file) carries `provenance(...)` under the key
``provenance``: the fecheck and Python versions, the command line, the resolved scene
(every key's value after the defaults and ``--set``, the keys ``--set`` gave, the scene
file), the sha256 of every input file, and the wall and CPU time of the command.
``fecheck run --from RESULT.json`` rebuilds the scene from it (`recorded_scene`) and
refuses when an input file's content changed (`changed_inputs`).

The clock starts when this module is imported, or at `start_clock` (the CLI calls it
first); the CPU time counts this process's threads and its finished child processes
(the workers of a pool).
"""

from __future__ import annotations

import hashlib
import math
import os
import platform
import sys
import time
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from fecheck.errors import FecheckError
from fecheck.scene.load import Scene, scene_from_values
from fecheck.scene.packaged import PACKAGE_PREFIX, data_dir
from fecheck.scene.relevance import inert_keys
from fecheck.scene.schema import SCHEMA

DATA_SUFFIXES = (".json", ".stl", ".obj", ".ply", ".vtk", ".vtu", ".msh", ".off")
"""Files of a data folder (``menisci.dir``) counted as its inputs (not its licence or
readme)."""
FILE_KEYS = ("geometry.femur", "geometry.tibia", "geometry.tibia_lateral",
             "geometry.femur_bone", "geometry.tibia_bone", "geometry.ligaments",
             "geometry.tibia_solid", "contact.calibration", "menisci.calibration")
"""Scene keys that name one input file."""
FOLDER_KEYS = ("menisci.dir", "patella.dir")
"""Scene keys that name a data folder, whose data files are inputs."""

_started = (time.perf_counter(), time.process_time(), os.times())
_command: list[str] | None = None


def start_clock(command: Sequence[str] | None = None) -> None:
    """Start the wall and CPU clocks of `provenance` now; `command` is the command line's
    arguments after ``fecheck`` (default: the process's own)."""
    global _started, _command
    _started = (time.perf_counter(), time.process_time(), os.times())
    _command = None if command is None else list(command)


def elapsed() -> tuple[float, float]:
    """(wall s, CPU s) since `start_clock`: CPU of this process and its waited-for
    children."""
    wall0, cpu0, times0 = _started
    now = os.times()
    children = (now.children_user - times0.children_user
                + now.children_system - times0.children_system)
    return time.perf_counter() - wall0, time.process_time() - cpu0 + children


def fecheck_version() -> str:
    """The installed fecheck package's version (its metadata), or "unknown"."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("fecheck")
    except PackageNotFoundError:
        return "unknown"


def sha256(path: str | Path) -> str:
    """sha256 (hex) of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _scene_dir(scene: Scene) -> Path:
    return Path(scene.source).expanduser().resolve().parent


def _folder(scene: Scene, key: str) -> Path | None:
    """The folder a folder key (``menisci.dir``) names, or None (unset or missing)."""
    given = scene[key]
    if not given:
        return None
    if given.startswith(PACKAGE_PREFIX):
        return data_dir(given, key)
    folder = Path(os.path.expandvars(given)).expanduser()
    folder = folder if folder.is_absolute() else (_scene_dir(scene) / folder).resolve()
    return folder if folder.is_dir() else None


def _file(scene: Scene, key: str) -> Path | None:
    """The file a file key names (geometry paths relative to ``geometry.dir``, the
    calibration to the scene's folder), or None."""
    from fecheck.scene.surfaces import file_path

    if key.startswith("geometry."):
        path = file_path(scene, key.split(".", 1)[1])
    else:
        value = scene[key]
        path = Path(os.path.expandvars(value)).expanduser() if value else None
        if path is not None and not path.is_absolute():
            path = _scene_dir(scene) / path
    return path if path is not None and path.is_file() else None


def input_files(scene: Scene) -> list[tuple[str, Path]]:
    """(role, path) of every input file `scene` reads: the scene file, each file key that
    has an effect in it, and the data files of ``menisci.dir`` and ``patella.dir``. Keys
    without effect in the scene's configuration (`fecheck.scene.relevance`) and missing
    files are left out (a run that needs one stops before it writes a result)."""
    out: list[tuple[str, Path]] = []
    source = Path(scene.source)
    if source.is_file():
        out.append(("scene", source.resolve()))
    set_keys = [k for k in (*FILE_KEYS, *FOLDER_KEYS) if scene[k]]
    inert = {k for k, _ in inert_keys(scene, set_keys)}
    for key in set_keys:
        path = None if key in inert or key in FOLDER_KEYS else _file(scene, key)
        if path is not None:
            out.append((key, path.resolve()))
    for key in FOLDER_KEYS:
        folder = _folder(scene, key) if key in set_keys and key not in inert else None
        if folder is not None:
            out += [(key, p.resolve()) for p in sorted(folder.rglob("*"))
                    if p.is_file() and p.suffix.lower() in DATA_SUFFIXES]
    return out


def file_records(files: Iterable[tuple[str, str | Path]]) -> list[dict[str, str]]:
    """[{"role", "path", "sha256"}] of (role, path) pairs."""
    return [{"role": role, "path": str(path), "sha256": sha256(path)} for role, path in files]


def scene_record(scene: Scene) -> dict[str, Any]:
    """The resolved scene: its file, every key's value, the ``--set`` texts and keys."""
    source = Path(scene.source)
    return {"source": str(source.resolve()) if source.exists() else scene.source,
            "label": scene.label, "values": {k: _json_value(v) for k, v in scene.values.items()},
            "overrides": list(scene.overrides), "set_keys": list(scene.set_keys)}


INFINITE = {"inf": math.inf, "-inf": -math.inf}
"""How an infinite number (a rigid body's modulus) is recorded: JSON has no infinity."""


def _json_value(value: Any) -> Any:
    """`value` as strict JSON holds it: an infinite float as its `INFINITE` text."""
    if isinstance(value, float) and math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return value


def _scene_value(key: str, value: Any) -> Any:
    """A recorded value back as the scene holds it: the `INFINITE` text of a number key."""
    if isinstance(value, str) and value in INFINITE and SCHEMA[key].kind in ("int", "float"):
        return INFINITE[value]
    return value


def provenance(scene: Scene | None = None,
               files: Iterable[tuple[str, str | Path]] = ()) -> dict[str, Any]:
    """The ``provenance`` block of a result file: versions, command, resolved `scene`
    (None for a verb without one), sha256 of the scene's input files and of `files`
    ((role, path) pairs), wall and CPU seconds since `start_clock`."""
    records = file_records((input_files(scene) if scene is not None else []) + list(files))
    wall, cpu = elapsed()
    return {"fecheck_version": fecheck_version(),
            "python_version": platform.python_version(),
            "command": ["fecheck", *(sys.argv[1:] if _command is None else _command)],
            "scene": None if scene is None else scene_record(scene),
            "input_files": records, "wall_s": wall, "cpu_s": cpu}


def with_provenance(data: Mapping[str, Any], scene: Scene | None = None,
                    files: Iterable[tuple[str, str | Path]] = ()) -> dict[str, Any]:
    """`data` with a ``provenance`` entry added (its other fields unchanged)."""
    return {**data, "provenance": provenance(scene, files)}


def recorded_scene(result: Mapping[str, Any], where: str) -> Scene:
    """The scene a result file's provenance records (values and ``--set`` texts), checked
    again; `FecheckError` when `result` (read from `where`) carries none."""
    stamp = result.get("provenance") if isinstance(result, Mapping) else None
    record = stamp.get("scene") if isinstance(stamp, Mapping) else None
    if not isinstance(record, Mapping) or not isinstance(record.get("values"), Mapping):
        raise FecheckError(f"{where} holds no recorded scene (no provenance.scene.values): "
                           "give a JSON written by `fecheck run --json` of this version")
    values = {k: _scene_value(k, v) if k in SCHEMA else v for k, v in record["values"].items()}
    return scene_from_values(values, str(record.get("source", where)),
                             tuple(record.get("overrides", ())), f"{where} (recorded scene)")


def changed_inputs(result: Mapping[str, Any], scene: Scene) -> list[str]:
    """What differs between the input files a result recorded and those `scene` reads
    now (the scene file aside: its values are recorded): one text per file."""
    listed = result["provenance"].get("input_files") or []
    recorded = {(r["role"], r["path"]): r["sha256"] for r in listed
                if isinstance(r, Mapping) and {"role", "path", "sha256"} <= set(r)
                and r["role"] != "scene"}
    now = {(role, str(path)): sha256(path) for role, path in input_files(scene)
           if role != "scene"}
    out = [f"{path} ({role}) is gone or no longer read" for (role, path) in recorded
           if (role, path) not in now]
    for (role, path), digest in now.items():
        then = recorded.get((role, path))
        if then is None:
            out.append(f"{path} ({role}) is read now but was not then")
        elif then != digest:
            out.append(f"{path} ({role}) changed (sha256 {then[:12]}… then, {digest[:12]}… "
                       "now)")
    return out
