"""Load-controlled frictionless contact of rigid indenters on elastic layers, with the
rigid bodies' DOFs as unknowns of the same problem.

Each layer (one per compartment) is bonded to a rigid body (the tibia, the patella: any
number, each named by its frame, `ContactLayer.body`) and pressed by its fixed rigid
indenter (the femoral surface). The unknowns q span the free DOFs of all the bodies: at q
each body has its pose X_WB and its twist basis B_B (6, k) (zero columns for the other
bodies' unknowns), and a layer's gaps and forces reach q through its own body's. At a pose q
the gap of layer vertex i along its
normal is g_i = g0_i(q) + J_i·δq + (C λ)_i, where C = N K⁻¹ Nᵀ is the layer's normal
compliance at the candidate vertices (one sparse factorization and one block solve per
layer, reused for every pose and load) and J_i = ∂g0_i/∂q. The contact forces λ ≥ 0 (N,
acting along −n_i on the layer) and the pose step δq solve the mixed complementarity
problem

    g0 + J δq + C λ ≥ 0,   λ ≥ 0,   λ·(g0 + J δq + C λ) = 0,   Gᵀ λ + Q(q) = 0,

where G maps each contact force (along minus the vertex's surface normal, at the
vertex: the force the layer carries to its body) to the unknowns — J differs from G
where the femoral surface is not parallel to the layer — and the last row is the
equilibrium of the bodies' free DOFs under the external load, gravity, ligaments and
muscles Q (generalised forces, N and N·mm; Q's own change with the pose, ∂Q/∂q, joins that row
as + ∂Q/∂q·δq when given). For an active set A the equalities are one dense solve;
vertices that pull are released and those that penetrate are added until A stops
changing (Hintermüller-Ito-Kunisch). The outer loop (`fecheck.fe.solve.drive`, the one
every FE solve with rigid unknowns runs) re-linearises g0, J and G at the
new pose (rotations are finite) until the pose stops moving: the
equilibrium is exact, with no penalty and no tolerance on penetration beyond round-off.
The equilibrium row's tangent carries, besides ∂Q/∂q, the change of the contact forces'
generalised force with the pose at the last forces, ∂(G(q)ᵀλ)/∂q (the forces turn and
move with the bodies; central differences of G, which needs no contact query): without it
the outer loop is a fixed-point iteration whose rate is the ratio of that term to the
joint's stiffness, slow (halving the step each update) or divergent where a free
rotation is soft, as the flexed knee's internal rotation is under a large axial load.

Two deformable layers (``fe.cartilage = "two-layer"``): the femoral surface is a layer of
its own (world frame, bonded to the femoral bone, `FemoralLayer`). Contact is
node-to-surface: tibial candidate i's ray along n_i hits a femoral face at barycentric
weights w; the femoral layer takes the force λ_i along +n_i there (the pair load
Pᵀλ, P (m, 3 m_f) with row i = w_a n_iᵀ on the dofs of the face's vertices a), and the gap
gains the femoral layer's give along n_i, (P C_f Pᵀ λ)_i, where C_f = (K_f⁻¹) at the
femoral candidate vertices in three dofs (one factorization, `nodal_compliance`). The
pairing P is formed again at every pose update (C_f is not), so the contact at the
solution is paired at the solution's pose. The femoral give is read along the tibial
normal n_i; the rigid part of the gap (g0, J) along the ray as before.

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

from fecheck.errors import FecheckError
from fecheck.fe.bodies.indenter import MeshIndenter, SphereIndenter
from fecheck.fe.bodies.pose import FramePose
from fecheck.fe.bodies.solid import LayerSolid
from fecheck.fe.contact.condense import CondensedBodies, ElasticBody, Pair
from fecheck.fe.contact.gap import surface_give
from fecheck.fe.solve.drive import Linearised, equilibrium

POSE_TOL = 1e-9
"""The outer loop stops when the pose step is below this (mm, and rad × 100 mm)."""

MAX_POSE_STEP = 5.0
"""The longest pose update taken (mm, and rad × 100 mm): a longer one is shortened along its
direction (a trust region). Where a free rotation is nearly unrestrained the linearised
step can run off by tens of mm (measured: 21 mm at the full-size knee's second update at 20°
under 800 N along the tibial axis), into poses whose contact sets no update recovers; a
limit of 1 kept the decimated knee at 26° from settling in 30 updates (its rotation steps
are up to 0.05 rad)."""


@dataclass(frozen=True, eq=False)
class FemoralLayer:
    """A deformable femoral layer (world frame, bonded to the femoral bone): its solid,
    whose surface the tibial layers it presses hit, and the surface vertices condensed in
    three dofs (the vertices the tibial candidates' rays may hit)."""

    name: str
    solid: LayerSolid
    candidates: np.ndarray


@dataclass(frozen=True, eq=False)
class ContactLayer:
    """One layer (in its rigid body's frame) with its indenter (in the world) and the
    surface vertices that may touch (indices into the layer's surface); with `femur` the
    indenter is that deformable layer's surface (a `MeshIndenter` of it); `body`: the
    frame name of the rigid body that carries it (`FramePose.body`: "T" the tibia, "P"
    the patella)."""

    name: str
    solid: LayerSolid
    indenter: SphereIndenter | MeshIndenter
    candidates: np.ndarray
    femur: FemoralLayer | None = None
    body: str = "T"


@dataclass(frozen=True, eq=False)
class LayerContact:
    """The contact state of one layer at the solution.

    force_N : (s,) contact force at every surface vertex (0 off contact), N
    gap_mm : (s,) final gap along the normal (≥ 0 up to round-off; FAR where the ray misses)
    u : the layer's kept-dof displacements, mm
    femur, femoral_u : the deformable femoral layer it presses and that layer's kept-dof
        displacements (mm), or None (a rigid femoral surface)
    """

    name: str
    force_N: np.ndarray
    gap_mm: np.ndarray
    active: np.ndarray
    u: np.ndarray
    femur: FemoralLayer | None = None
    femoral_u: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class JointSolution:
    """The unknowns q (k,), per-layer contact, iterations (outer, active-set) and timing (s)."""

    q: np.ndarray
    layers: list[LayerContact]
    outer_iterations: int
    active_set_iterations: int
    timing_s: dict


def femoral_shift(femur: FemoralLayer, u: np.ndarray, face: np.ndarray, weights: np.ndarray,
                  normals: np.ndarray) -> np.ndarray:
    """(m,) the give of the femoral layer (kept-dof displacements `u`, mm) at the points
    rays along world `normals` hit (faces `face`, -1 a miss, barycentric `weights`),
    along those normals, mm: what it adds to each gap."""
    disp = u[femur.solid.vertex_dofs]                                     # (s_f, 3)
    give = surface_give(disp[femur.solid.surface.faces[np.maximum(face, 0)]], weights,
                        normals)
    return np.where(face >= 0, give, 0.0)


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
        self.layers, groups = _shared_solids(layers)
        sizes = [len(layer.candidates) for layer in self.layers]
        self.offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(int)
        self.carrier: dict[int, str] = {}
        self.nodes = np.zeros(len(self.layers), dtype=int)
        bodies = []
        for members in groups:
            group = [self.layers[i] for i in members]
            name = " + ".join(lay.name for lay in group)
            starts = np.cumsum([0] + [lay.solid.surface.n_points for lay in group[:-1]])
            for i, start in zip(members, starts, strict=True):
                self.carrier[i], self.nodes[i] = name, start
            bodies.append(ElasticBody(name, group[0].solid.K,
                               np.concatenate([lay.solid.vertex_dofs for lay in group])))
        femurs = {id(lay.femur): lay.femur for lay in self.layers if lay.femur is not None}
        self.femurs = list(femurs.values())
        self.condensed_nodes = {}
        for f in self.femurs:
            self.condensed_nodes[f.name] = np.zeros(f.solid.surface.n_points, dtype=bool)
            self.condensed_nodes[f.name][f.candidates] = True
        self.bodies = bodies + [ElasticBody(f.name, f.solid.K, f.solid.vertex_dofs)
                                for f in self.femurs]
        self.solver = solver
        self.base = CondensedBodies(
            self.bodies, [self._pair(i, None)[0] for i in range(len(self.layers))],
            solver=solver, log=log,
            held={f.name: f.solid.vertex_dofs[f.candidates].ravel() for f in self.femurs})
        self.C = self.base.C
        self.seconds = time.perf_counter() - t0
        self.log = log

    def _pair(self, i: int, hit: tuple | None) -> tuple[Pair, np.ndarray]:
        """Layer i's candidates as the slave of a pair (its body's frame): against the rigid
        indenter (`hit` None) or, with `hit` = (faces, weights, world normals) of their
        rays, against its deformable femoral layer at the faces the rays hit (a row whose
        face has a vertex outside the femoral candidates, or that misses, reads no femoral
        give: weight 0); and the rows whose ray hits a face outside the femoral candidates
        (unpaired)."""
        layer = self.layers[i]
        cand = layer.candidates
        common = {"name": layer.name, "slave": self.carrier[i], "nodes": cand + self.nodes[i],
                  "normals": layer.solid.normals[cand], "gap0_mm": np.zeros(len(cand))}
        if hit is None:
            return Pair(**common), np.zeros(len(cand), dtype=bool)
        face, weights, normals = hit
        femur = layer.femur
        nodes = femur.solid.surface.faces[np.maximum(face, 0)]
        inside = (face >= 0) & self.condensed_nodes[femur.name][nodes].all(axis=1)
        pair = Pair(**common, master=femur.name,
                    master_nodes=np.where(inside[:, None], nodes, femur.candidates[0]),
                    weights=np.where(inside[:, None], weights, 0.0), master_normals=normals)
        return pair, (face >= 0) & ~inside

    def solve(self, pose: Callable[[np.ndarray], FramePose],
              basis: Callable[[np.ndarray], np.ndarray],
              load: Callable[[np.ndarray], np.ndarray], q0: np.ndarray, *,
              stiffness: Callable[[np.ndarray], np.ndarray] | None = None,
              max_outer: int = 30, max_active: int = 200) -> JointSolution:
        """Solve the contact under load control (module docstring).

        Parameters
        ----------
        pose : q → X_WB, the pose in the world (the femur's frame) of the rigid body
            that carries the layers at the unknowns q (`fecheck.fe.bodies.pose.FramePose`), or
            a tuple of them, one per body (each layer takes the pose whose `body` frame
            is its `ContactLayer.body`)
        basis : q → B (6, k), the body's twist (v, ω about the world origin) per unit
            step of each unknown (mm, rad), or (n, 6, k), one per body of `pose`
        load : q → Q (k,), generalised external force on the unknowns (N, N·mm): load,
            gravity, ligaments, muscles; positive along the unknowns
        q0 : (k,) start, e.g. the EF equilibrium
        stiffness : q → ∂Q/∂q (k, k) (ligament springs, a load that turns with the
            tibia); None: the load does not change with the pose
        """
        t0 = time.perf_counter()
        k = len(np.asarray(q0))

        def linearise(q: np.ndarray, lam: np.ndarray | None) -> Linearised:
            g0, J, G, hits = _linearised_gaps(self.layers, pose, basis, q)
            dQ = np.zeros((k, k)) if stiffness is None else stiffness(q)
            if lam is not None:
                dQ = dQ + _force_stiffness(self.layers, pose, basis, q, lam)
            return Linearised(g0, J, G, self._paired(hits)[0], load(q), dQ)

        def log(outer: int, dq: np.ndarray, active: np.ndarray) -> None:
            self.log(f"FE pose update {outer}: {int(active.sum())} vertices in contact, "
                     f"step {np.abs(dq).max():.2e}")

        turns = np.abs(np.asarray(basis(q0))[..., 3:, :]).reshape(-1, k).sum(axis=0)
        driven = equilibrium(
            linearise, lambda lin, active: self._first_set(lin.g0) if active is None else active,
            q0, scale=np.where(turns > 0, 100.0, 1.0), tolerance=POSE_TOL,
            max_step=MAX_POSE_STEP, max_outer=max_outer, max_active=max_active,
            hint="refine the layer under the contact or check the load",
            failure=f"the FE joint equilibrium did not settle in {max_outer} pose updates; "
                    "check the load and the free DOFs", log=log)
        q, lam = driven.q, driven.lam
        g0, _, _, hits = _linearised_gaps(self.layers, pose, basis, q)
        C, condensed, unpaired = self._paired(hits)
        if np.any(unpaired & (lam > 0)):
            row = int(np.flatnonzero(unpaired & (lam > 0))[0])
            i = int(np.searchsorted(self.offsets, row, side="right")) - 1
            layer = self.layers[i]
            x, y, z = layer.solid.surface.points[layer.candidates[row - self.offsets[i]]]
            raise FecheckError(f"the {layer.name} tibial vertex at ({x:.1f}, {y:.1f}, {z:.1f}) "
                               "mm (tibia frame) touches the femoral layer outside its "
                               "condensed vertices; raise fe.candidate_gap_mm")
        u = condensed.displacements(lam)
        out = []
        for i, layer in enumerate(self.layers):
            block = slice(self.offsets[i], self.offsets[i + 1])
            s = layer.solid.surface.n_points
            force = np.zeros(s)
            force[layer.candidates] = lam[block]
            gap = np.full(s, np.inf)
            gap[layer.candidates] = g0[block] + C[block] @ lam
            out.append(LayerContact(layer.name, force, gap, force > 0, u[self.carrier[i]],
                                    layer.femur,
                                    None if layer.femur is None else u.get(layer.femur.name)))
        timing = {"condense": self.seconds, "contact": time.perf_counter() - t0}
        return JointSolution(q, out, driven.outer, driven.inner, timing)

    def _first_set(self, g0: np.ndarray) -> np.ndarray:
        """The first active set: the four smallest gaps, and each rigid body none of
        whose candidates is among them its own four smallest (a body with no contact has
        only its load and springs to balance it, a step that can run far off)."""
        active = g0 <= np.sort(g0)[min(len(g0) - 1, 3)]
        owner = np.repeat([lay.body for lay in self.layers], np.diff(self.offsets))
        for body in dict.fromkeys(owner):
            mine = owner == body
            if not active[mine].any():
                active |= mine & (g0 <= np.sort(g0[mine])[min(int(mine.sum()) - 1, 3)])
        return active

    def _paired(self, hits: list) -> tuple[np.ndarray, CondensedBodies, np.ndarray]:
        """The compliance at the candidates with the femoral layers' give at the faces the
        candidates' rays hit now (`hits`: per layer None or (face, weights, normals)),
        C + Σ P C_f Pᵀ (each femoral compliance C_f condensed once, in `__init__`); the
        condensation it comes from; the candidates whose face lies outside the condensed
        femoral vertices."""
        if not self.femurs:
            return self.C, self.base, np.zeros(self.offsets[-1], dtype=bool)
        pairs, unpaired = zip(*(self._pair(i, hits[i]) for i in range(len(self.layers))),
                              strict=True)
        condensed = CondensedBodies(self.bodies, pairs, solver=self.solver, reuse=self.base)
        return condensed.C, condensed, np.concatenate(unpaired)


def rigid_bodies(pose, basis, q: np.ndarray) -> dict[str, tuple[FramePose, np.ndarray]]:
    """{body frame name: (X_WB, B (6, k))} at the unknowns q, from `JointContact.solve`'s
    `pose` and `basis` (one body, or one per body)."""
    poses, bases = pose(q), np.asarray(basis(q), dtype=float)
    if isinstance(poses, FramePose):
        return {poses.body: (poses, bases)}
    return {X.body: (X, b) for X, b in zip(poses, bases, strict=True)}


def _carrier(bodies: dict[str, tuple[FramePose, np.ndarray]], layer: ContactLayer
             ) -> tuple[FramePose, np.ndarray]:
    """The pose and twist basis of the body that carries `layer` (a lone body carries
    every layer)."""
    if len(bodies) == 1:
        return next(iter(bodies.values()))
    return bodies[layer.body]


def _contact_forces(layers: Sequence[ContactLayer], pose, basis, q: np.ndarray) -> np.ndarray:
    """G (m, k) of `_linearised_gaps` alone (no contact query)."""
    bodies = rigid_bodies(pose, basis, q)
    out = []
    for layer in layers:
        X_WB, b = _carrier(bodies, layer)
        pts = X_WB.points(layer.solid.surface.points[layer.candidates])
        nrm = X_WB.vectors(layer.solid.normals[layer.candidates])
        out.append(-np.hstack([nrm, np.cross(pts, nrm)]) @ b)
    return np.concatenate(out)


FORCE_STEP = 1e-6
"""Central-difference step of `_force_stiffness` (mm, rad): G is smooth (rotations), so
the truncation error is of order 1e-12 of the entries and round-off about 1e-10."""


def _force_stiffness(layers: Sequence[ContactLayer], pose, basis, q: np.ndarray,
                     lam: np.ndarray) -> np.ndarray:
    """∂(G(q)ᵀλ)/∂q (k, k) at fixed contact forces λ (N), by central differences, N/mm and
    N·mm/rad."""
    cols = []
    for j in range(len(q)):
        h = np.zeros(len(q))
        h[j] = FORCE_STEP
        cols.append((_contact_forces(layers, pose, basis, q + h).T @ lam
                     - _contact_forces(layers, pose, basis, q - h).T @ lam) / (2 * FORCE_STEP))
    return np.column_stack(cols)


def _linearised_gaps(layers: Sequence[ContactLayer], pose, basis, q: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, list]:
    """At pose q, for the candidates of all layers: gaps g0 (m,), J (m, k) = ∂g0/∂q,
    G (m, k), the generalised force on the unknowns of a unit contact force at each
    candidate (acting on the layer's body along minus its surface normal, at the vertex),
    and per layer None or, for a layer pressed by a deformable femoral layer, the faces its
    candidates' rays hit, the barycentric weights and the world normals."""
    bodies = rigid_bodies(pose, basis, q)
    gaps, rows, hits = [], [], []
    for layer in layers:
        X_WB, b = _carrier(bodies, layer)
        pts = X_WB.points(layer.solid.surface.points[layer.candidates])
        nrm = X_WB.vectors(layer.solid.normals[layer.candidates])
        if layer.femur is None:
            g = layer.indenter.gap(pts, nrm)
            hits.append(None)
        else:
            g, face, weights = layer.indenter.hits(pts, nrm)
            hits.append((face, weights, nrm))
        gaps.append(g.gap_mm)
        rows.append(g.twist @ b)
    return (np.concatenate(gaps), np.concatenate(rows), _contact_forces(layers, pose, basis, q),
            hits)
