"""How far a triangle sheet departs from a smooth surface, and its smoothed copy.

Smoothing over a length L: each vertex is moved along its local normal onto the
least-squares quadric height field fitted to the sheet within L of it. The local normal
is the area-weighted mean of the vertex normals within L; in the tangent plane (u, v) of
that normal the heights h of the vertices within L (3D distance) are fitted by
h = a + b u + c v + d u² + e uv + f v², each vertex weighted by its tributary area (a
third of its triangles' areas), and the vertex moves by a. A quadric is reproduced
exactly (a sphere patch barely moves), while features narrower than L are removed: the
roughness of the sheet at that length.

Measures of a sheet against its copy smoothed over L (`roughness`), with r the signed
distance raw − smoothed along the local normal at each vertex (mm):

- rms_mm : sqrt(Σ A_i r_i² / Σ A_i), A the tributary areas; a sinusoid of amplitude A0
  and wavelength well below L gives A0/√2;
- max_mm : max |r| and its place;
- terrace_mm : the dominant step of a terraced (staircase) sheet. Per edge the jump
  |(p_j − p_i)·n|, its rise along the mean of its ends' local normals; step edges are
  those whose jump exceeds half the 99th percentile of all jumps. On a staircase of step
  h a step edge jumps h − s·e and a tread edge s·e (s the mean slope, e the edge's run),
  so the step is the median jump of the step edges plus the median jump of the others.
  It is 0 (no terraces) when the step edges are under 0.5 % or over 35 % of the edges,
  their median jump is under three times the others', or more than a quarter as many
  edges jump by amounts in the middle half between the two medians (a smooth or
  sinusoidal sheet has no separate population of jumps);
- slivers : faces of quality 4√3·area / Σ edge² below `SLIVER_QUALITY` (1 for an
  equilateral triangle, 0 for a degenerate one).

Units: mm. Vectorised: the neighbourhoods are the pairs of a k-d tree within L.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geometry.cache import cached_arrays, per_mesh
from geometry.mesh import TriMesh

SLIVER_QUALITY = 0.1
"""A face of quality 4√3·area / Σ edge² below this is a sliver (a minimum angle of about
6°)."""
STEP_QUANTILE = 99.0
"""Percentile of the edge jumps that sets the scale of the step edges."""
STEP_SHARE = (0.005, 0.35)
"""Shares of the edges that step edges must lie between for a sheet to count as terraced."""
STEP_CONTRAST = 3.0
"""A terrace's median jump is at least this many times the median jump of the other edges."""
STEP_GAP = 0.25
"""At most this many edges per step edge may jump by amounts in the middle half between
the two populations' medians: a staircase's jumps fall in two separate groups, a smooth
wave's take every value."""


@dataclass(frozen=True, eq=False)
class Roughness:
    """A sheet against its copy smoothed over `radius_mm` (see the module docstring).

    residual_mm : (n_points,) signed distance raw − smoothed along the local normal
    """

    radius_mm: float
    rms_mm: float
    max_mm: float
    max_at_mm: np.ndarray
    terrace_mm: float
    step_edges: int
    edges: int
    slivers: int
    faces: int
    residual_mm: np.ndarray

    def local_mm(self, points: np.ndarray, at_mm: np.ndarray, within_mm: float) -> float:
        """Largest |residual| of the sheet's vertices `points` within `within_mm` of
        `at_mm` (the nearest vertex's when none is that close), mm."""
        d = np.linalg.norm(points - np.asarray(at_mm, dtype=float), axis=1)
        near = d <= within_mm
        if not near.any():
            near = d == d.min()
        return float(np.abs(self.residual_mm[near]).max())

    def as_dict(self) -> dict:
        """The measures (not the residual field), JSON-ready."""
        return {"radius_mm": self.radius_mm, "rms_mm": self.rms_mm, "max_mm": self.max_mm,
                "max_at_mm": [float(v) for v in self.max_at_mm],
                "terrace_mm": self.terrace_mm, "step_edges": self.step_edges,
                "edges": self.edges, "slivers": self.slivers, "faces": self.faces}

    def summary(self, name: str) -> str:
        """One line: `name` and its measures (mm)."""
        x, y, z = self.max_at_mm
        terrace = (f"terraces {self.terrace_mm:.3f} mm ({self.step_edges} step edges)"
                   if self.terrace_mm > 0 else "no terraces")
        return (f"{name}: departs from its copy smoothed over {self.radius_mm:.2f} mm by RMS "
                f"{self.rms_mm:.3f} mm, max {self.max_mm:.3f} mm at ({x:.1f}, {y:.1f}, "
                f"{z:.1f}) mm; {terrace}; {self.slivers} slivers of {self.faces} faces")


