"""A meniscus as an elastic body of the FE knee: placed at its EF pose on the tibial layer,
its P2 transversely isotropic stiffness with the horns' root springs (and the coronary
ligaments') to the tibia, its superior vertices that meet the femur and its inferior faces
that meet the tibial layer, and the stress of a displacement for its hoop force.

Everything is in the frame of the tibia at its EF pose. Units: mm, N, MPa.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from fecheck.errors import FecheckError
from fecheck.fe.bodies.meniscus_solid import (
    DONAHUE_HORN_N_PER_MM,
    INFERIOR,
    SUPERIOR,
    MeniscusSolid,
)
from fecheck.fe.bodies.pose import FramePose
from fecheck.fe.bodies.solid import edge_lookup, tie_matrix
from fecheck.fe.contact.condense import ElasticBody
from fecheck.fe.material.anisotropy import MENISCUS, TransIso, p2_transiso, stiffness_tensor
from fecheck.fe.solve.multibody import ray_pairs
from fecheck.statics.newton import body_pose
from fecheck.statics.root_spring import root_matrix
from geometry.mesh import TriMesh

if TYPE_CHECKING:
    from skfem import CellBasis


ROOTS = ("data", "donahue", "bundles", "springs")
"""Horn root stiffness sources: ``"data"`` the sum of the horn's root bundles' k / l0,
``"donahue"`` `DONAHUE_HORN_N_PER_MM` per horn (`horn_stiffness`), both the same in x, y
and z; ``"bundles"`` as ``"data"``; ``"springs"`` a linear spring along the root's
direction (`horn_matrices`)."""
FACING_COS = 0.5
"""A meniscus's superior vertex meets the femur when its normal lies within 60 deg of the
tibial axis: at a horn tip the few superior faces give a vertex normal that may point
sideways or down, whose ray meets the femoral surface far behind it (measured: 37.7 mm
at the lateral anterior tip)."""
_REACH_MM = 5.0
"""Rays toward a meniscus's inferior face start this far below the tibial vertex, mm."""
RIM_GAP_MM = 0.05
"""Where a tibial vertex's ray grazes the rim of a meniscus's inferior surface, lowering
the meniscus onto the layer makes that ray meet it, overlapping, and raising it makes the
ray miss, so the placement flips between the two (measured on 2 mm tibial sheets: the
medial meniscus of donahue2002 with its root bundles, ±0.010 mm): the meniscus then rests
where nothing overlaps, if its least gap there is under this, mm (the FE's contact closes
it)."""


@dataclass(frozen=True, eq=False)
class MeniscusBody:
    """A meniscus in the tibia frame: its solid, points (n, 3) mm, the `ElasticBody` (horn
    springs in K), superior vertices and their unit normals, inferior faces, the rise
    along the tibial axis (mm), the stiffness per horn and per spring node ((3, 3) N/mm
    each)."""

    side: str
    solid: MeniscusSolid
    points: np.ndarray
    body: ElasticBody
    superior: np.ndarray
    superior_normals: np.ndarray
    inferior_faces: np.ndarray
    rise_mm: float
    horn_N_per_mm: dict[str, np.ndarray]
    spring_nodes: np.ndarray
    spring_N_per_mm: np.ndarray
    basis: CellBasis | None = None
    tie: sp.spmatrix | None = None
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    material: TransIso = MENISCUS


