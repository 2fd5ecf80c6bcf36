"""The output of a contact law: pressure, the wrench on the slave and its exact tangent."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from fecheck.contact.convex import PointContact
from fecheck.contact.surface import ContactSurface


@dataclass(frozen=True, eq=False)
class LawResult:
    """A law's output for one contact (forces on the slave).

    surface : the contact the law read (a `PointContact` for `hertz_point`)
    pressure : (Q,) pressure at the quadrature points, MPa (none for a point contact)
    force : (3,) N;  moment : (3,) N·mm about `about`;  tangent : (6, 6) d[F, M]/dξ
    max_pressure : MPa at the deepest point;  max_depth : mm;  area : mm² (law's own
    contact area: the clipped area for foundation laws, πa² for Hertz)
    contact_radius_mm : Hertz contact radius a (mm); NaN for laws without one
    """

    surface: ContactSurface | PointContact
    pressure: np.ndarray
    force: np.ndarray
    moment: np.ndarray
    tangent: np.ndarray
    max_pressure: float
    area: float
    max_depth: float
    contact_radius_mm: float = math.nan
    face_pressure_fn: Callable[[], np.ndarray] | None = None

    @property
    def mean_pressure(self) -> float:
        """|F| / area, MPa (0 without contact)."""
        return float(np.linalg.norm(self.force) / self.area) if self.area > 0 else 0.0

    def face_pressure(self) -> np.ndarray:
        """(n_slave_faces,) mean pressure on every slave face, MPa (0 off contact)."""
        return self.face_pressure_fn()


def no_contact(surface: ContactSurface, about: np.ndarray) -> LawResult:
    z3 = np.zeros(3)
    n = surface.n_slave_faces
    return LawResult(surface, np.zeros(0), z3, z3.copy(), np.zeros((6, 6)), 0.0, 0.0, 0.0,
                     face_pressure_fn=lambda: np.zeros(n))

