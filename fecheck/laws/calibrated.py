"""An elastic foundation calibrated by finite elements (``contact.law = "ef-calibrated"``).

The linear EF, p = k·d, is the thin-layer limit of a bonded cartilage layer: where the
contact is as wide as the layer is thick it spreads the load over too large an area
(measured +25-32 % at h 6 mm, ν 0.3), and as ν → 0.5 its column stiffness diverges
while a bonded layer bulges. The calibrated law keeps the EF's locality and speed — the
pressure at a point is a function of its own depth — with a shape fitted to FE:

    p(d) = C · d · (d + d_s)^(n − 1),    d ≥ 0,

C (MPa/mm^n) and n per compartment, d_s = `SOFT_DEPTH_MM` (it keeps the tangent finite
at the contact edge for n < 1; for d ≫ d_s, p ≈ C·d^n). n = 1 is the linear EF with
k = C; n → 1/2 the Hertz limit of a contact much narrower than the layer, where
p_max / p_mean → 3/2.

Why this form: for a sphere of radius R on any local law, the contact area is the
overlap area 2πRδ and dF/dA = p(δ); a power law F = c·A^m of the FE force against area
is reproduced exactly by p(d) = c·m·(2πR·d)^(m−1), i.e. n = m − 1, C = c·m·(2πR)^(m−1).
The built-in table (`ef_calibration_table.json`, from the axisymmetric FE over ν 0.3-0.49,
h 1.5-12 mm, R 15-60 mm and F/E 2-100 mm²: validation/ef_calibration_table.py) gives m
and c for condyle spheres on a uniform layer; it reproduces the FE's area (within ~4-6 %
over the grid), but a local law that matches the area over-predicts p_max by the gap
between the force-area slope and the FE's p_max/p_mean (median +9.5 %, up to +26 % where
the contact is about as wide as the layer, at ν 0.49). `fecheck calibrate` fits C and n
per compartment to the FE of the scene itself (`fecheck.studies.calibrate`), balancing
area, p_max and load share (±5 % on the baseline). Units: mm, N, MPa.
"""

from __future__ import annotations

import json
import math
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from pathlib import Path

import numpy as np

from fecheck.errors import FecheckError
from fecheck.laws.kernel import CALIBRATED, law_function
from geometry.files import write_output

SOFT_DEPTH_MM = 0.01
"""d_s of the law: below this depth the law turns linear (finite tangent at d = 0)."""
EXPONENT_RANGE = (0.3, 1.5)
"""Allowed n: 1/2 is the Hertz limit, 1 the linear EF."""
FILE_VERSION = 1
"""Version of the calibration file layout (`write_calibration`)."""
CARTILAGE_INTERFACES, MENISCI_INTERFACES = "cartilage", "menisci"
"""What a calibration file's C and n are for (its ``interfaces`` field): the cartilage
contact of each compartment (contact.calibration; a file without the field is one), or
each meniscus's two interfaces (menisci.calibration)."""
TABLE_FILE = "ef_calibration_table.json"
"""The built-in table, beside this module (validation/ef_calibration_table.py --write)."""
_CHECKED: set[tuple[str, str | None, str]] = set()
"""(file, its fingerprint, the scene's) already warned about in this process."""


@dataclass(frozen=True)
class Calibration:
    """Law parameters of one compartment: p(d) = C·d·(d + d_s)^(n − 1)."""

    C: float
    n: float

    def check(self, where: str) -> None:
        """`FecheckError` for a non-finite or out-of-range parameter."""
        lo, hi = EXPONENT_RANGE
        if not (math.isfinite(self.C) and self.C > 0 and math.isfinite(self.n)
                and lo <= self.n <= hi):
            raise FecheckError(f"{where}: calibrated EF needs C > 0 and {lo} <= n <= {hi}, "
                               f"got C = {self.C!r}, n = {self.n!r}")


def calibrated_pressure(cal: Calibration) -> Callable[[np.ndarray], tuple[np.ndarray,
                                                                           np.ndarray]]:
    """p(d) and dp/dd of the law (MPa, MPa/mm) for depths d ≥ 0 (mm)."""
    return law_function(CALIBRATED, calibrated_params(cal))


def calibrated_params(cal: Calibration) -> np.ndarray:
    """(C, n, d_s) of the law (`fecheck.laws.kernel.law_values`)."""
    return np.array([float(cal.C), float(cal.n), SOFT_DEPTH_MM])


@lru_cache(maxsize=1)
def _table() -> dict:
    try:
        text = resources.files("fecheck.laws").joinpath(TABLE_FILE).read_text()
    except OSError as err:
        raise FecheckError(f"the built-in calibration table {TABLE_FILE} is missing from the "
                           f"installation ({err}); reinstall fecheck, or calibrate the scene "
                           "with `fecheck calibrate`") from None
    return json.loads(text)


