"""Ligaments between a femur point P (fixed, mm) and a tibia point Q (tibia frame, mm).

* Rods of constant length (thesis eq. 1.7, Lagrange multipliers): the constraint
  g = |P − x_Q| − L = 0; its multiplier is the rod tension (N, + pulls the tibia toward
  the femur; negative = compression).
* Springs (Blankevoort et al. 1991, J. Biomech. 24(11):1019-1031; thesis eq. 2.7 in its
  continuous form: the thesis prints the transition at ε_l, where the force jumps):
  strain ε = (l − l0)/l0 with slack length l0 = L_ref/(1 + ε_ref), ε_l =
  transition_strain/2 and stiffness k (N per unit strain): f = 0 for ε < 0,
  k·ε²/(4ε_l) for 0 ≤ ε ≤ 2ε_l, k·(ε − ε_l) beyond.
  Default k and ε_ref come from Lenhart et al. 2015 (J. Biomech. Eng. 137(8):081006) as
  shipped in ``shared/data/knee/lenhart2015/ligaments.json`` (see `fecheck.scene.schema`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fecheck.errors import FecheckError
from fecheck.statics.newton import point_force


def _direction(femur_point: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, float]:
    d = femur_point - x
    length = float(np.linalg.norm(d))
    if length < 1e-9:
        raise FecheckError("a ligament's attachments coincide (zero length); check the "
                           "knee landmarks")
    return d / length, length


def rod_constraint(femur_point: np.ndarray, tibia_point: np.ndarray, length_mm: float):
    """Constraint g = |P − x_Q| − L (mm) for `fecheck.statics.newton.Problem.constraints`.

    Returns a function (R, t, parts) → (g, w, dw/dξ) with w = −∂g/∂ξ the wrench of a unit
    tension on the tibia (the wrench `parts` of the evaluation are not needed).
    """
    p = np.asarray(femur_point, dtype=float)
    q = np.asarray(tibia_point, dtype=float)

    def constraint(rot: np.ndarray, t: np.ndarray, parts=()):
        x = rot @ q + t
        u, length = _direction(p, x)
        w, dw = point_force(x, u, -(np.eye(3) - np.outer(u, u)) / length)
        return length - length_mm, w, dw

    return constraint


def blankevoort_tension(strain: np.ndarray | float, stiffness_N: float,
                        transition_strain: float) -> tuple[np.ndarray, np.ndarray]:
    """Spring force f(ε) (N) and df/dε (N) of Blankevoort 1991 (continuous form)."""
    e = np.asarray(strain, dtype=float)
    el = 0.5 * transition_strain
    toe = stiffness_N * e * e / (4 * el)
    lin = stiffness_N * (e - el)
    f = np.where(e < 0, 0.0, np.where(e <= 2 * el, toe, lin))
    df = np.where(e < 0, 0.0, np.where(e <= 2 * el, stiffness_N * e / (2 * el), stiffness_N))
    return f, df


def transition_strain_check(transition_strain: float) -> None:
    """Reject a non-positive transition strain (FecheckError)."""
    if not transition_strain > 0:
        raise FecheckError(f"ligaments.transition_strain must be > 0, got {transition_strain}")


@dataclass(frozen=True)
class SpringLigament:
    """A Blankevoort 1991 spring; call it with (R, t) for its wrench on the tibia."""

    femur_point: np.ndarray
    tibia_point: np.ndarray
    slack_length_mm: float
    stiffness_N: float
    transition_strain: float

    def tension(self, length_mm: float) -> float:
        """Spring force at a length, N (+ tension)."""
        f, _ = blankevoort_tension((length_mm - self.slack_length_mm) / self.slack_length_mm,
                                   self.stiffness_N, self.transition_strain)
        return float(f)

    def __call__(self, rot: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x = rot @ self.tibia_point + t
        u, length = _direction(self.femur_point, x)
        l0 = self.slack_length_mm
        f, df = blankevoort_tension((length - l0) / l0, self.stiffness_N,
                                    self.transition_strain)
        f, dfdl = float(f), float(df) / l0
        jac = -dfdl * np.outer(u, u) - (f / length) * (np.eye(3) - np.outer(u, u))
        return point_force(x, f * u, jac)


def spring_wrench(femur_point: np.ndarray, tibia_point: np.ndarray, reference_length_mm: float,
                  stiffness_N: float, reference_strain: float, transition_strain: float
                  ) -> SpringLigament:
    """A spring whose strain at `reference_length_mm` is `reference_strain`."""
    if reference_strain <= -1:
        raise FecheckError("ligament reference strain must be > -1")
    return SpringLigament(np.asarray(femur_point, float), np.asarray(tibia_point, float),
                          reference_length_mm / (1 + reference_strain), float(stiffness_N),
                          float(transition_strain))
