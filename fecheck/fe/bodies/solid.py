"""The cartilage layer of a scene as an elastic solid: any articular surface, extruded.

The tibial articular surface the EF run used (a plateau patch, a scanned sheet, a user's
mesh; outward normals) is extruded along its inward vertex normals by the local
thickness (`geometry.extrude.extrude_layer`: prisms split into conforming tetrahedra),
the bottom is bonded to rigid bone (all its dofs fixed), and small-strain isotropic
linear elasticity is assembled on quadratic tetrahedra (scikit-fem, degree-2
quadrature: exact for affine P2 stiffness). Why extrusion: it keeps the EF run's surface
as the FE's contact surface vertex for vertex (no remeshing, so EF and FE pressures sit
on the same faces), takes any thickness map, and needs no Gmsh call.

Contact acts at the surface vertices along their reference normals n_v (the EF
convention: gap and force along the foundation normal). For that the normal
displacement of each top edge's midside node is tied to the mean of its end vertices'
(along the edge's mean normal), so the top is piecewise linear in the normal direction
and each vertex force is the lumped load of the pressure over its tributary area
(measured on the flat layer against the axisymmetric reference: node-wise constraints
on all quadratic top nodes let corner nodes lift off inside the contact).

Units: mm, N, MPa; the layer lives in the frame of its surface (the tibia's).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from fecheck.errors import FecheckError
from fecheck.fe.material.elasticity import lame
from fecheck.fe.pressure.recovery import tributary_areas
from geometry.extrude import extrude_layer
from geometry.mesh import TetMesh, TriMesh


@dataclass(frozen=True, eq=False)
class LayerSolid:
    """An assembled layer, reduced to the dofs it keeps (free and not tied).

    mesh : the tetrahedra; surface vertex v is mesh point v
    K : (n, n) stiffness of the kept dofs, N/mm (symmetric positive definite)
    normal_rows : (s, n) sparse: row v maps the kept dofs to n_v · u_v (mm) at vertex v
    vertex_dofs : (s, 3) the kept dofs of u_v (x, y, z) at each surface vertex
    normals : (s, 3) unit outward vertex normals of the surface
    tributary_mm2 : (s,) a third of the adjacent surface triangle areas
    surface : the articular surface (s vertices)
    n_dofs : kept dofs; n_nodes : quadratic nodes (vertices and edge midpoints)
    """

    mesh: TetMesh
    K: sp.csc_matrix
    normal_rows: sp.csr_matrix
    vertex_dofs: np.ndarray
    normals: np.ndarray
    tributary_mm2: np.ndarray
    surface: TriMesh
    n_dofs: int
    n_nodes: int
    timing_s: dict = field(default_factory=dict)


def check_material(youngs_MPa: float, poisson: float) -> None:
    """`FecheckError` unless E (MPa) is a positive number and ν lies in [0, 0.5)."""
    if not (np.isfinite(youngs_MPa) and youngs_MPa > 0):
        raise FecheckError(f"Young's modulus must be a positive number of MPa, got {youngs_MPa}")
    if not (np.isfinite(poisson) and 0.0 <= poisson < 0.5):
        raise FecheckError(f"Poisson's ratio must lie in [0, 0.5), got {poisson}")


def layer_solid(surface: TriMesh, thickness_mm: float | np.ndarray, youngs_MPa: float,
                poisson: float, *, layers: int = 4, ratio: float = 1.5,
                directions: np.ndarray | None = None,
                offsets: np.ndarray | None = None,
                formulation: str = "displacement") -> LayerSolid:
    """Assemble the bonded layer under `surface`, `thickness_mm` deep (a number or one value
    per surface vertex, mm, along the normal), with `layers` levels of elements graded by
    `ratio`, extruded along -`directions` (n, 3) (None: the vertex normals; see
    `geometry.extrude.extrusion_directions`) or by `offsets` (n, 3) from each bottom copy
    up to its vertex (they replace thickness and directions). Contact acts along the
    vertex normals; `formulation` as in `p2_elasticity`."""
    check_material(youngs_MPa, poisson)
    timing = {}
    t0 = time.perf_counter()
    layer = extrude_layer(surface, thickness_mm, layers=layers, ratio=ratio,
                          directions=directions, offsets=offsets)
    timing["mesh"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    mesh, basis, K = p2_elasticity(layer, youngs_MPa, poisson, formulation=formulation)
    timing["assemble"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    s = surface.n_points
    find_edge = edge_lookup(mesh.edges, mesh.p.shape[1])
    bottom = np.unique(layer.boundaries["bottom"])
    bottom_edges = _face_edges(layer.boundaries["bottom"])
    fixed = np.concatenate([basis.nodal_dofs[:, bottom].ravel(),
                            basis.edge_dofs[:, find_edge(*bottom_edges.T)].ravel()])
    top_edges = _face_edges(surface.faces)
    normals = surface.vertex_normals
    edge_normal = normals[top_edges[:, 0]] + normals[top_edges[:, 1]]
    edge_normal /= np.linalg.norm(edge_normal, axis=1, keepdims=True)
    mid_dofs = basis.edge_dofs[:, find_edge(*top_edges.T)].T              # (e, 3)
    end_dofs = basis.nodal_dofs[:, top_edges.ravel()].T.reshape(-1, 2, 3)  # (e, 2, 3)
    T, kept = tie_matrix(basis.N, fixed, mid_dofs, end_dofs, edge_normal)
    K_red = (T.T @ K @ T).tocsc()
    vertex_dofs = basis.nodal_dofs[:, :s].T                                # (s, 3)
    rows = np.repeat(np.arange(s), 3)
    N_full = sp.csr_matrix((normals.ravel(), (rows, vertex_dofs.ravel())), shape=(s, basis.N))
    normal_rows = (N_full @ T).tocsr()
    position = np.full(basis.N, -1)
    position[kept] = np.arange(len(kept))
    timing["reduce"] = time.perf_counter() - t0
    return LayerSolid(layer, K_red, normal_rows, position[vertex_dofs], normals,
                      tributary_areas(surface.points, surface.faces), surface, len(kept),
                      basis.N // 3, timing)


def p2_elasticity(layer: TetMesh, youngs_MPa: float, poisson: float, chunk: int = 8192,
                  formulation: str = "displacement"):
    """(skfem mesh, basis, K): isotropic small-strain elasticity on quadratic tetrahedra
    (degree-2 quadrature, exact for affine P2), stiffness K in N/mm; `formulation`
    'mixed' condenses an element-constant pressure (`fecheck.fe.material.elasticity`: the λ term
    on the element means of div u, for nearly incompressible layers) inside each element
    matrix, (λ/|T|) d dᵀ with d_(ia) = ∫_T ∂_a φ_i (no second sparse assembly; the
    same matrix as `fecheck.fe.material.elasticity.mean_dilatation_stiffness` to round-off).

    The element matrices are formed at once from the scalar P2 gradients,
    K_(ia)(jb) = ∫ λ ∂_a φ_i ∂_b φ_j + μ (δ_ab ∇φ_i·∇φ_j + ∂_b φ_i ∂_a φ_j) dx, in chunks
    of `chunk` elements summed into K chunk by chunk (memory: K and one chunk, never
    all element matrices at once), on the vector basis's dofs (node-major
    local order, as scikit-fem numbers them); scikit-fem's form assembly gives the same
    matrix to round-off, 2x slower (tests/fe/test_fe_general.py).
    """
    from skfem import Basis, ElementTetP2, ElementVector, MeshTet

    mesh = MeshTet(np.ascontiguousarray(layer.points.T), np.ascontiguousarray(layer.tets.T))
    basis = Basis(mesh, ElementVector(ElementTetP2()), intorder=2)
    lam, mu = lame(youngs_MPa, poisson)
    lam_point = 0.0 if formulation == "mixed" else lam
    scalar = Basis(mesh, ElementTetP2(), intorder=2)
    grads = np.array([phi[0].grad for phi in scalar.basis])            # (10, 3, nel, nq)
    K = sp.csr_matrix((basis.N, basis.N))
    for start in range(0, mesh.t.shape[1], chunk):
        part = slice(start, start + chunk)
        a = np.einsum("iaeq,jbeq,eq->eijab", grads[:, :, part], grads[:, :, part],
                      scalar.dx[part], optimize=True)
        ke = lam_point * a + mu * np.swapaxes(a, 3, 4)
        ke += mu * np.einsum("eijcc->eij", a)[..., None, None] * np.eye(3)
        ke = ke.transpose(0, 1, 3, 2, 4).reshape(-1, 30, 30)
        if formulation == "mixed":                  # + d dᵀ λ/|T|, d = ∫_T div φ (P0 pressure)
            d = np.einsum("iaeq,eq->eia", grads[:, :, part], scalar.dx[part]).reshape(-1, 30)
            ke += (lam / scalar.dx[part].sum(axis=1))[:, None, None] * d[:, :, None] \
                * d[:, None, :]
        dofs = basis.element_dofs[:, part].T.astype(np.int32)           # (e, 30)
        K = K + sp.csr_matrix((ke.ravel(), (np.repeat(dofs, 30, axis=1).ravel(),
                                            np.tile(dofs, (1, 30)).ravel())),
                              shape=(basis.N, basis.N))
    return mesh, basis, K


def release_freed_heap() -> None:
    """Hand the heap memory freed by the assembly back to the system (glibc's
    ``malloc_trim``; nothing elsewhere). The assembly's many mid-sized temporaries leave
    the heap fragmented, and glibc keeps it: 0.46 GB at 155k dofs, which the
    factorization that follows (allocated outside the heap) would sit on top of."""
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("c")
    try:
        ctypes.CDLL(name).malloc_trim(0)
    except (OSError, AttributeError, TypeError):
        return


def _face_edges(faces: np.ndarray) -> np.ndarray:
    """(e, 2) sorted unique vertex pairs of the edges of triangles `faces`."""
    e = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    return np.unique(e, axis=0)


def tie_matrix(n: int, fixed: np.ndarray, mid: np.ndarray, ends: np.ndarray,
                normal: np.ndarray) -> tuple[sp.csr_matrix, np.ndarray]:
    """T (n × kept) with u = T ũ: fixed dofs are zero, and at each top edge midside node
    the component along its largest normal axis k is eliminated by
    n·u_mid = ½ n·(u_a + u_b), i.e. u_mid[k] = (½ n·(u_a + u_b) − Σ_{j≠k} n_j u_mid[j]) / n_k.
    """
    k = np.argmax(np.abs(normal), axis=1)
    e = np.arange(len(mid))
    tied = mid[e, k]
    drop = np.zeros(n, dtype=bool)
    drop[fixed] = True
    drop[tied] = True
    kept = np.flatnonzero(~drop)
    col = np.full(n, -1)
    col[kept] = np.arange(len(kept))
    nk = normal[e, k]
    src = [ends[:, 0, :], ends[:, 1, :], mid]                  # (e, 3) dof indices each
    coef = [0.5 * normal / nk[:, None], 0.5 * normal / nk[:, None], -normal / nk[:, None]]
    coef[2][e, k] = 0.0                                        # the tied dof itself
    t_rows = [np.repeat(tied, 3)] * 3
    t_cols = [col[s_.ravel()] for s_ in src]
    t_vals = [c.ravel() for c in coef]
    rows = np.concatenate([kept, *t_rows])
    cols = np.concatenate([np.arange(len(kept)), *t_cols])
    vals = np.concatenate([np.ones(len(kept)), *t_vals])
    keep = (cols >= 0) & (vals != 0.0)                          # fixed sources are zero
    T = sp.csr_matrix((vals[keep], (rows[keep], cols[keep])), shape=(n, len(kept)))
    return T, kept


def edge_lookup(edges: np.ndarray, n: int):
    """A function mapping vertex pairs (a, b) to indices into ``edges`` (2, ne)."""
    keys = np.minimum(edges[0], edges[1]).astype(np.int64) * n + np.maximum(edges[0], edges[1])
    order = np.argsort(keys)

    def find(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        want = np.minimum(a, b).astype(np.int64) * n + np.maximum(a, b)
        return order[np.searchsorted(keys[order], want)]

    return find
