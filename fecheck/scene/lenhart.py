"""The lenhart2015 scanned right knee packaged with fecheck: where it is, its files and
its landmarks, for the validation scripts and tests that reproduce the thesis on it.

fecheck itself reads any knee through a scene's ``[geometry]`` keys; the packaged scenes
``sphere_tibia.toml`` and ``femur_tibia.toml`` name these files in
``geometry.dir = "fecheck:knee/lenhart2015"``. The files (MRI-derived, Apache-2.0, see
its README.md and docs/data.md) are read from the installed package,
``fecheck/data/knee/lenhart2015``, or from where ``$FECHECK_KNEE_DIR`` points (e.g. the
whole data set, ../shared/data/knee/lenhart2015). Every mesh is in mm in the thesis frame
at 0° flexion, femur and tibia frames coinciding (its README, "Pose and transform").

Landmarks (mm) come from the data set itself, so that geometry and ligaments agree:
condyle centres and radii from the femoral condyle sphere fits of ``fits.json``; contact
points the lowest point of each sphere, centre − R·e_z; ligament attachments the means
of the ``ligaments.json`` bundles of each group.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fecheck.errors import FecheckError
from fecheck.scene.bundles import Bundle, read_bundles
from fecheck.scene.constants import COMPARTMENTS
from fecheck.scene.packaged import data_dir
from fecheck.scene.surfaces import read_surface
from geometry.mesh import TriMesh

ENV_VAR = "FECHECK_KNEE_DIR"
DEFAULT_DIR = data_dir("fecheck:knee/lenhart2015")

FILES = {
    "femur_cartilage": "lenhart2015_R_femur_cartilage.stl",
    "femur_bone": "lenhart2015_R_femur_bone_distal60.stl",
    "tibia_cartilage_medial": "lenhart2015_R_tibia_cartilage_medial.stl",
    "tibia_cartilage_lateral": "lenhart2015_R_tibia_cartilage_lateral.stl",
    "tibia_bone": "lenhart2015_R_tibia_bone_proximal40.stl",
}


ANKLE_CENTRE_MM = (-1.757, -4.2, -381.0)
"""The ankle centre, on the mechanical axis (the data set's README, "Frame"): the shipped
scenes' load point."""


def knee_dir(*, must_exist: bool = True) -> Path:
    """The data folder: $FECHECK_KNEE_DIR, else the packaged one; `FecheckError` saying
    where it looked when its ``fits.json`` is missing and `must_exist`."""
    env = os.environ.get(ENV_VAR)
    path = Path(env).expanduser() if env else DEFAULT_DIR
    if must_exist and not (path / "fits.json").is_file():
        how = f"${ENV_VAR}" if env else "the package's data"
        raise FecheckError(f"scanned knee data not found at {path} (from {how}); put the "
                           f"lenhart2015 folder there or set {ENV_VAR}")
    return path


def mesh(name: str) -> TriMesh:
    """One of the data set's meshes by its short name (keys of `FILES`), mm."""
    path = knee_dir() / FILES[name]
    if not path.is_file():
        raise FecheckError(f"scanned mesh {path} is missing from the knee data folder")
    return read_surface(path)


def read_fits() -> dict:
    """The ``fits.json`` of the data set (reference fits and rest-pose checks)."""
    return json.loads((knee_dir() / "fits.json").read_text())


def bundles() -> tuple[Bundle, ...]:
    """The 55 tibiofemoral ligament bundles of ``ligaments.json``."""
    return read_bundles(knee_dir() / "ligaments.json")


@dataclass(frozen=True)
class Landmarks:
    """Condyle spheres and contact points of the scanned knee, mm."""

    condyle_center: dict[str, np.ndarray]
    condyle_radius_mm: dict[str, float]
    contact_point: dict[str, np.ndarray]


def landmarks() -> Landmarks:
    """Condyle spheres (fits.json) and contact points (lowest sphere points)."""
    fits = read_fits()["fits"]
    centre, radius, contact = {}, {}, {}
    for c in COMPARTMENTS:
        f = fits[f"femoral_condyle_{c}_sphere"]
        centre[c] = np.asarray(f["centre_mm"], dtype=float)
        radius[c] = float(f["radius_mm"])
        contact[c] = centre[c] - np.array([0.0, 0.0, radius[c]])
    return Landmarks(centre, radius, contact)


def knee_landmarks_table() -> dict:
    """The scene's ``[knee.landmarks]`` table for the scanned knee (mm, rounded to 1 µm):
    condyle centres and contact points from `landmarks`, the ACL, PCL and MCL attachments
    the means of their bundles' attachments."""
    lm = landmarks()
    groups: dict[str, list[Bundle]] = {}
    for b in bundles():
        groups.setdefault(b.group, []).append(b)

    def mean(group: str, attr: str) -> list[float]:
        return [round(float(v), 3) for v in np.mean([getattr(b, attr) for b in groups[group]],
                                                     axis=0)]

    def rounded(v: np.ndarray) -> list[float]:
        return [round(float(x), 3) for x in v]

    return {"condyle_center": {c: rounded(lm.condyle_center[c]) for c in COMPARTMENTS},
            "contact_point": {c: rounded(lm.contact_point[c]) for c in COMPARTMENTS},
            "femur_attachment": {g: mean(g, "femur_point") for g in ("ACL", "PCL", "MCL")},
            "tibia_attachment": {g: mean(g, "tibia_point") for g in ("ACL", "PCL", "MCL")}}