def vertex_normals(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(n, 3) area-weighted unit normals of `faces` at `points` (zero where no face)."""
    tri = points[faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    out = np.zeros_like(points)
    np.add.at(out, faces.ravel(), np.repeat(cross, 3, axis=0))
    norm = np.linalg.norm(out, axis=1, keepdims=True)
    return np.divide(out, norm, out=np.zeros_like(out), where=norm > 0)


def horn_stiffness(solid: MeniscusSolid, root: str) -> dict[str, float]:
    """Stiffness of each horn's attachment, N/mm: the sum of its root bundles' k / l0
    (``root = "data"``) or `DONAHUE_HORN_N_PER_MM` (``"donahue"``)."""
    if root not in ROOTS[:2]:
        raise FecheckError(f"horn root stiffness {root!r}: give one of {', '.join(ROOTS[:2])}")
    if root == "donahue":
        return {name: DONAHUE_HORN_N_PER_MM for name in solid.horns}
    out = {name: float(sum(b.stiffness_N_per_mm for b in h.ligaments))
           for name, h in solid.horns.items()}
    if not all(v > 0 for v in out.values()):
        raise FecheckError(f"the {solid.side} meniscus has a horn without root ligaments in "
                           "meniscal_ligaments.json; use root = 'donahue'")
    return out


def meniscus_body(solid: MeniscusSolid, points: np.ndarray, fibre: np.ndarray,
                  horns: dict[str, float], material: TransIso = MENISCUS,
                  extra: tuple[np.ndarray, np.ndarray] | None = None):
    """(`ElasticBody`, basis, T) of a meniscus solid at `points` (n, 3) with element fibres
    `fibre` (nel, 3), both in the common frame: P2 transversely isotropic stiffness, each
    horn's stiffness (N/mm, `horns`) spread over its nodes as grounded springs in x, y and
    z (and the springs `extra`: (nodes, N/mm)), and on the superior and inferior faces the
    midside normal displacement tied to its edge's ends (contact at vertices only); the
    full P2 displacement is T @ the body's kept-dof displacement."""
    basis, K = meniscus_stiffness(solid, points, fibre, horns, material, extra)
    mesh = basis.mesh
    find_edge = edge_lookup(mesh.edges, mesh.p.shape[1])
    edges, normals = [], []
    for label in (SUPERIOR, INFERIOR):
        faces = solid.faces(label)
        e = TriMesh(points, faces).edges_unique
        n = vertex_normals(points, faces)
        nm = n[e[:, 0]] + n[e[:, 1]]
        edges.append(e)
        normals.append(nm / np.linalg.norm(nm, axis=1, keepdims=True))
    edges_all = np.concatenate(edges)
    _, first = np.unique(np.sort(edges_all, axis=1), axis=0, return_index=True)
    edges_all, normals_all = edges_all[first], np.concatenate(normals)[first]
    mid = basis.edge_dofs[:, find_edge(*edges_all.T)].T
    ends = basis.nodal_dofs[:, edges_all.ravel()].T.reshape(-1, 2, 3)
    T, kept = tie_matrix(basis.N, np.zeros(0, dtype=np.int64), mid, ends, normals_all)
    position = np.full(basis.N, -1)
    position[kept] = np.arange(len(kept))
    return (ElasticBody(f"{solid.side} meniscus", (T.T @ K @ T).tocsc(),
                 position[basis.nodal_dofs.T]), basis, T)


def meniscus_stiffness(solid: MeniscusSolid, points: np.ndarray, fibre: np.ndarray,
                       horns: dict[str, float], material: TransIso = MENISCUS,
                       extra: tuple[np.ndarray, np.ndarray] | None = None):
    """(basis, K N/mm): the P2 transversely isotropic stiffness of the meniscus at
    `points` with element fibres `fibre`, plus each horn's stiffness (N/mm, `horns`)
    (a number: in x, y and z; a (3, 3) matrix: `horn_matrices`) spread evenly over its
    nodes as grounded springs, and the springs `extra` ((nodes, N/mm each), in x, y and
    z) likewise."""
    from skfem import MeshTet

    mesh = MeshTet(np.ascontiguousarray(points.T), np.ascontiguousarray(solid.mesh.tets.T))
    basis, K = p2_transiso(mesh, material, fibre)
    nodes, k_node = _springs(solid, horns, extra)
    dofs = basis.nodal_dofs[:, nodes].T                              # (m, 3)
    rows = np.repeat(dofs, 3, axis=1).ravel()
    cols = np.tile(dofs, (1, 3)).ravel()
    return basis, (K + _blocks(basis.N, rows, cols, k_node.ravel())).tocsr()


def _springs(solid: MeniscusSolid, horns: dict[str, float | np.ndarray],
             extra: tuple[np.ndarray, np.ndarray] | None = None
             ) -> tuple[np.ndarray, np.ndarray]:
    """(nodes (m,), stiffness (m, 3, 3) N/mm per node): each horn's stiffness (a number:
    the same in x, y and z; or a (3, 3) matrix) spread evenly over its nodes, then the
    springs `extra` ((nodes, N/mm), in x, y and z)."""
    nodes = [solid.horns[h].nodes for h in horns]
    k = [np.broadcast_to(_matrix(horns[h]) / len(n), (len(n), 3, 3))
         for h, n in zip(horns, nodes, strict=True)]
    if extra is not None:
        nodes.append(np.asarray(extra[0]))
        k.append(np.asarray(extra[1], dtype=float)[:, None, None] * np.eye(3))
    if not nodes:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3, 3))
    return np.concatenate(nodes), np.concatenate(k)


