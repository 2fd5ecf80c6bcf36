"""Rigid poses that name their frames, in Drake's ``X_WT`` notation.

``X_WT`` is the pose of frame T in frame W: the rotation ``R_WT`` (3, 3) whose columns
are T's unit axes expressed in W, and the translation ``p_WT`` (3,) mm, T's origin
expressed in W. A point with coordinates ``p_T`` in T has ``p_W = R_WT p_T + p_WT`` in
W; poses compose as ``X_WB = X_WT @ X_TB`` (the inner frames must match) and invert as
``X_TW = X_WT.inverse()``. In the FE the frames are the world (``"W"``, the femur's
frame), the tibia (``"T"``), the femur placed for a solve (``"F"``) and the menisci.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class FramePose:
    """The pose X_{frame}{body}: `rotation` (3, 3) R and `translation` (3,) p (mm) of frame
    `body` expressed in frame `frame`."""

    rotation: np.ndarray
    translation: np.ndarray
    frame: str = "W"
    body: str = "T"

    @classmethod
    def identity(cls, frame: str = "W", body: str = "W") -> FramePose:
        """Frame `body` on frame `frame`: no rotation, no translation."""
        return cls(np.eye(3), np.zeros(3), frame, body)

    @property
    def name(self) -> str:
        """Drake's name of the pose, e.g. ``X_WT``."""
        return f"X_{self.frame}{self.body}"

    def __matmul__(self, other: FramePose) -> FramePose:
        """X_AC = X_AB @ X_BC; `ValueError` when `other` is not expressed in this pose's
        body frame."""
        if other.frame != self.body:
            raise ValueError(f"cannot compose {self.name} with {other.name}: "
                             f"{other.name} is not in frame {self.body}")
        return FramePose(self.rotation @ other.rotation,
                    self.rotation @ other.translation + self.translation,
                    self.frame, other.body)

    def inverse(self) -> FramePose:
        """X_TW from X_WT: R_TW = R_WTᵀ, p_TW = −R_WTᵀ p_WT."""
        back = self.rotation.T
        return FramePose(back, -(back @ self.translation), self.body, self.frame)

    def points(self, p: np.ndarray) -> np.ndarray:
        """(n, 3) points given in the body frame (mm), expressed in `frame` (mm)."""
        return np.asarray(p) @ self.rotation.T + self.translation

    def vectors(self, v: np.ndarray) -> np.ndarray:
        """(n, 3) directions given in the body frame, expressed in `frame` (rotated only)."""
        return np.asarray(v) @ self.rotation.T

    def pair(self) -> tuple[np.ndarray, np.ndarray]:
        """(R, p): the rotation and translation, for code that takes them apart."""
        return self.rotation, self.translation
