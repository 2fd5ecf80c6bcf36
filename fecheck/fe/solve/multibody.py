"""Deformable solids in frictionless contact with each other and with one rigid indenter
under load control: the core of the FE with menisci.

The bodies (`fecheck.fe.contact.condense.ElasticBody`) and their contact pairs
(`fecheck.fe.contact.condense.Pair`: slave nodes of one body, with unit normals n toward
the master and reference gaps g0, mm, against the rigid indenter or a master body hit at
barycentric weights w, `ray_pairs`) are condensed onto the pairs' gaps as every FE
contact solve condenses them (`fecheck.fe.contact.condense.CondensedBodies`: the
compliance C). What this driver adds is its rigid unknowns: the indenter moves by δ along
its axis a (pushed with the load F; it may also turn by small angles about given axes
under given moments, `Condensed`), and a body that floats along some directions (a
meniscus between the femur and the tibia) keeps those rigid translations t_k as unknowns:
one dof per direction is anchored to make K positive definite, and the translation
amplitude joins the problem with the body's equilibrium along it (exact: the contact
forces that solve the problem are self-equilibrated along t_k, so the anchor carries
nothing). Every gap reads

    g = g0 + (Σ_a w_a u_a − u_s)·n + δ a·n (indenter pairs) = g0 + J δq + C λ,

δq = (δ, turns, t); a body `carried` by the indenter (bonded to it) adds the indenter's
motion to its own, so a pair it masters reads δ a·n as an indenter pair does, and the
forces on it load the indenter. The mixed complementarity problem g ≥ 0, λ ≥ 0, λ·g = 0
with the equilibria Jᵀλ = (−F, 0, ...) is solved by the outer loop every FE solve with
rigid unknowns runs (`fecheck.fe.solve.drive`: the primal-dual active set of
`fecheck.fe.contact.active_set` at each linearisation, no penalty). With the rigid gaps
given as a function of the indenter's travel and turns (the femur's surface over the
menisci), that loop evaluates them exactly at each update, so the turns are finite; J stays
the reference configuration's. The bodies' displacements are small (pairs fixed).
Units: mm, N, MPa.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from fecheck.errors import FecheckError
from fecheck.fe.contact.condense import CondensedBodies, ElasticBody, Pair, check_pairs
from fecheck.fe.solve.drive import Linearised, equilibrium

MOVE_TOL_MM = 1e-10
"""The outer loop stops when the indenter's and the bodies' step is below this, mm (a turn
times the lever arm `Condensed.solve` is given)."""
MAX_MOVES = 50
"""Most re-linearisations of one `Condensed.solve`."""


@dataclass(frozen=True)
class Indenter:
    """The rigid indenter: unit `axis` (d,) it moves along and is pushed along with
    `load_N` (N, > 0)."""

    axis: np.ndarray
    load_N: float


@dataclass(frozen=True, eq=False)
class PairContact:
    """One pair at the solution: force_N (m,) N, gap_mm (m,) mm, active (m,)."""

    force_N: np.ndarray
    gap_mm: np.ndarray
    active: np.ndarray


@dataclass(frozen=True, eq=False)
class MultibodySolution:
    """pairs: name → PairContact; approach_mm: the indenter's travel along its axis;
    translations: body → (k,) rigid translations (mm); u: body → kept-dof elastic
    displacements (mm, without the translations); iterations (active-set, summed);
    timing_s; turns_rad (r,) the indenter's turns about its `Condensed` turn axes (rad);
    updates: the outer loop's re-linearisations."""

    pairs: dict[str, PairContact]
    approach_mm: float
    translations: dict[str, np.ndarray]
    u: dict[str, np.ndarray]
    iterations: int
    timing_s: dict
    turns_rad: np.ndarray = field(default_factory=lambda: np.zeros(0))
    updates: int = 1

    @property
    def max_penetration_mm(self) -> float:
        """The largest penetration over every pair, mm (≥ 0)."""
        return float(max(0.0, -min(p.gap_mm.min() for p in self.pairs.values())))


