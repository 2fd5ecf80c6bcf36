"""Ligament bundles read from a file: Blankevoort 1991 springs with their attachments.

The file (scene key ``geometry.ligaments``) is a JSON list in the layout of OpenSim's
``Blankevoort1991Ligament`` as the lenhart2015 data set exports it: per bundle its name,
group, the two attachment points (mm, femur frame / tibia frame, which coincide at the
reference pose), the bone of each, the linear-region stiffness (N per unit strain), the
slack length (m) and the transition strain; optionally the wrap object of its path
(``wrap.geometry``: OpenSim's `WrapCylinder` or `WrapEllipsoid`, centre, local axes and
radii in the same frame, and the body it is fixed to).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fecheck.errors import FecheckError


@dataclass(frozen=True)
class Bundle:
    """One ligament bundle (a Blankevoort 1991 spring).

    femur_point, tibia_point : (3,) attachments, mm (femur frame / tibia frame, which
        coincide at the rest pose); the distal point may be on the fibula, which moves
        with the tibia
    stiffness_N : linear-region stiffness k, N per unit strain
    slack_length_mm : l0, mm;  transition_strain : ε_t (end of the toe region)
    wrap : the wrap object's geometry, as the data gives it (None: none)
    """

    name: str
    group: str
    femur_point: np.ndarray
    tibia_point: np.ndarray
    stiffness_N: float
    slack_length_mm: float
    transition_strain: float
    wrap: dict | None = None
    """The data's ``wrap.geometry`` of the object its path wraps over (None: a straight
    path); `fecheck.statics.wrapping.WrapObject.of` reads it."""

    @property
    def rest_length_mm(self) -> float:
        """Straight-line length at the rest pose, mm."""
        return float(np.linalg.norm(self.femur_point - self.tibia_point))


def read_bundles(path: str | os.PathLike) -> tuple[Bundle, ...]:
    """The ligament bundles of a JSON file (straight paths; layout in the scene key
    ``geometry.ligaments``); `FecheckError` naming the file and what is wrong."""
    path = Path(path)
    try:
        items = json.loads(path.read_text())
    except (OSError, ValueError) as err:
        raise FecheckError(f"{path}: cannot read the ligament bundles ({err})") from None
    out = []
    try:
        for item in items:
            p = item["parameters"]
            femur, tibia = (np.asarray(x, dtype=float) for x in item["points_mm"])
            if item["points_bone"][0] != "femur":
                femur, tibia = tibia, femur
            out.append(Bundle(item["name"], item["group"], femur, tibia,
                              float(p["linear_stiffness"]["value"]),
                              1000.0 * float(p["slack_length"]["value"]),
                              float(p["transition_strain"]["value"]),
                              (item.get("wrap") or {}).get("geometry")))
    except (KeyError, TypeError, ValueError, IndexError) as err:
        raise FecheckError(f"{path}: not a ligament bundle list ({type(err).__name__}: "
                           f"{err}); see the scene key geometry.ligaments for the layout") from None
    if not out:
        raise FecheckError(f"{path}: the ligament bundle list is empty")
    return tuple(out)
