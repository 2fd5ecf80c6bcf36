"""The fingerprint of a scene's contact geometry and material, for the files made for it.

A calibration file (`fecheck calibrate`) holds C and n fitted to one knee's surfaces,
layer and material; it carries to another scene only with the same ones. Its fingerprint
is the sha256 of: the material and layer keys (`MATERIAL_KEYS`), the keys that shape the
analytic surfaces (``plateau.*``, ``knee.*``, ``mesh.*``), and for the scanned kinds the
arrays of the surfaces the run reads (the tibial compartments as split and decimated, the
femoral surface, the bones of a bone-distance thickness: points in mm, faces).
"""

from __future__ import annotations

import hashlib
import json

import numpy as np

from fecheck.scene import Scene
from fecheck.scene.relevance import SCANNED_KINDS
from fecheck.scene.schema import SCHEMA

MATERIAL_KEYS = ("model.kind", "contact.youngs_MPa", "contact.poisson", "contact.thickness_mm",
                 "scanned.thickness")
"""Keys of the material and layer a calibration is fitted to."""
SHAPE_SECTIONS = ("plateau.", "knee.", "mesh.")
"""Key prefixes of the surfaces a scene builds from numbers."""


def _surfaces(scene: Scene) -> list:
    """The scanned surfaces the run reads (mm, thesis frame), in a fixed order."""
    from fecheck.model.scanned import femoral_master, tibial_slaves
    from fecheck.scene import surfaces

    slaves = tibial_slaves(scene)
    out = [slaves[c] for c in sorted(slaves)]
    if surfaces.file_path(scene, "femur") is not None:
        out.append(femoral_master(scene))
    if scene["scanned.thickness"] == "bone-distance":
        out += [surfaces.bone(scene, "femur"), surfaces.bone(scene, "tibia")]
    return out


def scene_fingerprint(scene: Scene) -> str:
    """sha256 (hex) of the scene's contact surfaces and material (module docstring)."""
    h = hashlib.sha256()
    keys = [*MATERIAL_KEYS, *(k for k in SCHEMA if k.startswith(SHAPE_SECTIONS))]
    h.update(json.dumps({k: scene[k] for k in keys}, sort_keys=True, default=str).encode())
    if scene["model.kind"] in SCANNED_KINDS:
        for mesh in _surfaces(scene):
            h.update(np.ascontiguousarray(mesh.points, dtype=np.float64).tobytes())
            h.update(np.ascontiguousarray(mesh.faces, dtype=np.int64).tobytes())
    return h.hexdigest()