def _check(bodies: Sequence[ElasticBody], pairs: Sequence[Pair], indenter: Indenter) -> dict:
    if not (np.isfinite(indenter.load_N) and indenter.load_N > 0):
        raise FecheckError(f"the indenter's load must be a positive number of N, got "
                           f"{indenter.load_N}")
    return check_pairs(bodies, pairs)


def solve_multibody(bodies: Sequence[ElasticBody], pairs: Sequence[Pair], indenter: Indenter, *,
                    solver: str = "cholmod", max_iter: int = 200, block: int = 512
                    ) -> MultibodySolution:
    """Solve the frictionless contact of `bodies` through `pairs` under the indenter's
    load (module docstring). Returns the forces, gaps and displacements; `FecheckError`
    when the active set does not settle or a stiffness is singular."""
    condensed = Condensed(bodies, pairs, indenter.axis, solver=solver, block=block)
    return condensed.solve(np.concatenate([p.gap0_mm for p in pairs]), indenter.load_N,
                           max_active=max_iter)


class Condensed:
    """`bodies` condensed onto the gaps of `pairs` (the costly part: one factorization and
    one block solve per body), ready to `solve` for any rigid gaps and load with the
    same pairing.

    `turns`: (unit axis (3,), centre (3,) mm) about which the indenter may also turn by a
    small angle θ, balanced by the moment `solve` is given: an indenter pair's gap then
    changes by θ a·((x − c) × n) at its slave point x (`Pair.points`, required), and its
    forces' moment about the axis, Σ λ a·((x − c) × n), balances the given one.

    `reuse`: an earlier condensation of the same bodies: a body with the same stiffness
    (the same K object) whose gaps read the same node directions, or node dofs among those
    it condensed (a master's weights moved: re-pairing), takes its compliance from there
    instead of a new factorization; a master whose dofs are not among them is condensed on
    the union of both, so that the next re-pairing is likely to find them; a body whose K
    is another object (rebuilt) is condensed afresh."""

    def __init__(self, bodies: Sequence[ElasticBody], pairs: Sequence[Pair], axis: np.ndarray, *,
                 solver: str = "cholmod", block: int = 512,
                 turns: Sequence[tuple[np.ndarray, np.ndarray]] = (),
                 reuse: Condensed | None = None):
        names = _check(bodies, pairs, Indenter(np.asarray(axis, dtype=float), 1.0))
        self.turns = [(np.asarray(a, dtype=float), np.asarray(c, dtype=float))
                      for a, c in turns]
        moved = [p for p in pairs if p.master is None or names[p.slave].carried
                 or names[p.master].carried]
        if turns and any(p.points is None for p in moved):
            raise FecheckError("an indenter that turns needs the slave points (Pair.points) "
                               "of each pair it or a body it carries is in, for the lever "
                               "arms")
        t0 = time.perf_counter()
        self.core = CondensedBodies(bodies, pairs, solver=solver, block=block,
                                    reuse=None if reuse is None else reuse.core)
        self.pairs, self.bodies, self.offsets = self.core.pairs, self.core.bodies, self.core.offsets
        self.unknowns = ([(None, np.asarray(axis, dtype=float))]
                         + [(None, a) for a, _ in self.turns]
                         + [(b.name, t) for b in bodies for t in b.translations])
        self.J = self._gap_map(names, int(self.offsets[-1]))
        self.C = self.core.C
        self.kept = self.core.kept
        self.seconds = time.perf_counter() - t0

    def _gap_map(self, names: dict, m: int) -> np.ndarray:
        """J (m, unknowns): the gaps' change with the indenter's travel and turns and the
        bodies' translations."""
        unknowns = self.unknowns
        J = np.zeros((m, len(unknowns)))
        for p, start in zip(self.pairs, self.offsets[:-1], strict=True):
            row = np.arange(start, start + len(p.nodes))
            for k in (k for k, (who, _) in enumerate(unknowns) if who == p.slave):
                J[row, k] -= p.normals @ unknowns[k][1]
            if names[p.slave].carried:
                self._indenter_columns(J, row, p, -1.0)
            if p.master is None:
                self._indenter_columns(J, row, p, 1.0)
                continue
            for k in (k for k, (who, _) in enumerate(unknowns) if who == p.master):
                J[row, k] += p.weights.sum(axis=1) * (p.normals @ unknowns[k][1])
            if names[p.master].carried:
                self._indenter_columns(J, row, p, p.weights.sum(axis=1))
        return J

    def _indenter_columns(self, J: np.ndarray, row: np.ndarray, p: Pair, sign) -> None:
        """Add to the gap rows `row` of pair `p` the indenter's travel and turns, `sign`
        +1 (per row) where the indenter or a body it carries is the master, -1 the slave:
        a turn θ about (a, c) moves the contact point x by θ a × (x − c), and
        (a × (x − c))·n = a·((x − c) × n) is the same at the slave point and at the point
        its ray hits (they differ along n)."""
        J[row, 0] += sign * (p.normals @ self.unknowns[0][1])
        for i, (a, c) in enumerate(self.turns, start=1):
            J[row, i] += sign * (np.cross(p.points - c, p.normals) @ a)

    def displacements(self, lam: np.ndarray) -> dict[str, np.ndarray]:
        """Each body's kept-dof displacements (mm) under the contact forces `lam` (m,) N."""
        return self.core.displacements(lam)

    def solve(self, g0: np.ndarray | Callable[[np.ndarray], np.ndarray], load_N: float, *,
              moments_Nmm: np.ndarray | None = None, start: np.ndarray | None = None,
              arm_mm: float = 1.0, max_outer: int = MAX_MOVES, max_active: int = 200
              ) -> MultibodySolution:
        """The contact under the indenter's load `load_N` (N, > 0) and the moment
        `moments_Nmm` (r,) on it about each turn axis (N·mm, zero when None), by the outer
        loop every FE solve with rigid unknowns runs (`fecheck.fe.solve.drive`).

        g0 : the pairs' rigid gaps, rows in order (mm): (m,) with the indenter at rest (they
            change by J with its travel and turns), or a function of its travel and turns
            (1 + r,) mm, rad, evaluated exactly at each update (turns are then finite)
        start : (1 + r,) the indenter's travel and turns to start from (zeros when None)
        arm_mm : the lever arm that turns a turn into a step (mm), for the loop's tolerance
        """
        if not (np.isfinite(load_N) and load_N > 0):
            raise FecheckError(f"the indenter's load must be a positive number of N, got "
                               f"{load_N}")
        t0 = time.perf_counter()
        r = len(self.turns)
        Q = np.zeros(len(self.unknowns))
        Q[0] = load_N
        if moments_Nmm is not None:
            moments = np.asarray(moments_Nmm, dtype=float)
            if moments.shape != (r,) or not np.all(np.isfinite(moments)):
                raise FecheckError(f"give one finite moment (N mm) per turn axis ({r}), got "
                                   f"{moments_Nmm}")
            Q[1:1 + r] = moments
        moved, slid = self.J[:, :1 + r], self.J[:, 1 + r:]
        rigid = g0 if callable(g0) else (lambda x: g0 + moved @ x)
        zero = np.zeros((len(Q), len(Q)))

        def linearise(q: np.ndarray, lam: np.ndarray | None) -> Linearised:
            return Linearised(rigid(q[:1 + r]) + slid @ q[1 + r:], self.J, self.J, self.C, Q,
                              zero)

        q0 = np.zeros(len(Q))
        if start is not None:
            q0[:1 + r] = start
        driven = equilibrium(
            linearise, lambda lin, active: self._first_set(lin.g0, active), q0,
            scale=np.r_[1.0, np.full(r, arm_mm), np.ones(slid.shape[1])],
            tolerance=MOVE_TOL_MM, max_outer=max_outer, max_active=max_active,
            hint="refine the meshes at the contact or check the load",
            failure=f"the rigid indenter (the femur) and the floating bodies do not settle "
                    f"in {max_outer} re-linearisations; check the load and the meshes")
        u = self.displacements(driven.lam)
        off, q, gap = self.offsets, driven.q, driven.gap_mm
        out = {p.name: PairContact(driven.lam[a:b], gap[a:b], driven.active[a:b])
               for p, a, b in zip(self.pairs, off[:-1], off[1:], strict=True)}
        translations = {b.name: q[[k for k, (who, _) in enumerate(self.unknowns)
                                   if who == b.name]] for b in self.bodies}
        return MultibodySolution(out, float(q[0]), translations, u, driven.inner,
                                 {"condense": self.seconds,
                                  "active_set": time.perf_counter() - t0},
                                 q[1:1 + r].copy(), driven.outer)

    def _first_set(self, g0: np.ndarray, start: np.ndarray | None) -> np.ndarray:
        """The first active set: the closest gaps of `g0` (m,) mm, the set `start` (m,)
        (the last solve's; None: none), and for each unknown no contact of which holds it
        the closest gap among those it moves."""
        first = (g0 <= g0.min() + 1e-9) | (False if start is None else start)
        for k in range(len(self.unknowns)):
            rows = self.J[:, k] != 0.0
            if rows.any() and not (first & rows).any():
                first[np.argmin(np.where(rows, g0, np.inf))] = True
        return first


