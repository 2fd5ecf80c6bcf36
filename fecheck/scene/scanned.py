"""The scanned lenhart2015 right knee: where its files are, its meshes, landmarks and ligaments.

The data set (MRI-derived, Apache-2.0, see its README.md) lives OUTSIDE the repository,
by default in ``<repo>/../shared/data/knee/lenhart2015``. The folder is found, in order,
from an explicit argument (the scene key ``scanned.data_dir``), the environment variable
``FECHECK_KNEE_DIR``, then that default. Every mesh is in mm in the thesis frame at 0°
flexion, femur and tibia frames coinciding (README "Pose and transform").

Landmarks (mm) come from the data set itself, so that geometry and ligaments agree:

* condyle centres and radii: the femoral condyle sphere fits of ``fits.json``;
* contact points: the lowest point of each sphere, centre − R·e_z;
* ligaments: the 55 tibiofemoral ``Blankevoort1991Ligament`` bundles of
  ``ligaments.json`` (femoral and tibial/fibular attachment, linear stiffness k in N per
  unit strain, slack length l0, transition strain ε_t = 0.06);
* load point: the ankle centre (-1.757, -4.2, -381) mm, on the mechanical axis (hip,
  knee and ankle centres lie on z within about 2 mm, README "Frame"), so that an 800 N
  vertical load applied there is a ground reaction along the mechanical axis;
* tibia (shank) mass 2.652 kg with its centre of mass at (-1.757, 5.850, -150.861) mm
  (README "Body mass properties", body ``tibia_r``).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from fecheck.errors import FecheckError
from fecheck.scene.constants import COMPARTMENTS

ENV_VAR = "FECHECK_KNEE_DIR"
DEFAULT_DIR = Path(__file__).resolve().parents[3] / "shared" / "data" / "knee" / "lenhart2015"

FILES = {
    "femur_cartilage": "lenhart2015_R_femur_cartilage.stl",
    "femur_bone": "lenhart2015_R_femur_bone_distal60.stl",
    "tibia_cartilage": "lenhart2015_R_tibia_cartilage.stl",
    "tibia_cartilage_medial": "lenhart2015_R_tibia_cartilage_medial.stl",
    "tibia_cartilage_lateral": "lenhart2015_R_tibia_cartilage_lateral.stl",
    "tibia_bone": "lenhart2015_R_tibia_bone_proximal40.stl",
}

ANKLE_CENTRE_MM = (-1.757, -4.2, -381.0)
"""Load point: the ankle centre on the mechanical axis (README "Frame, units, origin")."""
TIBIA_MASS_KG = 2.65207
TIBIA_COM_MM = (-1.757, 5.850, -150.861)
"""Shank mass and centre of mass of body ``tibia_r`` (README "Body mass properties")."""


def knee_dir(override: str | os.PathLike | None = None, *, must_exist: bool = True) -> Path:
    """The scanned-knee folder: `override`, else $FECHECK_KNEE_DIR, else the default.

    Raises `FecheckError` (saying where it looked and how to point elsewhere) when the
    folder or its ``fits.json`` is missing and `must_exist` is true.
    """
    if override:
        path, how = Path(override).expanduser(), "scene key scanned.data_dir"
    elif os.environ.get(ENV_VAR):
        path, how = Path(os.environ[ENV_VAR]).expanduser(), f"${ENV_VAR}"
    else:
        path, how = DEFAULT_DIR, "the default location"
    if must_exist and not (path / "fits.json").is_file():
        raise FecheckError(f"scanned knee data not found at {path} (from {how}); put the "
                           f"lenhart2015 folder there, or set {ENV_VAR} or the scene key "
                           f"scanned.data_dir to the folder holding fits.json")
    return path


def mesh_path(name: str, directory: str | os.PathLike | None = None) -> Path:
    """Path of one scanned mesh by its short name (keys of `FILES`)."""
    if name not in FILES:
        raise FecheckError(f"unknown scanned mesh {name!r}; known: {', '.join(FILES)}")
    path = knee_dir(directory) / FILES[name]
    if not path.is_file():
        raise FecheckError(f"scanned mesh {path} is missing from the knee data folder")
    return path


KNEE_EXTENT_MM = (5.0, 1000.0)
"""Plausible bounding-box diagonal of a knee surface, mm: a cartilage sheet spans some
20-100 mm, a bone surface a few hundred."""


def check_length_unit(points, path: str) -> None:
    """`FecheckError` when a mesh's extent says its coordinates are not millimetres."""
    diagonal = float(np.linalg.norm(np.ptp(points, axis=0))) if len(points) else 0.0
    low, high = KNEE_EXTENT_MM
    if diagonal < low:
        hint = (" - it looks like metres: scale it by 1000" if 0.005 <= diagonal <= 1.0
                else "")
        raise FecheckError(f"{path} spans {diagonal:.4g} units across; a knee surface in "
                           f"millimetres spans {low:g}-{high:g}{hint} (fecheck reads "
                           "millimetres)")
    if diagonal > high:
        raise FecheckError(f"{path} spans {diagonal:.4g} units across; a knee surface in "
                           f"millimetres spans {low:g}-{high:g}: check its unit (fecheck "
                           "reads millimetres)")


