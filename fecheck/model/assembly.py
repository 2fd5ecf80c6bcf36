"""Assembly: the scene's loads and contacts as wrenches on the tibia, with their tangents.

The femur is fixed; the tibia's pose is (R, t) with q = (x, y, z mm, θy, θz rad). Each
part of the tibia's wrench — one per compartment's contact, the external load with
gravity, each ligament spring — is a function of the pose returning (W (6,), dW/dξ
(6, 6)) in N and N·mm about the world origin; `fecheck.statics.newton` sums them.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fecheck import laws
from fecheck.contact.convex import SpherePlanePair
from fecheck.contact.pair import ContactPair
from fecheck.errors import FecheckError
from fecheck.laws import calibrated
from fecheck.laws.fused import HotPath
from fecheck.laws.registry import LawInputs, spec_of
from fecheck.model.fingerprint import scene_fingerprint
from fecheck.model.results import Pose
from fecheck.scene import Scene
from fecheck.scene.constants import COMPARTMENTS, DOF_NAMES, GRAVITY_MPS2, LIGAMENTS
from fecheck.scene.knee import plane_normal
from fecheck.statics.newton import carried, cross3, master_tangent, point_force

Part = tuple[np.ndarray, np.ndarray]
"""(W (6,), dW/dξ (6, 6)): one part of the tibia's wrench and its tangent."""


def start_pose(scene: Scene) -> np.ndarray:
    """q = (x, y, z, θy, θz) (mm, rad) from the dofs.* values, z lowered by the start gap."""
    return np.array([scene["dofs.x_mm"], scene["dofs.y_mm"],
                     scene["dofs.z_mm"] - scene["solver.start_gap_mm"],
                     math.radians(scene["dofs.abduction_deg"]),
                     math.radians(scene["dofs.internal_deg"])])


def pose_dict(q: np.ndarray, side: str = "right") -> dict[str, float]:
    """Pose for reports (`fecheck.model.results.POSE_KEYS`) of a `side` knee."""
    return dict(Pose.of(q, side=side))


def free_indices(scene: Scene) -> tuple[int, ...]:
    return tuple(DOF_NAMES.index(d) for d in scene.free_dofs)


def plateau_normals(scene: Scene) -> dict[str, np.ndarray]:
    """{compartment: unit plateau normal, tibia frame} for plane plateaus."""
    if scene["plateau.kind"] == "transverse":
        return {c: np.array([0.0, 0.0, 1.0]) for c in COMPARTMENTS}
    if scene["plateau.kind"] == "inclined":
        return {c: plane_normal(scene[f"plateau.{c}_angles_deg"]) for c in COMPARTMENTS}
    raise FecheckError("this model needs plane plateaus: set plateau.kind to 'transverse' or "
                       "'inclined'")