def tributary_areas(mesh: TriMesh) -> np.ndarray:
    """(n_points,) a third of the areas of each vertex's triangles, mm²."""
    return np.bincount(mesh.faces.ravel(), weights=np.repeat(mesh.face_areas / 3.0, 3),
                       minlength=mesh.n_points)


def _pairs(points: np.ndarray, radius_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """(i, j) of every ordered pair of points within `radius_mm`, each point with itself."""
    from scipy.spatial import cKDTree

    tree = cKDTree(points)
    pairs = tree.query_pairs(radius_mm, output_type="ndarray")
    own = np.arange(len(points))
    i = np.concatenate([pairs[:, 0], pairs[:, 1], own])
    j = np.concatenate([pairs[:, 1], pairs[:, 0], own])
    return i, j


def _frames(mesh: TriMesh, i: np.ndarray, j: np.ndarray, weight: np.ndarray
            ) -> np.ndarray:
    """(n, 3, 3) local frames (e1, e2, normal) from the weighted mean vertex normals."""
    normals = mesh.vertex_normals
    n = np.column_stack([np.bincount(i, weights=weight[j] * normals[j, k],
                                     minlength=mesh.n_points) for k in range(3)])
    length = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.where(length > 0, n / np.where(length > 0, length, 1.0), normals)
    helper = np.eye(3)[np.argmin(np.abs(n), axis=1)]
    e1 = np.cross(n, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return np.stack([e1, np.cross(n, e1), n], axis=1)


def quadric_offsets(mesh: TriMesh, radius_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """(n,) offset a of each vertex to the quadric fitted within `radius_mm` (mm, along
    the local normal; smoothed = raw + a·normal) and (n, 3) those local unit normals; kept
    in the mesh cache by the mesh's content (`fecheck knee import` and `fecheck fe` measure
    the same sheets)."""
    offsets, normals = cached_arrays("quadric-offsets", [mesh, np.array([radius_mm], float)],
                                     lambda: _quadric_offsets(mesh, radius_mm))
    return offsets, normals


def _quadric_offsets(mesh: TriMesh, radius_mm: float) -> tuple[np.ndarray, np.ndarray]:
    points = mesh.points
    weight = tributary_areas(mesh)
    i, j = _pairs(points, radius_mm)
    frames = _frames(mesh, i, j, weight)
    local = np.einsum("mkc,mc->mk", frames[i], points[j] - points[i]) / radius_mm
    u, v, h = local[:, 0], local[:, 1], local[:, 2] * radius_mm
    basis = np.column_stack([np.ones_like(u), u, v, u * u, u * v, v * v])
    w = weight[j]
    n = mesh.n_points
    normal = np.empty((n, 6, 6))
    for a in range(6):
        for b in range(a, 6):
            normal[:, a, b] = normal[:, b, a] = np.bincount(i, weights=w * basis[:, a]
                                                            * basis[:, b], minlength=n)
    rhs = np.column_stack([np.bincount(i, weights=w * basis[:, a] * h, minlength=n)
                           for a in range(6)])
    ridge = 1e-6 * normal[:, 0, 0]                 # too few neighbours: quadric terms → 0
    normal[:, np.arange(1, 6), np.arange(1, 6)] += ridge[:, None]
    coef = np.linalg.solve(normal, rhs[:, :, None])[:, :, 0]
    return coef[:, 0], frames[:, 2]


def smooth(mesh: TriMesh, radius_mm: float) -> TriMesh:
    """`mesh` with every vertex moved onto its local quadric fitted within `radius_mm`
    (module docstring); the same faces. `radius_mm` ≤ 0 returns `mesh` itself."""
    if radius_mm <= 0:
        return mesh
    offset, normal = quadric_offsets(mesh, radius_mm)
    return TriMesh(mesh.points + offset[:, None] * normal, mesh.faces)


@per_mesh
def smooth_sheet(mesh: TriMesh, radius_mm: float) -> TriMesh:
    """`smooth`, kept per mesh object and radius (a scene's sheets are read once)."""
    return smooth(mesh, radius_mm)


def _terrace(mesh: TriMesh, normals: np.ndarray) -> tuple[float, int]:
    """(step height mm, number of step edges) of the module docstring's definition, with
    `normals` the (n, 3) local normals of the smoothing."""
    edges = mesh.edges_unique
    mean = normals[edges[:, 0]] + normals[edges[:, 1]]
    mean /= np.linalg.norm(mean, axis=1, keepdims=True)
    rise = mesh.points[edges[:, 1]] - mesh.points[edges[:, 0]]
    jump = np.abs(np.einsum("ij,ij->i", rise, mean))
    if len(jump) == 0:
        return 0.0, 0
    step = jump > 0.5 * np.percentile(jump, STEP_QUANTILE)
    share = step.mean()
    if not (STEP_SHARE[0] <= share <= STEP_SHARE[1]) or step.all():
        return 0.0, int(step.sum())
    rise, tread = float(np.median(jump[step])), float(np.median(jump[~step]))
    gap = 0.25 * (rise - tread)
    between = np.count_nonzero((jump > tread + gap) & (jump < rise - gap))
    if rise < STEP_CONTRAST * tread or between > STEP_GAP * step.sum():
        return 0.0, int(step.sum())
    return rise + tread, int(step.sum())


def sliver_count(mesh: TriMesh) -> int:
    """Faces of quality 4√3·area / Σ edge² below `SLIVER_QUALITY`."""
    t = mesh.triangles
    edge2 = (np.sum((t[:, 1] - t[:, 0]) ** 2, axis=1) + np.sum((t[:, 2] - t[:, 1]) ** 2, axis=1)
             + np.sum((t[:, 0] - t[:, 2]) ** 2, axis=1))
    quality = 4.0 * np.sqrt(3.0) * mesh.face_areas / np.where(edge2 > 0, edge2, 1.0)
    return int(np.count_nonzero(quality < SLIVER_QUALITY))


def roughness(mesh: TriMesh, radius_mm: float) -> Roughness:
    """The measures of `mesh` against its copy smoothed over `radius_mm` (mm)."""
    offset, normals = quadric_offsets(mesh, radius_mm)
    residual = -offset
    area = tributary_areas(mesh)
    rms = float(np.sqrt(np.sum(area * residual**2) / max(area.sum(), 1e-300)))
    worst = int(np.argmax(np.abs(residual)))
    terrace, steps = _terrace(mesh, normals)
    return Roughness(float(radius_mm), rms, float(abs(residual[worst])),
                     mesh.points[worst].copy(), terrace, steps, len(mesh.edges_unique),
                     sliver_count(mesh), mesh.n_faces, residual)


def default_radius(mesh: TriMesh) -> float:
    """The smoothing length the reports use: max(2 mm, 4 median edge lengths), mm (a
    quadric needs a few rings of vertices; 2 mm is a fraction of a knee contact's width)."""
    return max(2.0, 4.0 * median_edge(mesh))


def median_edge(mesh: TriMesh) -> float:
    """The median edge length of `mesh`, mm (0 without edges)."""
    e = mesh.edges_unique
    length = np.linalg.norm(mesh.points[e[:, 1]] - mesh.points[e[:, 0]], axis=1)
    return float(np.median(length)) if len(length) else 0.0


MIN_SMOOTHING_EDGES = 2.0
"""A smoothing length under this many median edges holds little more than each vertex's
own ring, which the six-term quadric fits almost exactly: the sheet barely moves."""


def roughness_report(mesh: TriMesh, name: str, radius_mm: float | None = None) -> str:
    """One line of `Roughness.summary` for a sheet (`radius_mm` None: `default_radius`),
    e.g. for `fecheck knee import`."""
    radius = default_radius(mesh) if radius_mm is None else radius_mm
    return roughness(mesh, radius).summary(name)
