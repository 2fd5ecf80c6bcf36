"""Checks of a triangle sheet meant for contact: its size, winding, folds and side.

A contact sheet under a millimetre across is in metres (an error), over a metre in µm or
scaled twice (a warning, `ImplausibleInput`); a tibial sheet with mixed winding, edges
shared by three or more faces or normals pointing down is an error, one that folds back
over itself a warning. The topology each check reads (face pairs across edges, the mean
normal, the folded faces, the extent, the mean x) is computed once per `TriMesh` and kept
while the mesh lives (`geometry.cache.per_mesh`): a sweep checks the same sheets at every point.
No mechanics here. Units mm.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from geometry.cache import per_mesh
from geometry.errors import FecheckError, ImplausibleInput
from geometry.mesh import TriMesh

MESH_EXTENT_MM = (1.0, 1000.0)
"""A knee contact surface is tens of mm across: under 1 mm it is in metres (an error: the
solve cannot mean anything), over a metre in µm or scaled twice (a warning)."""

FOLD_COS = math.cos(math.radians(120.0))
"""Neighbouring faces of a consistently wound sheet whose normals differ by more than
120° fold back over each other (the scanned tibial sheets: ≤ 25°, ≤ 55° decimated to
100 faces); a face turned more than 120° from the sheet's mean normal lies under a fold."""


def _warn(message: str) -> None:
    warnings.warn(message, ImplausibleInput, stacklevel=3)


def _read_only(*arrays: np.ndarray) -> None:
    for a in arrays:
        a.setflags(write=False)


@per_mesh
def extent_mm(mesh: TriMesh) -> float:
    """Largest bounding-box side of the mesh's used vertices, mm."""
    used = np.zeros(mesh.n_points, dtype=bool)
    used[mesh.faces.ravel()] = True
    return float(np.ptp(mesh.points[used], axis=0).max()) if used.any() else 0.0


def check_extent(mesh: TriMesh, what: str) -> None:
    """`FecheckError` for a contact surface under a millimetre across (in metres?), a
    warning over a metre."""
    size = extent_mm(mesh)
    low, high = MESH_EXTENT_MM
    if size < low:
        raise FecheckError(f"the {what} is {size:.3g} mm across, where a knee's is tens of "
                           f"mm: mesh in metres? (scale it by 1000: fecheck works in mm)")
    if size > high:
        _warn(f"the {what} is {size:,.0f} mm across, where a knee's is tens of mm: mesh in "
              "µm, or scaled to mm twice? (fecheck works in mm)")


@dataclass(frozen=True)
class EdgeNeighbours:
    """The faces on the two sides of every shared edge of a triangle mesh.

    a, b : (k,) faces sharing an edge; consistent : (k,) the edge is traversed in
    opposite directions by a and b (their winding agrees); edge : (k, 2) its vertices;
    non_manifold : edges shared by more than two faces; crowded : (m, 2) their vertices,
    once per extra face
    """

    a: np.ndarray
    b: np.ndarray
    consistent: np.ndarray
    edge: np.ndarray
    non_manifold: int
    crowded: np.ndarray

    @property
    def winding_consistent(self) -> bool:
        """`geometry.checks.mesh_report`'s definition: every edge shared by two faces is
        traversed in opposite directions by them, and no edge by more than two."""
        return bool(self.consistent.all()) and self.non_manifold == 0


@per_mesh
def edge_neighbours(mesh: TriMesh) -> EdgeNeighbours:
    """Face pairs across the shared edges of `mesh`, from its `geometry.mesh.EdgeTable`
    (`geometry.checks.mesh_report` answers the same winding question with every other
    check, ~10x the time, too slow for every run)."""
    table = mesh.edge_table
    directed, order = table.directed, table.order
    equal = table.sorted_edge[1:] == table.sorted_edge[:-1]
    same = np.flatnonzero(equal)
    a, b = order[same], order[same + 1]
    third = np.flatnonzero(equal[1:] & equal[:-1])
    out = EdgeNeighbours(a // 3, b // 3, directed[a, 0] == directed[b, 1], directed[a],
                         int(np.count_nonzero(equal[1:] & equal[:-1])), directed[order[third]])
    _read_only(out.a, out.b, out.consistent, out.edge, out.crowded)
    return out