def _matrix(k: float | np.ndarray) -> np.ndarray:
    """(3, 3) stiffness of a horn given as a number (the same in x, y, z) or a matrix."""
    k = np.asarray(k, dtype=float)
    return k * np.eye(3) if k.ndim == 0 else k


def horn_matrices(solid: MeniscusSolid, root: str, stiffness_N_per_mm: float,
                  torn: tuple[str, ...] = ()) -> dict[str, np.ndarray]:
    """{horn: (3, 3) stiffness N/mm} of each horn not `torn`: ``root = "springs"`` a
    linear spring of `stiffness_N_per_mm` along the root's direction
    (`fecheck.statics.root_spring.root_matrix`, `Horn.direction`); else the same in x, y
    and z (`horn_stiffness`: ``"bundles"`` the data's bundles, as ``"data"``)."""

    if root not in ROOTS:
        raise FecheckError(f"horn roots {root!r}: give one of {', '.join(ROOTS)}")
    kept = [h for h in solid.horns if h not in torn]
    if root == "springs":
        return {h: root_matrix(solid.horns[h].direction, stiffness_N_per_mm) for h in kept}
    k = horn_stiffness(solid, "data" if root == "bundles" else root)
    return {h: k[h] * np.eye(3) for h in kept}


def coronary_springs(solid: MeniscusSolid, folder) -> tuple[np.ndarray, np.ndarray]:
    """(nodes, N/mm): the `solid`'s coronary ligaments (group ``COR`` of
    ``meniscal_ligaments.json`` in `folder`), each a spring of its linear-region stiffness
    k / l0 on the mesh node nearest its meniscal point."""
    import json
    from pathlib import Path

    from scipy.spatial import cKDTree

    path = Path(folder) / "meniscal_ligaments.json"
    items = [it for it in json.loads(path.read_text(encoding="utf-8"))["ligaments"]
             if it.get("meniscus") == solid.side and it.get("group") == "COR"]
    if not items:
        raise FecheckError(f"{path}: no coronary (COR) ligament of the {solid.side} meniscus; "
                           "run without coronary=True")
    points = np.array([it["points_mm"][1] for it in items], dtype=float)
    k = np.array([float(it["parameters"]["linear_stiffness"]["value"])
                  / (1000.0 * float(it["parameters"]["slack_length"]["value"]))
                  for it in items])
    return cKDTree(solid.mesh.points).query(points)[1], k


def element_stress(basis, u: np.ndarray, fibre: np.ndarray,
                   material: TransIso = MENISCUS) -> np.ndarray:
    """(nel, 3, 3) stress (MPa) per element of the P2 displacement `u` (mm, on the
    scikit-fem vector `basis`): the element's volume-mean strain times the transversely
    isotropic stiffness with its fibre `fibre` (nel, 3)."""
    grad = np.asarray(basis.interpolate(u).grad)                     # (3, 3, nel, nq)
    dx = np.asarray(basis.dx)
    mean = np.einsum("abeq,eq->eab", grad, dx) / dx.sum(axis=1)[:, None, None]
    strain = 0.5 * (mean + mean.transpose(0, 2, 1))
    return np.einsum("nabcd,ncd->nab", stiffness_tensor(material, fibre), strain)


def _blocks(n: int, rows: np.ndarray, cols: np.ndarray, values: np.ndarray) -> sp.csr_matrix:
    return sp.csr_matrix((values, (rows, cols)), shape=(n, n))


