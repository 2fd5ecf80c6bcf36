"""Shared builders and finite-difference helpers for the contact tests."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from geometry.mesh import TriMesh

IDENTITY = (np.eye(3), np.zeros(3))


def cap_area(R: float, d: float) -> float:
    """Base area of a spherical cap of height d, mm²."""
    return np.pi * (2.0 * R * d - d * d)


def cap_volume(R: float, d: float) -> float:
    """Volume of a spherical cap of height d, mm³."""
    return np.pi * d * d * (R - d / 3.0)


def moved(pose, xi):
    """Pose after the rigid motion exp(ξ) about the world origin, ξ = (v, ω)."""
    R, t = pose
    dR = Rotation.from_rotvec(xi[3:]).as_matrix()
    return dR @ R, dR @ t + xi[:3]


def volume(s) -> float:
    """Σ w·max(d, 0), mm³."""
    return float((s.qp_weight * np.maximum(s.qp_depth, 0.0)).sum())


def moments(s) -> np.ndarray:
    """(Σ w d, Σ w d²): integrals whose twist derivatives need no boundary term."""
    d, w = s.qp_depth, s.qp_weight
    return np.array([(w * d).sum(), (w * d * d).sum()])


def moments_twist(s) -> np.ndarray:
    """(2, 6) analytic twist derivatives of `moments` from the surface's fields."""
    d, w = s.qp_depth[:, None], s.qp_weight[:, None]
    return np.stack([(s.qp_weight_twist * d + w * s.qp_depth_twist).sum(0),
                     (s.qp_weight_twist * d * d + 2 * w * d * s.qp_depth_twist).sum(0)])


def central_difference(f, pose, h: float = 1e-6) -> np.ndarray:
    """(…, 6) central differences of f(pose) under small twists of size h."""
    cols = []
    for k in range(6):
        e = np.zeros(6)
        e[k] = h
        cols.append((f(moved(pose, e)) - f(moved(pose, -e))) / (2 * h))
    return np.stack(cols, axis=-1)


def extrapolated_difference(f, pose, h: float = 1e-6) -> np.ndarray:
    """Central differences at h and 2h combined to cancel their h² error (Richardson):
    for points near a short clip, whose second derivatives are large."""
    return (4 * central_difference(f, pose, h) - central_difference(f, pose, 2 * h)) / 3


def box(lo, hi) -> TriMesh:
    """A closed axis-aligned box, faces counter-clockwise from outside."""
    import trimesh

    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    m = trimesh.creation.box(extents=hi - lo)
    return TriMesh(np.asarray(m.vertices) + (lo + hi) / 2, np.asarray(m.faces))


def crop(mesh: TriMesh, keep) -> TriMesh:
    """The open sub-mesh of the faces whose centroid satisfies keep(centroids)."""
    faces = mesh.faces[keep(mesh.face_centroids)]
    used, local = np.unique(faces, return_inverse=True)
    return TriMesh(mesh.points[used], local.reshape(-1, 3))
