"""Knee landmarks: the thesis's baseline right knee and additional left knee (App. B).

Coordinates in mm, thesis frame (origin at the tibial plateau centre, x to the
subject's right, y anterior, z superior), femur points in the femur (world) frame and
tibia points in the tibia frame, which coincide at the reference pose. In a right knee
the medial compartment is at negative x, in a left knee at positive x.

Condyle radius = distance from the femoral condyle centre to the tibial contact point
(Tables B.2, B.4); ligament rest length = distance between its two attachments at the
reference pose.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from fecheck.errors import FecheckError
from fecheck.scene.constants import COMPARTMENTS, LIGAMENTS


@dataclass(frozen=True)
class Knee:
    """Landmarks of one knee, mm.

    side : "right" or "left"
    condyle_center : {"medial"|"lateral": (3,)} femoral condyle sphere centres
    contact_point : {"medial"|"lateral": (3,)} tibial contact points (plateau points)
    femur_attachment, tibia_attachment : {"ACL"|"PCL"|"MCL": (3,)} ligament insertions
    """

    side: str
    condyle_center: Mapping[str, np.ndarray]
    contact_point: Mapping[str, np.ndarray]
    femur_attachment: Mapping[str, np.ndarray]
    tibia_attachment: Mapping[str, np.ndarray]

    def radius_mm(self, compartment: str) -> float:
        """Condyle radius = centre-to-contact-point distance, mm."""
        return float(np.linalg.norm(self.condyle_center[compartment]
                                    - self.contact_point[compartment]))

    def ligament_length_mm(self, ligament: str) -> float:
        """Ligament length at the reference pose, mm."""
        return float(np.linalg.norm(self.femur_attachment[ligament]
                                    - self.tibia_attachment[ligament]))


def _arrays(table: Mapping[str, tuple[float, float, float]]) -> dict[str, np.ndarray]:
    return {k: np.array(v, dtype=float) for k, v in table.items()}


# Thesis Table B.1 (baseline right knee, from its reference [14]).
BASELINE_RIGHT = Knee(
    side="right",
    condyle_center=_arrays({"medial": (-20.4, 12.8, 16.8), "lateral": (28.3, 12.8, 25.8)}),
    contact_point=_arrays({"medial": (-20.4, 12.8, -8.7), "lateral": (28.3, 12.8, -6.0)}),
    femur_attachment=_arrays({"ACL": (17.0, 31.4, 20.4), "PCL": (-7.9, 21.3, 8.8),
                              "MCL": (-38.0, 13.8, 11.2)}),
    tibia_attachment=_arrays({"ACL": (0.0, 0.0, 0.0), "PCL": (18.3, 35.5, -21.3),
                              "MCL": (-3.0, -1.0, -64.6)}),
)

# Thesis Table B.3 (additional left knee: medial compartment at +x).
ADDITIONAL_LEFT = Knee(
    side="left",
    condyle_center=_arrays({"medial": (24.3, 0.1, 24.8), "lateral": (-27.5, 0.1, 25.6)}),
    contact_point=_arrays({"medial": (24.3, 0.1, -2.1), "lateral": (-27.5, 0.1, 0.1)}),
    femur_attachment=_arrays({"ACL": (-5.7, 3.6, 29.7), "PCL": (10.2, 5.4, 20.2),
                              "MCL": (43.5, -2.4, 27.7)}),
    tibia_attachment=_arrays({"ACL": (0.0, 0.0, 0.0), "PCL": (-6.9, 26.1, -14.3),
                              "MCL": (14.0, -6.0, -58.8)}),
)

PRESETS: dict[str, Knee] = {"baseline-right": BASELINE_RIGHT, "additional-left": ADDITIONAL_LEFT}


def knee_from_landmarks(side: str, landmarks: Mapping[str, Mapping[str, object]]) -> Knee:
    """A knee from explicit landmarks (mm).

    `landmarks` has the tables ``condyle_center``, ``contact_point``,
    ``femur_attachment`` and ``tibia_attachment``; the first two keyed by
    ``medial``/``lateral``, the last two by ``ACL``/``PCL``/``MCL``, each value 3
    finite coordinates in mm.
    """
    if side not in ("right", "left"):
        raise FecheckError(f"knee.side must be 'right' or 'left', got {side!r}")
    tables = {}
    for name, keys in (("condyle_center", COMPARTMENTS), ("contact_point", COMPARTMENTS),
                       ("femur_attachment", LIGAMENTS), ("tibia_attachment", LIGAMENTS)):
        table = landmarks.get(name)
        if not isinstance(table, Mapping) or set(table) != set(keys):
            raise FecheckError(f"knee.landmarks.{name} must give exactly {', '.join(keys)} "
                               f"(3 coordinates in mm each)")
        out = {}
        for key in keys:
            v = np.asarray(table[key], dtype=float)
            if v.shape != (3,) or not np.all(np.isfinite(v)):
                raise FecheckError(f"knee.landmarks.{name}.{key} must be 3 finite numbers "
                                   f"(mm), got {table[key]!r}")
            out[key] = v
        tables[name] = out
    knee = Knee(side=side, **tables)
    for c in COMPARTMENTS:
        if knee.radius_mm(c) <= 0.0:
            raise FecheckError(f"knee.landmarks: the {c} condyle centre coincides with its "
                               f"contact point (zero radius)")
    check_side(side, knee.condyle_center["medial"][0], knee.condyle_center["lateral"][0],
               "knee.landmarks has the medial condyle centre", "swap the medial and "
               "lateral landmarks")
    return knee


def check_side(side: str, medial_x: float, lateral_x: float, what: str, other_fix: str
               ) -> None:
    """`FecheckError` when the medial compartment at x = `medial_x` and the lateral at
    `lateral_x` (mm) are on the sides opposite to a `side` knee's (right: medial at -x);
    `what` names the medial's source ("... at x = ..."), `other_fix` the other cure."""
    if medial_x == lateral_x or (medial_x < lateral_x) == (side == "right"):
        return
    medial_at, actual = ("-x", "left") if side == "right" else ("+x", "right")
    raise FecheckError(f"knee.side = {side!r} puts the medial compartment at {medial_at}, but "
                       f"{what} at x = {medial_x:+.1f} mm and the lateral at "
                       f"{lateral_x:+.1f} mm, as in a {actual} knee: set knee.side = "
                       f"{actual!r} (or {other_fix})")


def plane_normal(angles_deg: tuple[float, float] | list[float]) -> np.ndarray:
    """Unit upward normal of a plateau plane with angles (λ, γ) in degrees, tibia frame.

    The plane is z = x·tan γ + y·tan λ + c (thesis App. C: λ in the sagittal plane, γ in
    the frontal plane, from the least-squares plane z = a x + b y + c), so its normal is
    (−tan γ, −tan λ, 1)/‖·‖. With Table 2.1 (medial γ < 0, lateral γ > 0) both plateaus
    rise toward their outer edge. (0, 0) is transverse.
    """
    lam, gam = np.radians(np.asarray(angles_deg, dtype=float))
    n = np.array([-np.tan(gam), -np.tan(lam), 1.0])
    return n / np.linalg.norm(n)