def inferior_rays(points: np.ndarray, faces: np.ndarray, layer_points: np.ndarray,
                   layer_normals: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(faces, weights, gaps mm) of the rays from the layer vertices along their normals to
    the meniscus's inferior `faces` on `points` (overlaps up to `_REACH_MM` seen)."""
    face, weights, gap = ray_pairs(layer_points - _REACH_MM * layer_normals, layer_normals,
                                   points, faces, 0.0)
    return face, weights, np.where(face >= 0, gap - _REACH_MM, np.inf)


def place_meniscus(solid: MeniscusSolid, q_meniscus: np.ndarray, q_tibia: np.ndarray,
                   layer_points: np.ndarray, layer_normals: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, float]:
    """(points (n, 3), fibres (nel, 3), rise mm): the meniscus at its EF body coordinates
    `q_meniscus`, in the frame of the tibia at `q_tibia`, moved along the tibial z axis
    until the least gap from the tibial layer vertices (along their normals) to its
    inferior faces is zero (to 1e-9 mm); where a ray grazing the inferior surface's rim
    keeps that from settling, the placement where nothing overlaps and the least gap is
    smallest, if under `RIM_GAP_MM`."""
    rot_m, t_m = body_pose(np.asarray(q_meniscus, dtype=float))
    rot_t, t_t = body_pose(np.asarray(q_tibia, dtype=float))
    points = (solid.mesh.points @ rot_m.T + t_m - t_t) @ rot_t
    fibre = solid.fibre @ (rot_t.T @ rot_m).T
    inferior = solid.faces(INFERIOR)
    rise = 0.0
    clear = (np.inf, points, rise)      # the placement with the least gap where none overlaps
    for _ in range(30):                 # the least gap falls about tenfold per rise
        face, _, gap = inferior_rays(points, inferior, layer_points, layer_normals)
        if not (face >= 0).any():
            raise FecheckError(f"the {solid.side} meniscus at its EF pose lies over no "
                               "vertex of the tibial layer: check menisci.dir and the pose")
        low = float(gap.min())
        if abs(low) <= 1e-9:
            return points, fibre, rise
        if 0.0 < low < clear[0]:
            clear = (low, points, rise)
        points = points - [0.0, 0.0, low]
        rise -= low
    if clear[0] <= RIM_GAP_MM:
        return clear[1], fibre, clear[2]
    raise FecheckError(f"the {solid.side} meniscus does not settle on the tibial layer "
                       f"(gap {low:.2e} mm after a rise of {rise:.3f} mm)")


def build_meniscus(solid: MeniscusSolid, q: np.ndarray, q_tibia: np.ndarray,
                   layer_points: np.ndarray, layer_normals: np.ndarray,
                   horns: dict[str, np.ndarray],
                   extra: tuple[np.ndarray, np.ndarray] | None = None,
                   material: TransIso = MENISCUS) -> MeniscusBody:
    """The `MeniscusBody` of `solid` at its EF body coordinates `q` (6,) in the frame of
    the tibia at `q_tibia`, placed on the tibial layer (its surface `layer_points` and
    normals, `place_meniscus`), with the horns' stiffness `horns` ({horn: (3, 3) N/mm},
    `horn_matrices`), the springs `extra` ((nodes, N/mm), `coronary_springs`) and its
    `material`."""
    points, fibre, rise = place_meniscus(solid, q, q_tibia, layer_points, layer_normals)
    body, basis, tie = meniscus_body(solid, points, fibre, horns, material, extra)
    X_WT = FramePose(*body_pose(np.asarray(q_tibia, dtype=float)), "W", "T")
    X_WM = FramePose(*body_pose(np.asarray(q, dtype=float)), "W", "M")
    rotation = (X_WT.inverse() @ X_WM).rotation
    superior = np.unique(solid.faces(SUPERIOR))
    normals = vertex_normals(points, solid.faces(SUPERIOR))[superior]
    facing = normals[:, 2] >= FACING_COS
    superior, normals = superior[facing], normals[facing]
    nodes, k_node = _springs(solid, horns, extra)
    return MeniscusBody(solid.side, solid, points, body, superior, normals,
                        solid.faces(INFERIOR), rise, horns, nodes, k_node, basis, tie,
                        rotation, material)
