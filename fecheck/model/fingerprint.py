"""The fingerprint of a scene's contact geometry and material, for the files made for it.

A calibration file (`fecheck calibrate`) holds C and n fitted to one knee's surfaces,
layer and material; it carries to another scene only with the same ones. Its fingerprint
is the sha256 of: the material and layer keys (`MATERIAL_KEYS`, and `SIDE_KEYS` where
set), the keys that shape the analytic surfaces (``plateau.*``, ``knee.*``, ``mesh.*``),
and for the scanned kinds the arrays of the surfaces the run reads (the tibial
compartments as split and decimated, the femoral surface, the bones of a bone-distance
thickness: points in mm, faces). It is kept
per process for the same keys and file contents (a decimated knee takes ~1.5 s to build,
and `fecheck calibrate` reads its file at every EF equilibrium).
"""

from __future__ import annotations

import hashlib
import json

import numpy as np

from fecheck.model.knee_surfaces import femoral_master, tibial_slaves
from fecheck.scene import Scene, surfaces
from fecheck.scene.relevance import SCANNED_KINDS
from fecheck.scene.schema import SCHEMA

MATERIAL_KEYS = ("model.kind", "contact.youngs_MPa", "contact.poisson", "contact.thickness_mm",
                 "scanned.thickness")
"""Keys of the material and layer a calibration is fitted to."""
SIDE_KEYS = ("contact.femoral_share", "contact.femoral_youngs_MPa", "contact.femoral_poisson")
"""Keys that set the femoral layer apart: part of the fingerprint only where set away from
their defaults (the fingerprints of scenes that leave them alone are unchanged)."""
SHAPE_SECTIONS = ("plateau.", "knee.", "mesh.")
"""Key prefixes of the surfaces a scene builds from numbers."""
_MEMO: dict[str, str] = {}
"""Fingerprints by what they are made of: keys, folder and file contents."""


def _surfaces(scene: Scene) -> list:
    """The scanned surfaces the run reads (mm, thesis frame), in a fixed order."""
    slaves = tibial_slaves(scene)
    out = [slaves[c] for c in sorted(slaves)]
    if surfaces.file_path(scene, "femur") is not None:
        out.append(femoral_master(scene))
    if scene["scanned.thickness"] == "bone-distance":
        out += [surfaces.bone(scene, "femur"), surfaces.bone(scene, "tibia")]
    return out


def _memo_key(scene: Scene) -> str:
    """Everything a scene's fingerprint depends on: its geometry, layer, shape and material
    keys, the folder its files resolve in and the files' contents."""
    keys = [k for k in SCHEMA if k in MATERIAL_KEYS or k in SIDE_KEYS
            or k.startswith((*SHAPE_SECTIONS, "geometry.", "scanned."))]
    paths = [surfaces.file_path(scene, k) for k in surfaces.FILE_KEYS]
    digests = [surfaces.file_digest(p) if p.is_file() else str(p) for p in paths if p]
    return json.dumps([{k: scene[k] for k in keys}, str(surfaces.base_dir(scene)), digests],
                      sort_keys=True, default=str)


def scene_fingerprint(scene: Scene) -> str:
    """sha256 (hex) of the scene's contact surfaces and material (module docstring)."""
    memo = _memo_key(scene)
    if memo in _MEMO:
        return _MEMO[memo]
    h = hashlib.sha256()
    keys = [*MATERIAL_KEYS, *(k for k in SCHEMA if k.startswith(SHAPE_SECTIONS))]
    h.update(json.dumps({k: scene[k] for k in keys}, sort_keys=True, default=str).encode())
    sides = {k: scene[k] for k in SIDE_KEYS if scene[k] != SCHEMA[k].default}
    if sides:
        h.update(json.dumps(sides, sort_keys=True).encode())
    if scene["model.kind"] in SCANNED_KINDS:
        for mesh in _surfaces(scene):
            h.update(np.ascontiguousarray(mesh.points, dtype=np.float64).tobytes())
            h.update(np.ascontiguousarray(mesh.faces, dtype=np.int64).tobytes())
    if len(_MEMO) >= 64:
        _MEMO.clear()
    _MEMO[memo] = h.hexdigest()
    return _MEMO[memo]
