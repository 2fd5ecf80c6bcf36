"""The tibial cartilage or insert as a closed solid: ``geometry.tibia_solid``.

A scene may name, besides (or instead of) the tibial articular sheet ``geometry.tibia``,
the closed triangle surface of the whole tibial cartilage volume or implant insert (the
same file formats, units and rigid transform as the other ``[geometry]`` files). It is
one closed piece for both compartments (a one-piece insert) or two closed pieces (one
per compartment). The FE meshes its volume (`fecheck.fe.bodies.volume`); the EF keeps using an
articular sheet:

- Articular face (the contact surface): the boundary faces of the solid that lie on the
  tibial sheet — centroid within `ARTICULAR_TOL_MM` of the sheet, normal within 60° of
  the sheet's there. Without ``geometry.tibia``, the sheet is the solid's up-facing part:
  the faces whose outward normal is within `UP_ANGLE_DEG` of +z (toward the femur) and
  that are seen from above (an upward ray from the face hits no other face of the
  solid), split into compartments by ``geometry.tibia_split`` like a sheet file.
- Orientation: each closed piece is wound outward (a piece wound inward is turned).

This module holds the mesh operations; the scene's readers (`solid_surface`,
`articular_sheets`) are in `fecheck.scene.surfaces`.

Units: mm, thesis frame (x right, y anterior, z superior).
"""

from __future__ import annotations

import math

import numpy as np

from fecheck.errors import FecheckError
from geometry.mesh import TriMesh, components

KEY = "geometry.tibia_solid"
ARTICULAR_TOL_MM = 0.1
"""A solid's boundary face is on the articular sheet when its centroid is this close to
the sheet, mm (a different triangulation of the same smooth surface deviates by its
chord sag, about 0.01 mm for 1 mm triangles on a 20 mm radius)."""
UP_ANGLE_DEG = 75.0
"""Without a sheet, the up-facing part of the solid: outward normals within this angle
of +z (and seen from above)."""


def open_edges(mesh: TriMesh) -> np.ndarray:
    """(k, 2) vertex pairs of the edges not shared by exactly two faces."""
    table = mesh.edge_table
    return table.edges[table.counts != 2]


def outward(mesh: TriMesh, name: str) -> TriMesh:
    """`mesh` with every closed piece wound outward (positive enclosed volume);
    `FecheckError` naming `name` when it is not closed."""
    bad = open_edges(mesh)
    if len(bad):
        where = ", ".join(f"{v:.1f}" for v in mesh.points[bad[0, 0]])
        raise FecheckError(f"{name}: {KEY} must be a closed surface, but {len(bad)} edges "
                           f"are not shared by exactly two faces (one at ({where}) mm); "
                           "close the solid (or leave the key out and let the FE extrude "
                           "the sheet geometry.tibia)")
    directed = mesh.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2).astype(np.int64)
    keys, counts = np.unique(directed[:, 0] * mesh.n_points + directed[:, 1],
                             return_counts=True)
    if (counts > 1).any():
        where = ", ".join(f"{v:.1f}" for v in mesh.points[keys[counts > 1][0] // mesh.n_points])
        raise FecheckError(f"{name}: the faces of {KEY} are not wound consistently (two "
                           f"neighbours run along their shared edge the same way, at "
                           f"({where}) mm); orient them all outward and export it again")
    faces = mesh.faces.copy()
    p = mesh.points[mesh.faces]
    six_v = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2]))
    for piece in components(mesh):
        if six_v[piece].sum() < 0:
            faces[piece] = faces[piece][:, ::-1]
    return TriMesh(mesh.points, faces)


def up_facing(solid: TriMesh) -> np.ndarray:
    """Face indices of the part of a closed `solid` seen from above (module docstring)."""
    normals = solid.face_normals
    steep = normals[:, 2] >= math.cos(math.radians(UP_ANGLE_DEG))
    from geometry.distance import ray_hits

    size = float(np.linalg.norm(np.ptp(solid.points, axis=0)))
    idx = np.flatnonzero(steep)
    up = np.tile([0.0, 0.0, 1.0], (len(idx), 1))
    hit, _ = ray_hits(solid.face_centroids[idx] + 1e-6 * size * up, up, solid)
    return idx[~np.isfinite(hit)]


def on_sheet(solid: TriMesh, sheet: TriMesh) -> np.ndarray:
    """Face indices of `solid` lying on `sheet` (module docstring)."""
    from geometry.distance import closest_distance

    dist, face = closest_distance(solid.face_centroids, sheet)
    facing = np.einsum("ij,ij->i", solid.face_normals, sheet.face_normals[face]) > 0.5
    return np.flatnonzero((dist <= ARTICULAR_TOL_MM) & facing)