def applied_load(scene: Scene) -> Callable[[np.ndarray, np.ndarray],
                                            tuple[np.ndarray, np.ndarray]]:
    """Wrench (and tangent) of the external load and the tibia's weight at pose (R, t)."""
    direction = np.asarray(scene["load.direction"], dtype=float)
    norm = np.linalg.norm(direction)
    force = scene["load.force_N"] * (direction / norm if norm > 0 else direction)
    point = np.asarray(scene["load.point_mm"], dtype=float)
    weight = np.array([0.0, 0.0, -scene["tibia.mass_kg"] * GRAVITY_MPS2 * scene["gravity"]])
    com = np.asarray(scene["tibia.com_mm"], dtype=float)
    follows = scene["load.frame"] == "tibia"
    w_fixed = np.concatenate([force, np.cross(point, force)])

    def wrench(rot: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        w2, d2 = point_force(rot @ com + t, weight)
        if follows:                                 # point and direction turn with the tibia
            f = rot @ force
            w1 = np.concatenate([f, cross3(rot @ point + t, f)])
            return w1 + w2, carried(w1) + d2
        return w_fixed + w2, d2

    return wrench


def force_scale(scene: Scene) -> float:
    """Load magnitude the residual tolerance is relative to, N (≥ 1)."""
    weight = scene["tibia.mass_kg"] * GRAVITY_MPS2 * scene["gravity"]
    return max(1.0, scene["load.force_N"], weight)


def ligament_names(scene: Scene) -> tuple[str, ...]:
    return LIGAMENTS if scene["ligaments.model"] != "none" else ()




def wrench_parts(contact: ContactModel, *others: Callable[[np.ndarray, np.ndarray], Part]
                 ) -> Callable[[np.ndarray, np.ndarray], list[Part]]:
    """The tibia's wrench as a list of parts at pose (R, t): the contact parts first (one
    per compartment, in `contact.compartments` order), then each of `others`."""
    def parts(rot: np.ndarray, t: np.ndarray) -> list[Part]:
        return contact(rot, t) + [part(rot, t) for part in others]

    return parts


@dataclass
class Compartment:
    """One compartment's contact: pair, law and which body the slave belongs to.

    note : a caveat of this pair with this law, appended to `describe()`
    """

    name: str
    pair: ContactPair | SpherePlanePair
    law: Callable[[object], laws.LawResult]
    slave_is_tibia: bool
    radius_mm: float
    note: str = ""

    def __post_init__(self) -> None:
        self._hot = HotPath(self.pair, self.law)

    def describe(self) -> str:
        """How the pair is evaluated, with the law's caveat (for ``--explain``)."""
        return self.pair.describe() + self.note

    def _poses(self, rot: np.ndarray, t: np.ndarray) -> tuple[tuple, tuple]:
        """(slave pose, master pose) at tibia pose (R, t)."""
        fixed, tibia = (_EYE, _ZERO), (rot, t)
        return (tibia, fixed) if self.slave_is_tibia else (fixed, tibia)

    def _on_tibia(self, wrench: np.ndarray, tangent: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
        """The contact wrench on the tibia (6,) and dW/dξ (6, 6) for the tibia's twist,
        from the law's wrench [F, M] (6,) on the slave and its tangent."""
        if self.slave_is_tibia:
            return wrench, tangent
        # the femur is the slave: minus the wrench on it, for the tibia's (master's) twist
        return -wrench, master_tangent(wrench, tangent)

    def evaluate(self, rot: np.ndarray, t: np.ndarray
                 ) -> tuple[laws.LawResult, np.ndarray, np.ndarray]:
        """The law's result at tibia pose (R, t) and the contact wrench on the tibia
        (6,) with its tangent dW/dξ (6, 6) for the tibia's twist ξ."""
        res = self.law(self.pair.evaluate(*self._poses(rot, t)))
        return (res, *self._on_tibia(np.concatenate([res.force, res.moment]), res.tangent))

    def wrench(self, rot: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        """The contact wrench on the tibia (6,), dW/dξ (6, 6) and the largest depth (mm)
        at tibia pose (R, t), through the compiled hot path (`fecheck.laws.fused`)."""
        w = self._hot.evaluate(*self._poses(rot, t))
        return (*self._on_tibia(w.wrench, w.tangent), w.max_depth)


_EYE = np.eye(3)
_ZERO = np.zeros(3)


class ContactModel:
    """The contact parts of the tibia's wrench, one per compartment, at a pose.

    Counts evaluations and the time spent in contact (for the report); `touching` says
    whether the latest evaluation found any contact (for the solver's free flight).
    """

    def __init__(self, compartments: Sequence[Compartment]):
        self.compartments = list(compartments)
        self.evaluations = 0
        self.contact_seconds = 0.0
        self.touching = False

    def _timed(self, each: Callable[[Compartment], tuple]) -> list[tuple]:
        """`each` of every compartment, counted and timed as one contact evaluation."""
        t0 = time.perf_counter()
        out = [each(comp) for comp in self.compartments]
        self.contact_seconds += time.perf_counter() - t0
        self.evaluations += 1
        return out

    def evaluate(self, rot: np.ndarray, t: np.ndarray
                 ) -> list[tuple[laws.LawResult, np.ndarray, np.ndarray]]:
        """(law result, W, dW/dξ) of every compartment at tibia pose (R, t)."""
        out = self._timed(lambda comp: comp.evaluate(rot, t))
        self.touching = any(res.max_depth > 0 for res, _, _ in out)
        return out

    def __call__(self, rot: np.ndarray, t: np.ndarray) -> list[Part]:
        """The contact parts (W, dW/dξ) at tibia pose (R, t), for the Newton loop: the
        hot path, which builds no contact surface."""
        out = self._timed(lambda comp: comp.wrench(rot, t))
        self.touching = any(depth > 0 for _, _, depth in out)
        return [(w, dw) for w, dw, _ in out]

    def wrenches(self, rot: np.ndarray, t: np.ndarray) -> dict[str, np.ndarray]:
        """{compartment: (6,) contact wrench on the tibia (N, N·mm)} at pose (R, t)."""
        evaluated = self.evaluate(rot, t)
        return {c.name: w for c, (_, w, _) in zip(self.compartments, evaluated, strict=True)}


def equal_force_constraint(rot: np.ndarray, t: np.ndarray, parts: Sequence[Part]
                           ) -> tuple[float, np.ndarray, np.ndarray]:
    """g = |F_medial| − |F_lateral| (N) from the first two parts of this evaluation (the
    contact parts, see `wrench_parts`); w = −∂g/∂ξ. The second derivative is not
    available: the Newton step is inexact in this one row."""
    grads, mags = [], []
    for w, dw in parts[:2]:
        f = w[:3]
        mag = float(np.linalg.norm(f))
        grads.append(f @ dw[:3] / mag if mag > 0 else np.zeros(6))
        mags.append(mag)
    return mags[0] - mags[1], -(grads[0] - grads[1]), np.zeros((6, 6))


def law_inputs(scene: Scene) -> LawInputs:
    """What the scene's law is built from (`fecheck.laws.registry.LawInputs`): its values
    and its calibration file, read when the law asks for it."""
    return LawInputs(scene, lambda: calibration_file(scene))


def law_factory(scene: Scene) -> Callable[[float, str], Callable[[object], laws.LawResult]]:
    """Validated contact law of a scene (`fecheck.laws.registry`), as a function of the
    condyle radius (mm; NaN where there is no sphere) and the compartment's name."""
    return spec_of(scene).build(law_inputs(scene))


def calibration_file(scene: Scene) -> dict | None:
    """{compartment: Calibration} of ``contact.calibration`` (a path relative to the scene
    file's folder), or None where it is unset."""
    value = scene["contact.calibration"]
    if not value:
        return None
    path = Path(os.path.expandvars(value)).expanduser()
    if not path.is_absolute():
        path = Path(scene.source).expanduser().resolve().parent / path
    out = calibrated.read_calibration(path)
    calibrated.check_fingerprint(path, scene_fingerprint(scene))
    return out
