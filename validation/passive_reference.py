"""The source model's passive flexion of the lenhart2015 knee as reference curves, and the band
fecheck's passive flexion is held to.

Two published OpenSim-JAM runs (the data set ``lenhart2015_passive_flexion``, beside the
repository: ``$FECHECK_SHARED_DATA/knee/lenhart2015_passive_flexion``, else
``../shared/data/knee/...``): each settles at 0° for 0.5 s, then flexes the knee to 90°.
Their ``knee_add_r`` (+ adduction: the distal tibia medially) and ``knee_rot_r`` (+ internal)
are the Cardan angles of the sequence flexion (about the femur's medio-lateral axis, x here),
adduction, rotation, about the joint origin: fecheck's adduction_deg and internal_rotation_deg
when `fecheck flex` turns the tibia about the same axis (`SOURCE_AXIS`), in a right knee.
Curves are compared as changes from the settled 0° value (how flexion curves compare across
models); the band at an angle is the two runs' span widened by `MARGIN_DEG` either side.
"""

from __future__ import annotations

import csv
import os
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
FOLDER = Path(os.environ.get("FECHECK_SHARED_DATA", REPO.parent / "shared" / "data")) \
    / "knee" / "lenhart2015_passive_flexion"
RUNS = {"jam-resources": "passive_flexion_jam_resources.csv",
        "opensim-jam": "passive_flexion_opensim_jam.csv"}
SETTLE_S = 0.5
"""Each run holds 0° for this long before it flexes, s."""
SOURCE_AXIS = ((-1.757, -0.150, 22.272), (1.0, 0.0, 0.0))
"""The source model's knee_flex_r axis in this frame: femoral x through the joint origin
(point mm, direction; the lenhart2015 README, "Pose and transform")."""
COORDINATES = {"adduction_deg": "knee_add_r_deg", "internal_rotation_deg": "knee_rot_r_deg"}
"""fecheck's flex column → the source model's coordinate."""
MARGIN_DEG = 2.0
TABLE_DEG = (10, 20, 30, 45, 60, 75, 90)
PATELLA = {"pf_flex_deg": ("pf_flex_r_deg", 5.0), "pf_rot_deg": ("pf_rot_r_deg", 5.0),
           "pf_tilt_deg": ("pf_tilt_r_deg", 5.0), "pf_tx_mm": ("pf_tx_r_mm", 3.0),
           "pf_ty_mm": ("pf_ty_r_mm", 3.0), "pf_tz_mm": ("pf_tz_r_mm", 3.0)}
"""fecheck's patella column → (the source model's pf_r coordinate, margin of its band: ±5°
for the rotations, ±3 mm for the translations). The patella's coordinates are compared as
values, not changes: fecheck reads them in the source model's own frames
(`fecheck.model.patella.pf_coordinates`). pf_rot is plotted and listed but is not one of
the acceptance's coordinates (patellar flexion, tilt and the translations)."""


def available() -> bool:
    """Whether the two runs' files are there."""
    return all((FOLDER / name).is_file() for name in RUNS.values())


def read_run(name: str) -> dict[str, np.ndarray]:
    """{column: values} of one run's rows after settling (time ≥ `SETTLE_S`), in flexion
    order, and 'settled': {column: its value at the end of settling}."""
    with (FOLDER / RUNS[name]).open(encoding="utf-8") as fh:
        rows = [{k: float(v) for k, v in r.items()} for r in csv.DictReader(fh)]
    settled = [r for r in rows if r["time_s"] <= SETTLE_S + 1e-9][-1]
    after = [r for r in rows if r["time_s"] >= SETTLE_S - 1e-9]
    out = {k: np.array([r[k] for r in after]) for k in rows[0]}
    out["settled"] = settled
    return out


def change_at(run: dict, column: str, angles) -> np.ndarray:
    """The run's `column` at knee flexion `angles` (deg), less its settled 0° value."""
    return (np.interp(angles, run["knee_flex_r_deg"], run[column])
            - run["settled"][column])


def band(column: str, angles) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) of the two runs' changes of `column` at `angles`, widened by
    `MARGIN_DEG`."""
    values = np.array([change_at(read_run(name), column, angles) for name in RUNS])
    return values.min(axis=0) - MARGIN_DEG, values.max(axis=0) + MARGIN_DEG


def value_at(run: dict, column: str, angles) -> np.ndarray:
    """The run's `column` at knee flexion `angles` (deg), after settling."""
    return np.interp(angles, run["knee_flex_r_deg"], run[column])


def value_band(column: str, angles, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) of the two runs' values of `column` at `angles`, widened by `margin`."""
    values = np.array([value_at(read_run(name), column, angles) for name in RUNS])
    return values.min(axis=0) - margin, values.max(axis=0) + margin