def ray_pairs(points: np.ndarray, normals: np.ndarray, master_points: np.ndarray,
              master_faces: np.ndarray, tolerance_mm: float
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where each ray points + s·normals (m, 3) meets the master surface (triangles
    `master_faces` on `master_points`): (faces (m,), barycentric weights (m, 3), gaps s
    (m,) mm; face -1 and gap inf where it misses). A ray that passes outside the surface's
    rim by at most `tolerance_mm` (a slave vertex on a circle the master's chords cut
    inside) takes the nearest face, its weights clipped to it."""
    from scipy.spatial import cKDTree

    from geometry.distance import ray_hits
    from geometry.mesh import TriMesh

    surface = TriMesh(master_points, master_faces)
    gap, face = ray_hits(points, normals, surface)
    miss = face < 0
    if miss.any():
        centroids = master_points[master_faces].mean(axis=1)
        _, near = cKDTree(centroids).query(points[miss], k=min(6, len(centroids)))
        near = near.reshape(int(miss.sum()), -1)
        best_d = np.full(len(near), np.inf)
        for j in range(near.shape[1]):
            f = near[:, j]
            w = _barycentric(points[miss], master_points[master_faces[f]], normals[miss])
            w = np.clip(w, 0.0, None)
            w /= w.sum(axis=1, keepdims=True)
            x = np.einsum("mk,mkc->mc", w, master_points[master_faces[f]])
            s = np.einsum("mc,mc->m", x - points[miss], normals[miss])
            off = np.linalg.norm(x - points[miss] - s[:, None] * normals[miss], axis=1)
            better = (off <= tolerance_mm) & (off < best_d)
            idx = np.flatnonzero(miss)[better]
            face[idx], gap[idx], best_d[better] = f[better], s[better], off[better]
    weights = np.zeros((len(points), 3))
    hit = face >= 0
    weights[hit] = _barycentric(points[hit] + gap[hit, None] * normals[hit],
                                master_points[master_faces[face[hit]]], normals[hit])
    weights[hit] = np.clip(weights[hit], 0.0, None)
    weights[hit] /= weights[hit].sum(axis=1, keepdims=True)
    return face, weights, gap


def _barycentric(x: np.ndarray, tri: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """(m, 3) barycentric weights of x (m, 3) projected along `normals` onto the planes of
    triangles tri (m, 3, 3)."""
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    d = x - tri[:, 0]
    n = normals
    det = np.einsum("mc,mc->m", n, np.cross(e1, e2))
    b1 = np.einsum("mc,mc->m", n, np.cross(d, e2)) / det
    b2 = np.einsum("mc,mc->m", n, np.cross(e1, d)) / det
    return np.column_stack([1.0 - b1 - b2, b1, b2])