def _where(points_xy: np.ndarray) -> str:
    x, y = points_xy.mean(axis=0)
    return f"around (x, y) = ({x:.1f}, {y:.1f}) mm"


@per_mesh
def area_mean_normal(mesh: TriMesh) -> np.ndarray:
    """(3,) the faces' normals averaged by area: |·| 1 for a flat sheet, less as it
    curves; its z says which way the sheet faces."""
    cross = mesh.face_cross
    out = cross.sum(axis=0) / max(float(np.linalg.norm(cross, axis=1).sum()), 1e-300)
    _read_only(out)
    return out


def check_winding(mesh: TriMesh, what: str) -> None:
    """`FecheckError` for a tibial sheet with mixed winding (edges traversed the same
    way by both faces) or wound upside down (its area-weighted mean normal points down,
    -z, where contact expects it up, towards the femur)."""
    edges = edge_neighbours(mesh)
    if edges.non_manifold:
        count = len(np.unique(np.sort(edges.crowded, axis=1), axis=0))
        raise FecheckError(f"the {what} has {count} edges shared by three or more faces "
                           f"(non-manifold), "
                           f"{_where(mesh.points[edges.crowded.ravel()][:, :2])}, where a "
                           "contact sheet is one layer of faces: remove the extra faces there")
    if not edges.winding_consistent:
        down = mesh.face_cross[:, 2] < 0
        bad = int(np.count_nonzero(~edges.consistent)) + edges.non_manifold
        minority = down if np.count_nonzero(down) <= mesh.n_faces / 2 else ~down
        where = (_where(mesh.face_centroids[minority][:, :2]) if minority.any() else
                 _where(mesh.points[edges.edge[~edges.consistent].ravel()][:, :2]))
        raise FecheckError(f"the {what} has mixed winding: {bad} edges are traversed the "
                           f"same way by both their faces and {int(down.sum())} of "
                           f"{mesh.n_faces} faces face down (-z), {where}; orient every "
                           "face counter-clockwise seen from above (normals up, towards "
                           "the femur), e.g. trimesh.repair.fix_normals or MeshLab")
    mean = area_mean_normal(mesh)
    if mean[2] < 0:
        raise FecheckError(f"the {what}'s normals point down (area-weighted mean normal "
                           f"n_z = {mean[2]:.2f}), where contact expects them up, towards the "
                           "femur: its winding is inverted; reverse the vertex order of "
                           "every face (flip the normals) in the mesh file")


@per_mesh
def fold_faces(mesh: TriMesh) -> np.ndarray:
    """(n_faces,) True for faces of a consistently wound sheet that fold back: across an
    edge their normal turns more than 120° from the neighbour's, or they face more than
    120° away from the sheet's mean normal (under a fold)."""
    edges = edge_neighbours(mesh)
    n = mesh.face_normals
    a, b = edges.a, edges.b
    sharp = edges.consistent & (np.einsum("ij,ij->i", n[a], n[b]) < FOLD_COS)
    out = np.zeros(mesh.n_faces, dtype=bool)
    out[a[sharp]] = True
    out[b[sharp]] = True
    mean = area_mean_normal(mesh)
    norm = float(np.linalg.norm(mean))
    if norm > 0:
        out |= n @ (mean / norm) < FOLD_COS
    _read_only(out)
    return out


def check_folds(mesh: TriMesh, what: str) -> None:
    """Warn when the sheet folds back over itself: the contact would meet the fold's
    upper layer (wrong depth, area and pressure)."""
    folded = fold_faces(mesh)
    if folded.any():
        _warn(f"the {what} folds back over itself: {int(folded.sum())} of {mesh.n_faces} "
              f"faces turn more than 120° against their neighbours or the sheet, "
              f"{_where(mesh.face_centroids[folded][:, :2])}; the contact meets the folded "
              "layer (depth, area and pressure are wrong there): repair the mesh")


def check_sheet(mesh: TriMesh, what: str) -> None:
    """A tibial contact sheet's winding (errors) and folds (a warning)."""
    check_winding(mesh, what)
    check_folds(mesh, what)


@per_mesh
def mean_x_mm(mesh: TriMesh) -> float:
    """Area-weighted mean x of the mesh's faces, mm (0 for a mesh without area)."""
    area = mesh.face_areas
    return float(area @ mesh.face_centroids[:, 0]) / max(float(area.sum()), 1e-300)
