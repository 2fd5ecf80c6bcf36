"""Elastic bodies condensed onto the gaps of their contact pairs: the compliance every FE
contact solve with deformable bodies reads.

A `ElasticBody` is an assembled linear elastic solid reduced to its kept dofs (stiffness K,
N/mm, symmetric positive definite once its supports, symmetry planes and anchors are
removed) with, for each node, the kept dof of each displacement component (-1: a fixed
component, zero displacement). A `Pair` pairs slave nodes of one body (unit normals n
toward the master, in the slave's frame) with a rigid surface (no master) or with the
nodes of a master body its rays hit, at barycentric weights w (along the same normals
in the master's frame, `Pair.master_normals`, when the two bodies' frames differ). With
the contact force λ ≥ 0 (N) on each gap the slave takes −λ n and the master +λ Σ w n
(`fecheck.fe.contact.gap`), so the gaps' elastic part is C λ with

    C = Σ_bodies D_b K_b⁻¹ D_bᵀ,

D_b the gaps' map to body b's kept dofs. `CondensedBodies` factorizes each body once and
reads K_b⁻¹ on the dofs D_b touches from the factor's trailing block: along the normals
for a body that is only a slave at distinct, wholly kept nodes
(`fecheck.fe.contact.compliance.condensed_compliance`), on whole node triplets otherwise
(`nodal_compliance`), or by block solves with another solver (`block_compliance`). A
re-pairing (the masters' weights moved) reuses an earlier condensation of the same
bodies. Units: mm, N.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Hashable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from fecheck.errors import FecheckError
from fecheck.fe.contact.compliance import (
    block_compliance,
    condensed_compliance,
    factorize,
    nodal_compliance,
)
from fecheck.fe.contact.gap import kept_dofs, surface_entries


@dataclass(frozen=True, eq=False)
class ElasticBody:
    """An assembled solid: name, kept-dof stiffness K (N/mm), node_dofs (N, d) the kept
    dof of each node's displacement components (-1: fixed), translations (k, d) the unit
    rigid translations left free (anchored out of K); `carried`: bonded to the indenter
    (a cartilage layer on a rigid bone), so it moves and turns with it, its displacements
    are relative to it, and the contact forces on it load the indenter
    (`fecheck.fe.solve.multibody.Condensed`)."""

    name: str
    K: sp.spmatrix
    node_dofs: np.ndarray
    translations: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    carried: bool = False


@dataclass(frozen=True, eq=False)
class Pair:
    """Slave `nodes` (m,) of body `slave` with unit `normals` (m, d) toward the master (in
    the slave's frame) and reference gaps `gap0_mm` (m,); `master` None for a rigid
    surface, else a body hit at `master_nodes` (m, k) with `weights` (m, k) (a zero
    weight: the row does not read the master) along `master_normals` (m, d) (in the
    master's frame; None: `normals`); `points` (m, 3) the slave nodes' places (mm), the
    lever arms of an indenter pair when the indenter turns; `key` what the model that
    built the pair knows it by (its bodies and kind, typed), the solver does not read
    it."""

    name: str
    slave: str
    nodes: np.ndarray
    normals: np.ndarray
    gap0_mm: np.ndarray
    master: str | None = None
    master_nodes: np.ndarray | None = None
    weights: np.ndarray | None = None
    points: np.ndarray | None = None
    key: Hashable = None
    master_normals: np.ndarray | None = None

    @property
    def master_directions(self) -> np.ndarray:
        """The normals the master's displacements are read along (its frame)."""
        return self.normals if self.master_normals is None else self.master_normals


@dataclass(frozen=True, eq=False)
class Compliance:
    """A body's condensed compliance, kept for reuse (`CondensedBodies`): its dofs (the node
    dof triplets along `directions` (m, 3), or with `directions` None the dofs (k,) of
    (K⁻¹) on them), the block (mm/N), the solver of its K and that K (a body of the same
    name with another K, a layer rebuilt larger, is condensed afresh)."""

    dofs: np.ndarray
    block: np.ndarray
    solve: Callable[[np.ndarray], np.ndarray]
    directions: np.ndarray | None = None
    K: sp.spmatrix | None = None


def check_pairs(bodies: Sequence[ElasticBody], pairs: Sequence[Pair]) -> dict[str, ElasticBody]:
    """{name: body}; `FecheckError` for a pair naming an unknown body or with normals that
    are not unit vectors."""
    names = {b.name: b for b in bodies}
    for p in pairs:
        for who in (p.slave, p.master):
            if who is not None and who not in names:
                raise FecheckError(f"contact pair {p.name!r} names body {who!r}, which is "
                                   f"not among {sorted(names)}")
        for normals in (p.normals, p.master_directions):
            if not np.allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-9):
                raise FecheckError(f"contact pair {p.name!r}: the normals must be unit "
                                   "vectors")
    return names


class CondensedBodies:
    """`bodies` condensed onto the gaps of `pairs` (module docstring): `C` (m, m) mm/N over
    the pairs' rows in order (`offsets`), each body's gap map `D` and solver.

    `reuse`: an earlier condensation of the same bodies: a body with the same stiffness
    (the same K object) whose gaps read the same node directions, or node dofs among those
    it condensed, takes its compliance from there instead of a new factorization; a master
    whose dofs are not among them is condensed on the union of both, so that the next
    re-pairing is likely to find them; a body whose K is another object (rebuilt) is
    condensed afresh. `held`: {body: dofs (k,)} to condense a body on whole (nodal), in
    that order, even before a pair reads them (a master whose pairing changes with the
    pose: every later pairing inside them reuses it). `log` gets a line per factorization.
    """

    def __init__(self, bodies: Sequence[ElasticBody], pairs: Sequence[Pair], *,
                 solver: str = "cholmod", block: int = 512,
                 reuse: CondensedBodies | None = None,
                 held: Mapping[str, np.ndarray] | None = None,
                 log: Callable[[str], None] = lambda s: None):
        names = check_pairs(bodies, pairs)
        t0 = time.perf_counter()
        self.pairs, self.bodies = list(pairs), list(bodies)
        sizes = [len(p.nodes) for p in pairs]
        self.offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(int)
        m = int(self.offsets[-1])
        entries = self._entries(names)
        C = np.zeros((m, m))
        self.D: dict[str, sp.csr_matrix] = {}
        self.solves: dict[str, Callable[[np.ndarray], np.ndarray]] = {}
        self.kept: dict[str, Compliance] = {}
        before = reuse.kept if reuse is not None else {}
        held = held or {}
        for b in bodies:
            old = before.get(b.name)
            if old is not None and old.K is not b.K:     # rebuilt: nothing to reuse
                old = None
            if b.name in held and (old is None or old.directions is not None):
                log(f"FE {b.name}: factorizing {b.K.shape[0]} dofs, condensing "
                    f"{len(held[b.name]) // 3} vertices in 3 dofs")
                block_, solve = nodal_compliance(b.K, held[b.name])
                old = Compliance(np.asarray(held[b.name]), block_, solve, K=b.K)
                self.kept[b.name], self.solves[b.name] = old, solve
            if not entries[b.name]:
                continue
            r, c, v = (np.concatenate(x) for x in zip(*entries[b.name], strict=True))
            self.D[b.name] = D = sp.csr_matrix((v, (r, c)), shape=(m, b.K.shape[0]))
            normal = self._normal_gaps(b) if solver == "cholmod" else None
            if normal is not None:        # one direction per node: the normal compliance
                rows, dofs, directions = normal
                if (old is not None and old.directions is not None
                        and np.array_equal(old.dofs, dofs)
                        and np.array_equal(old.directions, directions)):
                    along, self.solves[b.name] = old.block, old.solve
                else:
                    log(f"FE {b.name}: factorizing {b.K.shape[0]} dofs, condensing onto "
                        f"{len(rows)} contact candidates")
                    along, self.solves[b.name] = condensed_compliance(b.K, dofs, directions)
                self.kept[b.name] = Compliance(dofs, along, self.solves[b.name], directions,
                                               b.K)
                C[np.ix_(rows, rows)] += along
                continue
            nodal = old is not None and old.directions is None
            if solver == "cholmod" or nodal:  # (K⁻¹) on the dofs the gaps read
                cols = np.unique(c)
                if nodal and np.isin(cols, old.dofs).all():
                    kept = old
                else:
                    union = np.union1d(old.dofs, cols) if nodal else cols
                    kept = Compliance(union, *nodal_compliance(b.K, union), K=b.K)
                self.kept[b.name], self.solves[b.name] = kept, kept.solve
                at = np.full(b.K.shape[0], -1)
                at[kept.dofs] = np.arange(len(kept.dofs))
                inverse = kept.block[np.ix_(at[cols], at[cols])]
                Dc = D[:, cols]
                C += (Dc @ (Dc @ inverse).T).T
                continue
            touched = np.unique(r)
            log(f"FE {b.name}: factorizing {b.K.shape[0]} dofs, condensing onto "
                f"{len(touched)} contact candidates")
            self.solves[b.name] = factorize(b.K, solver)
            C[np.ix_(touched, touched)] += block_compliance(D[touched], self.solves[b.name],
                                                            block)
        self.C = 0.5 * (C + C.T)
        self.seconds = time.perf_counter() - t0

    def _entries(self, names: dict[str, ElasticBody]) -> dict[str, list]:
        """Per body the (rows, columns, values) of the gaps' map to its kept dofs."""
        out: dict[str, list] = {name: [] for name in names}
        for p, start in zip(self.pairs, self.offsets[:-1], strict=True):
            row = np.arange(start, start + len(p.nodes))
            out[p.slave].append(surface_entries(
                row, p.nodes[:, None], -np.ones((len(row), 1)), p.normals,
                kept_dofs(names[p.slave].node_dofs)))
            if p.master is not None:
                out[p.master].append(surface_entries(
                    row, p.master_nodes, p.weights, p.master_directions,
                    kept_dofs(names[p.master].node_dofs)))
        return out

    def _normal_gaps(self, body: ElasticBody) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """(gap rows, node dof triplets, normals) when `body` is only ever a slave, at
        distinct nodes with all three dofs kept (each gap reads one node's normal
        displacement: `condensed_compliance` applies); else None."""
        mine = [(p, start) for p, start in zip(self.pairs, self.offsets[:-1], strict=True)
                if body.name in (p.slave, p.master)]
        if any(p.master == body.name for p, _ in mine):
            return None
        nodes = np.concatenate([p.nodes for p, _ in mine])
        dofs = body.node_dofs[nodes]
        if len(np.unique(nodes)) < len(nodes) or dofs.shape[1] != 3 or (dofs < 0).any():
            return None
        rows = np.concatenate([np.arange(start, start + len(p.nodes)) for p, start in mine])
        return rows, dofs, np.concatenate([p.normals for p, _ in mine])

    def displacements(self, lam: np.ndarray) -> dict[str, np.ndarray]:
        """Each body's kept-dof displacements (mm) under the contact forces `lam` (m,) N
        (the bodies no pair reads: none)."""
        u = {name: self.solves[name](self.D[name].T @ lam) for name in self.D}
        if not all(np.all(np.isfinite(x)) for x in u.values()):
            raise FecheckError("the FE contact solve produced NaN: a stiffness is singular")
        return u
