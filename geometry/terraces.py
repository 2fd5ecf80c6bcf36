"""Voxel terraces: detect the staircase of a segmented sheet and fit the smooth surface it
was cut from.

A sheet taken from a voxel label by marching cubes is a staircase along a grid axis t:
flat terraces at levels z0 + k·step (t·p, mm), joined by risers. Where a riser climbs from
one terrace to the next, the label changed between two voxel centres: the true surface
crosses the level half-way between the terraces, z0 + (k + ½)·step, there. Inside a
terrace nothing says where the surface lies within the step: a local fit sees a flat
plateau, and at the bottom of a condyle a 10 mm terrace puts the surface up to half a
step off.

`staircase` finds t, step and z0 from the faces that face along t; `terrace_heights` fits
a height field over a lattice to the mid-riser contour points (the level lines at
z0 + (k + ½)·step, weighted by their length) and, weakly or not at all, to the terrace
points, with a thin-plate penalty (squared second differences along the lattice lines):
one sparse least-squares solve. Inside the innermost contour the field continues the
slopes around it as a cap, not a flat terrace.

Units: mm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from geometry.mesh import TriMesh
from geometry.planar import locate_in_plane

FLAT_DEG = 5.0
"""Faces within this angle of the staircase axis are terrace faces."""
MIN_FLAT_SHARE = 0.02
"""A staircase has at least this share of the sheet's area in terrace faces."""
MIN_LEVELS = 3
"""... on at least this many levels, each holding `MIN_LEVEL_SHARE` of the terrace area."""
MIN_LEVEL_SHARE = 0.02
MIN_CONCENTRATION = 0.6
"""|mean exp(2πi z/step)| of the terrace faces' levels (area-weighted): 1 on exact levels,
near 0 for heights spread evenly over the step."""
STEPS_MM = np.arange(0.2, 1.2, 0.001)
"""Candidate steps, mm (the voxels of a segmentation)."""
TERRACE_WEIGHT = 0.05
"""Default pull of a mm² of terrace face toward its level, against a mm of mid-riser contour
(`TerraceFit`): where the contours leave the field free it stays near the terraces' levels.
On the synthetic plateau (geometry/synthetic/knee.py) voxelized at 0.5 mm the lateral
bump's crest and its saddles lie within one terrace (1.5-2.0 mm): no contour says where,
and the thin plate alone sinks 0.40 mm below the plateau at the contact (0.16 with this
pull). On a cap whose top terrace is wide the pull costs accuracy: the top of
tests/geometry/test_terraces.py's 40 mm cap 0.13 mm low (0.02 mm without)."""
BEND_MM = 0.02
"""Thin-plate weight, mm³ per mm of lattice line (squared second derivative, mm⁻², times
area): bends the field only where the data leave it free."""


@dataclass(frozen=True)
class TerraceFit:
    """How `geometry.prepare.prepare_sheet` fits a terraced sheet.

    step_mm : the staircase's step when known (the other sheet of the same segmentation),
    mm; None: detect it (`staircase`)
    terrace_weight : pull of a mm² of terrace face toward its level, against a mm of
    mid-riser contour (0: the contours alone)
    """

    step_mm: float | None = None
    terrace_weight: float = TERRACE_WEIGHT


@dataclass(frozen=True)
class Staircase:
    """A sheet's voxel staircase: terraces at z0 + k·step along `axis`.

    axis : (3,) unit grid axis; step : level spacing, mm; z0 : a terrace level, mm
    (axis · point); concentration : how sharply the terrace faces sit on the levels (0-1)
    """

    axis: np.ndarray
    step: float
    z0: float
    concentration: float


def staircase(sheet: TriMesh, axis: np.ndarray, step: float | None = None
              ) -> Staircase | None:
    """The voxel staircase of `sheet` seen along `axis` (its mean normal), or None when the
    sheet has none (smooth or scanned sheets): terrace faces (within `FLAT_DEG` of the grid
    axis, at least `MIN_FLAT_SHARE` of the area) on at least `MIN_LEVELS` levels
    z0 + k·step, with a concentration of at least `MIN_CONCENTRATION`; the largest such
    step. With `step` (mm, the staircase of another sheet of the same segmentation) only
    that step is tried, and one level is enough (the bottom of a condyle)."""
    normals, areas = sheet.face_normals, sheet.face_areas
    t = np.asarray(axis, float)
    for deg in (10.0, FLAT_DEG, 1.0):
        near = normals @ t >= np.cos(np.radians(deg))
        if not near.any():
            return None
        t = (normals[near] * areas[near, None]).sum(axis=0)
        t /= np.linalg.norm(t)
    flat = normals @ t >= np.cos(np.radians(FLAT_DEG))
    if areas[flat].sum() < MIN_FLAT_SHARE * areas.sum():
        return None
    z = sheet.points[sheet.faces[flat]].mean(axis=1) @ t
    w = areas[flat] / areas[flat].sum()
    steps = STEPS_MM if step is None else np.array([step])
    phase = np.exp(2j * np.pi * z[None, :] / steps[:, None]) @ w
    r = np.abs(phase)
    if step is not None:
        if r[0] < MIN_CONCENTRATION:
            return None
        return Staircase(t, step, step * float(np.angle(phase[0])) / (2 * np.pi), float(r[0]))
    peak = 1 + np.flatnonzero((r[1:-1] > r[:-2]) & (r[1:-1] >= r[2:])
                              & (r[1:-1] >= MIN_CONCENTRATION))
    for i in peak[::-1]:
        z0 = steps[i] * float(np.angle(phase[i])) / (2 * np.pi)
        level = np.rint((z - z0) / steps[i])
        share = np.bincount((level - level.min()).astype(int), weights=w)
        if (share >= MIN_LEVEL_SHARE).sum() >= MIN_LEVELS:
            # the levels' offset and spacing: weighted least squares z ≈ z0 + k·step
            basis = np.column_stack([np.ones_like(level), level]) * np.sqrt(w)[:, None]
            z0, fitted = np.linalg.lstsq(basis, z * np.sqrt(w), rcond=None)[0]
            return Staircase(t, float(fitted), float(z0), float(r[i]))
    return None