def table_calibration(youngs_MPa: float, poisson: float, thickness_mm: float,
                      radius_mm: float) -> Calibration:
    """C and n for a sphere of `radius_mm` on a bonded layer, from the built-in table
    (interpolated linearly in ν, log h, log R; m and log c, then C, n)."""
    table = _table()
    axes = table["axes"]
    point, names = [], ("poisson", "thickness_mm", "radius_mm")
    for name, value in zip(names, (poisson, thickness_mm, radius_mm), strict=True):
        grid = np.asarray(axes[name], dtype=float)
        if not grid[0] <= value <= grid[-1]:
            raise FecheckError(f"contact.law = 'ef-calibrated': {name} = {value:g} lies outside "
                               f"the built-in table ({grid[0]:g}-{grid[-1]:g}); calibrate "
                               "the scene with `fecheck calibrate` and set "
                               "contact.calibration")
        scaled = grid if name == "poisson" else np.log(grid)
        x = value if name == "poisson" else math.log(value)
        i = int(np.clip(np.searchsorted(scaled, x) - 1, 0, len(grid) - 2))
        point.append((i, (x - scaled[i]) / (scaled[i + 1] - scaled[i])))
    m = _trilinear(np.asarray(table["m"], dtype=float), point)
    log_c = _trilinear(np.asarray(table["log_c"], dtype=float), point)
    c = youngs_MPa / table["E_reference_MPa"] * math.exp(log_c)
    return Calibration(C=c * m * (2.0 * math.pi * radius_mm) ** (m - 1.0), n=m - 1.0)


def _trilinear(values: np.ndarray, point: list[tuple[int, float]]) -> float:
    out = 0.0
    for corner in range(8):
        weight, index = 1.0, []
        for axis, (i, t) in enumerate(point):
            upper = (corner >> axis) & 1
            weight *= t if upper else 1.0 - t
            index.append(i + upper)
        out += weight * values[tuple(index)]
    return float(out)


def read_calibration(path: str | Path, interfaces: str = CARTILAGE_INTERFACES,
                     key: str = "contact.calibration") -> dict[str, Calibration]:
    """{compartment: Calibration} of a file `fecheck calibrate` wrote for `interfaces`
    (`CARTILAGE_INTERFACES` or `MENISCI_INTERFACES`); `key` names the scene key in
    messages."""
    path = Path(path)
    if path.is_dir():
        raise FecheckError(f"{key}: {path} is a directory: give the calibration "
                           "file `fecheck calibrate SCENE -o FILE` wrote")
    try:
        data = json.loads(path.read_text())
        out = {c: Calibration(float(v["C"]), float(v["n"]))
               for c, v in data["compartments"].items()}
        made_for = data.get("interfaces", CARTILAGE_INTERFACES)
    except FileNotFoundError:
        raise FecheckError(f"{key}: {path} not found; write it with "
                           "`fecheck calibrate SCENE -o FILE`") from None
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as err:
        raise FecheckError(f"{key}: {path} is not a calibration file written "
                           f"by `fecheck calibrate` ({type(err).__name__}: {err})") from None
    if made_for != interfaces:
        other = "menisci.calibration" if made_for == MENISCI_INTERFACES else \
            "contact.calibration"
        raise FecheckError(f"{key}: {path} calibrates the {made_for} interfaces, not the "
                           f"{interfaces} ones; give it to {other}")
    for c, cal in out.items():
        cal.check(f"{path} ({c})")
    return out


def check_fingerprint(path: str | Path, fingerprint: str,
                      key: str = "contact.calibration") -> None:
    """Warn (once per file and scene in a process) when the calibration file `path` was
    fitted to other surfaces or material than those of `fingerprint`
    (`fecheck.model.fingerprint.scene_fingerprint`), or holds no fingerprint to check;
    `key` names the scene key in messages."""
    path = Path(path)
    try:
        stored = json.loads(path.read_text()).get("fingerprint")
    except (OSError, ValueError, AttributeError):
        stored = None
    check = (str(path.resolve()), stored, fingerprint)
    if check in _CHECKED or stored == fingerprint:
        return
    _CHECKED.add(check)
    if stored is None:
        warnings.warn(f"{key}: {path} holds no fingerprint of the scene it was "
                      "fitted to (written by an older fecheck): whether it fits this scene's "
                      "surfaces and material cannot be checked; rerun `fecheck calibrate "
                      f"SCENE -o {path.name}` to refit and stamp it", stacklevel=2)
    else:
        warnings.warn(f"{key}: {path} was fitted to other surfaces or another "
                      "material (its fingerprint differs from this scene's: geometry files, "
                      "split, decimation, contact.youngs_MPa, contact.poisson, thickness"
                      f"{', menisci.*' if key.startswith('menisci') else ''}): "
                      "its C and n do not carry over; run `fecheck calibrate SCENE -o FILE` "
                      "for this scene", stacklevel=2)


def write_calibration(path: str | Path, parameters: Mapping[str, Calibration],
                      info: Mapping) -> Path:
    """Write `parameters` (and what they were fitted to, `info`) as JSON."""
    path = Path(path)
    doc = {"law": "p = C d (d + d_s)^(n - 1)", "version": FILE_VERSION,
           "soft_depth_mm": SOFT_DEPTH_MM,
           "compartments": {c: {"C": p.C, "n": p.n} for c, p in parameters.items()},
           **info}
    text = json.dumps(doc, indent=2) + "\n"
    return write_output(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))