@lru_cache(maxsize=16)
def _load(path: str):
    from geometry.io import load_mesh

    mesh = load_mesh(path)
    check_length_unit(mesh.points, path)
    return mesh


def load_scanned_mesh(name: str, directory: str | os.PathLike | None = None):
    """A scanned mesh (`geometry.mesh.TriMesh`, mm, thesis frame), read once per process."""
    return _load(str(mesh_path(name, directory)))


@dataclass(frozen=True)
class Bundle:
    """One ligament bundle of ligaments.json (a Blankevoort 1991 spring).

    femur_point, tibia_point : (3,) attachments, mm (femur frame / tibia frame, which
        coincide at the rest pose); the distal point may be on the fibula, which moves
        with the tibia
    stiffness_N : linear-region stiffness k, N per unit strain
    slack_length_mm : l0, mm;  transition_strain : ε_t (end of the toe region)
    """

    name: str
    group: str
    femur_point: np.ndarray
    tibia_point: np.ndarray
    stiffness_N: float
    slack_length_mm: float
    transition_strain: float

    @property
    def rest_length_mm(self) -> float:
        """Straight-line length at the rest pose, mm."""
        return float(np.linalg.norm(self.femur_point - self.tibia_point))


@dataclass(frozen=True)
class ScannedLandmarks:
    """Landmarks of the scanned knee, mm (module docstring for their origin)."""

    condyle_center: dict[str, np.ndarray]
    condyle_radius_mm: dict[str, float]
    contact_point: dict[str, np.ndarray]
    load_point: np.ndarray
    tibia_mass_kg: float
    tibia_com: np.ndarray


def read_fits(directory: str | os.PathLike | None = None) -> dict:
    """The ``fits.json`` of the data set (reference fits and rest-pose checks)."""
    return json.loads((knee_dir(directory) / "fits.json").read_text())


def landmarks(directory: str | os.PathLike | None = None) -> ScannedLandmarks:
    """Condyle spheres, contact points, load point and shank mass of the scanned knee."""
    fits = read_fits(directory)["fits"]
    centre, radius, contact = {}, {}, {}
    for c in COMPARTMENTS:
        f = fits[f"femoral_condyle_{c}_sphere"]
        centre[c] = np.asarray(f["centre_mm"], dtype=float)
        radius[c] = float(f["radius_mm"])
        contact[c] = centre[c] - np.array([0.0, 0.0, radius[c]])
    return ScannedLandmarks(centre, radius, contact, np.array(ANKLE_CENTRE_MM),
                            TIBIA_MASS_KG, np.array(TIBIA_COM_MM))


def bundles(directory: str | os.PathLike | None = None) -> tuple[Bundle, ...]:
    """The 55 tibiofemoral ligament bundles of ``ligaments.json`` (straight paths)."""
    path = knee_dir(directory) / "ligaments.json"
    if not path.is_file():
        raise FecheckError(f"{path} is missing: the scanned knee's ligament bundles are "
                           f"read from it")
    out = []
    for item in json.loads(path.read_text()):
        p = item["parameters"]
        femur, tibia = (np.asarray(x, dtype=float) for x in item["points_mm"])
        if item["points_bone"][0] != "femur":
            femur, tibia = tibia, femur
        out.append(Bundle(item["name"], item["group"], femur, tibia,
                          float(p["linear_stiffness"]["value"]),
                          1000.0 * float(p["slack_length"]["value"]),
                          float(p["transition_strain"]["value"])))
    return tuple(out)


def knee_landmarks_table(directory: str | os.PathLike | None = None) -> dict:
    """The scene's ``[knee.landmarks]`` table for the scanned knee (mm, rounded to 1 µm).

    Condyle centres and contact points from `landmarks`; the ACL, PCL and MCL attachments
    are the means of their bundles' attachments (for the three-ligament models).
    """
    lm = landmarks(directory)
    groups = {}
    for b in bundles(directory):
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