def contour_points(sheet: TriMesh, stair: Staircase) -> tuple[np.ndarray, np.ndarray]:
    """The sheet's level lines at the mid-riser levels z0 + (k + ½)·step: one point per
    face and level crossed (the midpoint of the level line's segment in the face, (m, 3))
    and the segment's length (m,), mm."""
    tri = sheet.points[sheet.faces]                                    # (f, 3, 3)
    z = tri @ stair.axis
    lo = np.ceil((z.min(axis=1) - stair.z0) / stair.step - 0.5).astype(int)
    hi = np.floor((z.max(axis=1) - stair.z0) / stair.step - 0.5).astype(int)
    count = np.maximum(hi - lo + 1, 0)
    face = np.repeat(np.arange(len(tri)), count)
    k = lo[face] + np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    level = stair.z0 + (k + 0.5) * stair.step
    za, zb = z[face], z[face][:, [1, 2, 0]]
    a, b = tri[face], tri[face][:, [1, 2, 0]]
    crosses = (np.minimum(za, zb) <= level[:, None]) & (np.maximum(za, zb) > level[:, None])
    s = (level[:, None] - za) / np.where(za == zb, 1.0, zb - za)
    p = a + s[..., None] * (b - a)                                     # (m, 3 edges, 3)
    two = crosses.sum(axis=1) == 2
    p, crosses = p[two], crosses[two]
    first = np.argmax(crosses, axis=1)
    second = 2 - np.argmax(crosses[:, ::-1], axis=1)
    rows = np.arange(len(p))
    p0, p1 = p[rows, first], p[rows, second]
    return 0.5 * (p0 + p1), np.linalg.norm(p1 - p0, axis=1)


def terrace_heights(lattice: np.ndarray, faces: np.ndarray, lines: np.ndarray,
                    sheet: TriMesh, stair: Staircase, origin: np.ndarray, frame: np.ndarray,
                    axis: np.ndarray, fit: TerraceFit) -> np.ndarray | None:
    """(n,) heights along `axis` at the lattice vertices (n, 2) of the plane (origin, frame),
    h linear on the lattice `faces`: the least-squares fit to the mid-riser contour points
    (weight: their length, mm) and the terrace faces' centroids (weight
    ``fit.terrace_weight`` times their area, mm²), with the thin-plate energy `BEND_MM` ·
    Σ (second difference / s²)² s² over the lattice `lines` (triples of consecutive
    vertices, spacing s) (module docstring); None when fewer than 3 weighted points fall
    on the lattice (the field would not be held)."""
    from scipy.sparse.linalg import spsolve

    points, length = contour_points(sheet, stair)
    flat = sheet.face_normals @ stair.axis >= np.cos(np.radians(FLAT_DEG))
    points = np.concatenate([points, sheet.points[sheet.faces[flat]].mean(axis=1)])
    weight = np.concatenate([length, fit.terrace_weight * sheet.face_areas[flat]])
    A, z, inside = _interpolation(lattice, faces, points, origin, frame, axis)
    if (weight[inside] > 0).sum() < 3:
        return None
    W = sp.diags(weight[inside])
    s = float(np.linalg.norm(lattice[lines[0, 1]] - lattice[lines[0, 0]]))
    rows = np.repeat(np.arange(len(lines)), 3)
    D = sp.csr_matrix((np.tile([1.0, -2.0, 1.0], len(lines)), (rows, lines.ravel())),
                      shape=(len(lines), len(lattice)))
    lhs = (A.T @ W @ A + BEND_MM / s ** 2 * (D.T @ D)).tocsc()
    return np.asarray(spsolve(lhs, A.T @ (W @ z))).ravel()


def _interpolation(lattice: np.ndarray, faces: np.ndarray, points: np.ndarray,
                   origin: np.ndarray, frame: np.ndarray, axis: np.ndarray
                   ) -> tuple[sp.csr_matrix, np.ndarray, np.ndarray]:
    """The barycentric rows (m, n) from the lattice's vertex heights to the points (k, 3)
    that fall on the lattice, those points' heights along `axis` (m,), and which fall
    on it (k,)."""
    rel = points - origin
    face, bary, inside = locate_in_plane(lattice, faces, rel @ frame.T)
    m = int(inside.sum())
    rows = np.repeat(np.arange(m), 3)
    A = sp.csr_matrix((bary[inside].ravel(), (rows, faces[face[inside]].ravel())),
                      shape=(m, len(lattice)))
    return A, rel[inside] @ axis, inside
