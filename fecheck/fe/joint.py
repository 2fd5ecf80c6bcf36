"""Load-controlled frictionless contact of rigid indenters on elastic layers, with the
tibia's rigid-body DOFs as unknowns of the same problem.

Each layer (one per compartment) is bonded to the tibia and pressed by its fixed rigid
indenter (the femoral surface). At a tibia pose q the gap of layer vertex i along its
normal is g_i = g0_i(q) + J_i·δq + (C λ)_i, where C = N K⁻¹ Nᵀ is the layer's normal
compliance at the candidate vertices (one sparse factorization and one block solve per
layer, reused for every pose and load) and J_i = ∂g0_i/∂q. The contact forces λ ≥ 0 (N,
acting along −n_i on the layer) and the pose step δq solve the mixed complementarity
problem

    g0 + J δq + C λ ≥ 0,   λ ≥ 0,   λ·(g0 + J δq + C λ) = 0,   Gᵀ λ + Q(q) = 0,

where G maps each contact force (along minus the vertex's surface normal, at the
vertex: the force the layer carries to the tibia) to the unknowns — J differs from G
where the femoral surface is not parallel to the layer — and the last row is the
equilibrium of the tibia's free DOFs under the external load, gravity and ligaments Q
(generalised forces, N and N·mm; Q's own change with the pose, ∂Q/∂q, joins that row
as + ∂Q/∂q·δq when given). For an active set A the equalities are one dense solve;
vertices that pull are released and those that penetrate are added until A stops
changing (Hintermüller-Ito-Kunisch). The outer loop re-linearises g0, J and G at the
new pose (rotations are finite) until the pose stops moving: the
equilibrium is exact, with no penalty and no tolerance on penetration beyond round-off.

The same solve serves a single compartment pushed along one direction with a given
force (``mode = "compartment"``: one DOF, the translation along the load) and the whole
joint (``mode = "joint"``: the scene's free DOFs, both compartments at once, so the FE
finds its own medial/lateral split).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from fecheck.errors import FecheckError
from fecheck.fe.contact import active_set, condensed_compliance, factorize
from fecheck.fe.solid import LayerSolid

POSE_TOL = 1e-9
"""The outer loop stops when the pose step is below this (mm, and rad × 100 mm)."""


@dataclass(frozen=True, eq=False)
class ContactLayer:
    """One layer (in the tibia's frame) with its indenter (in the world) and the surface
    vertices that may touch (indices into the layer's surface)."""

    name: str
    solid: LayerSolid
    indenter: object
    candidates: np.ndarray


@dataclass(frozen=True, eq=False)
class LayerContact:
    """The contact state of one layer at the solution.

    force_N : (s,) contact force at every surface vertex (0 off contact), N
    gap_mm : (s,) final gap along the normal (≥ 0 up to round-off; FAR where the ray misses)
    u : the layer's kept-dof displacements, mm
    """

    name: str
    force_N: np.ndarray
    gap_mm: np.ndarray
    active: np.ndarray
    u: np.ndarray


@dataclass(frozen=True, eq=False)
class JointSolution:
    """Pose q (5,), per-layer contact, iterations (outer, active-set) and timing (s)."""

    q: np.ndarray
    layers: list[LayerContact]
    outer_iterations: int
    active_set_iterations: int
    timing_s: dict


class _Compliance:
    """The factorized stiffness of one solid and its normal compliance at the candidates
    of the layers it carries: one layer, or the compartments of one tibial solid (their
    `LayerSolid`s share the stiffness matrix), coupled through it."""

    def __init__(self, layers: Sequence[ContactLayer], solver: str, block: int = 256):
        self.layers = layers
        rows = sp.vstack([lay.solid.normal_rows[lay.candidates] for lay in layers]).tocsr()
        self.rows = rows
        K = layers[0].solid.K
        if solver == "cholmod":
            C, self.solve = condensed_compliance(
                K, np.concatenate([lay.solid.vertex_dofs[lay.candidates] for lay in layers]),
                np.concatenate([lay.solid.normals[lay.candidates] for lay in layers]))
        else:
            self.solve = factorize(K, solver)
            m = rows.shape[0]
            C = np.empty((m, m))
            rhs_all = rows.T.tocsc()
            for start in range(0, m, block):
                stop = min(start + block, m)
                C[:, start:stop] = rows @ self.solve(rhs_all[:, start:stop].toarray())
        self.C = 0.5 * (C + C.T)


def _shared_solids(layers: Sequence[ContactLayer]) -> tuple[list[ContactLayer], list[list[int]]]:
    """The layers grouped by the stiffness they share (the compartments of one tibial
    solid), each candidate vertex whose dofs an earlier layer of its group already holds
    left out (a vertex on the seam between two compartments' articular faces)."""
    groups: dict[int, list[int]] = {}
    for i, layer in enumerate(layers):
        groups.setdefault(id(layer.solid.K), []).append(i)
    out = list(layers)
    for members in groups.values():
        seen = np.zeros(0, dtype=np.int64)
        for i in members:
            lay = out[i]
            first = lay.solid.vertex_dofs[lay.candidates, 0]
            keep = ~np.isin(first, seen)
            seen = np.concatenate([seen, first[keep]])
            if not keep.all():
                out[i] = replace(lay, candidates=lay.candidates[keep])
    return out, list(groups.values())


class JointContact:
    """Layers ready to solve: each factorized and condensed onto its contact candidates
    once (the costly part), then `solve` for any load in milliseconds, so that answers
    are smooth in the load (the same mesh and the same compliance for every load)."""

    def __init__(self, layers: Sequence[ContactLayer], *, solver: str = "cholmod",
                 log: Callable[[str], None] = lambda s: None):
        t0 = time.perf_counter()
        self.layers, self.groups = _shared_solids(layers)
        sizes = [len(layer.candidates) for layer in self.layers]
        self.offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(int)
        self.C = np.zeros((self.offsets[-1], self.offsets[-1]))
        self.compliance, self.group_rows = [], []
        for members in self.groups:
            group = [self.layers[i] for i in members]
            log(f"FE {' + '.join(lay.name for lay in group)}: factorizing "
                f"{group[0].solid.n_dofs} dofs, condensing onto "
                f"{sum(len(lay.candidates) for lay in group)} contact candidates")
            self.compliance.append(_Compliance(group, solver))
            idx = np.concatenate([np.arange(self.offsets[i], self.offsets[i + 1])
                                  for i in members])
            self.group_rows.append(idx)
            self.C[np.ix_(idx, idx)] = self.compliance[-1].C
        self.seconds = time.perf_counter() - t0
        self.log = log

    def solve(self, pose: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
              basis: Callable[[np.ndarray], np.ndarray],
              load: Callable[[np.ndarray], np.ndarray], q0: np.ndarray, *,
              stiffness: Callable[[np.ndarray], np.ndarray] | None = None,
              max_outer: int = 30, max_active: int = 200) -> JointSolution:
        """Solve the contact under load control (module docstring).

        Parameters
        ----------
        pose : q → (R, t), the tibia's rotation and translation (mm) at the unknowns q
        basis : q → B (6, k), the tibia's twist (v, ω about the world origin) per unit
            step of each unknown (mm, rad)
        load : q → Q (k,), generalised external force on the unknowns (N, N·mm): load,
            gravity; positive along the unknowns
        q0 : (k,) start, e.g. the EF equilibrium
        stiffness : q → ∂Q/∂q (k, k) (ligament springs, a load that turns with the
            tibia); None: the load does not change with the pose
        """
        t0 = time.perf_counter()
        q = np.asarray(q0, dtype=float).copy()
        active = None
        inner = 0
        for outer in range(1, max_outer + 1):
            g0, J, G = _linearised_gaps(self.layers, pose, basis, q)
            if active is None:
                active = g0 <= np.sort(g0)[min(len(g0) - 1, 3)]
            dQ = np.zeros((len(q), len(q))) if stiffness is None else stiffness(q)
            lam, dq, active, it = active_set(self.C, g0, J, G, load(q), dQ, active,
                                             max_active, "refine the layer under the "
                                             "contact or check the load")
            inner += it
            q = q + dq
            self.log(f"FE pose update {outer}: {int(active.sum())} vertices in contact, "
                     f"step {np.abs(dq).max():.2e}")
            scale = np.where(np.abs(basis(q)[3:]).sum(axis=0) > 0, 100.0, 1.0)   # rad → mm
            if float(np.max(np.abs(dq) * scale)) <= POSE_TOL:
                break
        else:
            raise FecheckError(f"the FE joint equilibrium did not settle in {max_outer} pose "
                               "updates; check the load and the free DOFs")
        g0, _, _ = _linearised_gaps(self.layers, pose, basis, q)
        u = {}
        for members, c, idx in zip(self.groups, self.compliance, self.group_rows,
                                   strict=True):
            u.update(dict.fromkeys(members, c.solve(-(c.rows.T @ lam[idx]))))
        out = []
        for i, layer in enumerate(self.layers):
            block = slice(self.offsets[i], self.offsets[i + 1])
            s = layer.solid.surface.n_points
            force = np.zeros(s)
            force[layer.candidates] = lam[block]
            gap = np.full(s, np.inf)
            gap[layer.candidates] = g0[block] + self.C[block] @ lam
            out.append(LayerContact(layer.name, force, gap, force > 0, u[i]))
        timing = {"condense": self.seconds, "contact": time.perf_counter() - t0}
        return JointSolution(q, out, outer, inner, timing)


def _linearised_gaps(layers: Sequence[ContactLayer], pose, basis, q: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """At pose q, for the candidates of all layers: gaps g0 (m,), J (m, k) = ∂g0/∂q, and
    G (m, k), the generalised force on the unknowns of a unit contact force at each
    candidate (acting on the tibia along minus its surface normal, at the vertex)."""
    rot, t = pose(q)
    b = basis(q)
    gaps, rows, forces = [], [], []
    for layer in layers:
        pts = layer.solid.surface.points[layer.candidates] @ rot.T + t
        nrm = layer.solid.normals[layer.candidates] @ rot.T
        g = layer.indenter.gap(pts, nrm)
        gaps.append(g.gap_mm)
        rows.append(g.twist @ b)
        forces.append(-np.hstack([nrm, np.cross(pts, nrm)]) @ b)
    return np.concatenate(gaps), np.concatenate(rows), np.concatenate(forces)
