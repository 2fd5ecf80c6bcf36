"""A meniscal horn root as a linear spring along the root's direction (EF statics).

The root ties a point of the meniscus to the same point of the tibia (both at the start
pose, so the spring is unstretched there). With d the meniscal point's displacement from
the tibial one (world, mm) and e the root's unit direction (carried by the tibia), the
force on the meniscus is

    f = −k (e·d) e − k_t (d − (e·d) e),

k the root's stiffness (N/mm) and k_t = `TRANSVERSE_FRACTION` k across it: a root holds a
horn along its fibres; the small transverse part only keeps the meniscus from pivoting
freely about a root (frictionless contact leaves that mode to the wedge alone). Its
tension is k (e·d) (N, + pulling the horn toward the tibia).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from fecheck.statics.newton import two_point_force

TRANSVERSE_FRACTION = 0.01
"""Stiffness across a root over its stiffness along it (numerical: no source gives one)."""


def root_matrix(direction: np.ndarray, stiffness: float,
                fraction: float = TRANSVERSE_FRACTION) -> np.ndarray:
    """(3, 3) stiffness (N/mm) of a root along unit `direction`: k e eᵀ + k_t (I − e eᵀ)."""
    e = np.asarray(direction, dtype=float)
    e = e / np.linalg.norm(e)
    along = np.outer(e, e)
    return stiffness * (along + fraction * (np.eye(3) - along))


@dataclass(frozen=True)
class RootSpring:
    """A horn root (module docstring): the tibia's body index and point, the meniscus's
    body index and point (each in its body's frame, mm, the same place at the start), the
    root's unit direction in the tibia frame and its stiffness along it (N/mm)."""

    tibia: int
    tibia_point: np.ndarray
    meniscus: int
    meniscus_point: np.ndarray
    direction: np.ndarray
    stiffness_N_per_mm: float

    def _force(self, poses):
        (rt, tt), (rm, tm) = poses[self.tibia], poses[self.meniscus]
        x_t, x_m = rt @ self.tibia_point + tt, rm @ self.meniscus_point + tm
        k = rt @ root_matrix(self.direction, self.stiffness_N_per_mm) @ rt.T
        return x_t, x_m, -k @ (x_m - x_t), -k

    def tension(self, poses: Sequence) -> float:
        """Force along the root, N (+ pulling the horn toward the tibia)."""
        x_t, x_m, _, _ = self._force(poses)
        e = poses[self.tibia][0] @ (self.direction / np.linalg.norm(self.direction))
        return float(self.stiffness_N_per_mm * e @ (x_m - x_t))

    def force(self, poses: Sequence) -> np.ndarray:
        """(3,) force on the meniscus (N, world)."""
        return self._force(poses)[2]

    def __call__(self, poses: Sequence):
        x_t, x_m, f, df = self._force(poses)
        w, dw = two_point_force(x_t, x_m, f, df)
        return (self.tibia, self.meniscus), w, dw
