"""Rotations and rigid poses in the thesis frame.

Frame: origin at the tibial plateau centre, x to the subject's right, y anterior,
z superior; lengths in mm, angles in radians unless a name says ``_deg``.
Rotations compose as R = Rx(θx) · Ry(θy) · Rz(θz) (thesis §2.1.1): θx flexion,
θy abduction/adduction, θz internal/external rotation.
"""

from __future__ import annotations

import numpy as np


def rot_x(angle: float) -> np.ndarray:
    """Rotation matrix about x by `angle` (rad)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(angle: float) -> np.ndarray:
    """Rotation matrix about y by `angle` (rad)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(angle: float) -> np.ndarray:
    """Rotation matrix about z by `angle` (rad)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rotation(theta_x: float, theta_y: float, theta_z: float) -> np.ndarray:
    """R = Rx(θx) · Ry(θy) · Rz(θz), angles in rad.

    >>> bool(np.allclose(rotation(0.0, 0.0, np.pi / 2) @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]))
    True
    """
    return rot_x(theta_x) @ rot_y(theta_y) @ rot_z(theta_z)


def skew(v: np.ndarray) -> np.ndarray:
    """(…, 3, 3) cross-product matrices: skew(a) @ b == a × b."""
    v = np.asarray(v, dtype=float)
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out
