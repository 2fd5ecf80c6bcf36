"""Static equilibrium of rigid bodies by safeguarded block Newton-Raphson.

Each body's pose is x_world = R·X + t with generalised coordinates
q = (x, y, z, θx, θy, θz) (mm, rad; `BODY_DOFS`), R = Rx(θx)·Ry(θy)·Rz(θz), t = (x, y, z);
every coordinate is free (solved) or held at its start value (driven or fixed). A small
motion of a body is the twist ξ = (v, ω) about the world origin, δx = v + ω × x, and
ξ = B(q)·δq with B = [[I, t × a_x, t × a_y, t × a_z], [0, a_x, a_y, a_z]], a_x = e_x,
a_y = Rx e_y, a_z = Rx Ry e_z the rotation axes (world). Loads are wrenches W = (F, M),
M about the world origin (N, N·mm). The generalised force on body b is Q_b = B_bᵀ·W_b;
its exact tangent is dQ_b/dq_c = B_bᵀ·(dW_b/dξ_c)·B_c + δ_bc Σ_k (∂B_b/∂q_k)ᵀ·W_b e_kᵀ
(thesis §1.3, eq. 1.14, for one body).

The wrench comes in parts (`Part`): a load or a spring to the world acts on one body; a
contact interface or a spring between two bodies acts on both, with the tangent blocks of
both bodies' twists (`interface_part`). Constraints g = 0 (ligament rods) add
multipliers λ whose wrench is λ·w with w = -∂g/∂ξ (for a rod, λ is its tension, N).
Newton solves [Q + Σ λ_i Bᵀ w_i = 0, g = 0] for the stacked free coordinates of every
body with a backtracking line search on the residual norm; where the stiffness is
indefinite because the wrench's parts cancel (no constraints) it takes energy-descent
steps instead (`_descent_step`), so it reaches stable equilibria; a start without
contact (no stiffness along the load) is handled by a growing step along the unbalanced
load until contact is made. DOFs with no stiffness and no load are reported as a
`FecheckError` telling the scene to drive them.

The tibia under a fixed femur is the one body of the knee models: its q = (x, y, z, θy,
θz) (`fecheck.scene.constants.DOF_NAMES`) with θx driven; `pose`, `twist_basis` and
`geometric_tangent` are its 5-coordinate forms and `tibia_body` its `Body`.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field, replace

import numpy as np

from fecheck.errors import FecheckError
from fecheck.statics.frames import rot_x, rot_y, rot_z, skew

E_X = np.array([1.0, 0.0, 0.0])

BODY_DOFS = ("x", "y", "z", "flexion", "abduction", "internal")
"""A body's generalised coordinates q (6,): translations (mm), then θx, θy, θz (rad)."""

TIBIA_COORDINATES = (0, 1, 2, 4, 5)
"""Where the tibia's q = (x, y, z, θy, θz) sits in its body coordinates (θx driven)."""

BodyPose = tuple[np.ndarray, np.ndarray]
"""(R (3, 3), t (3,) mm): x_world = R·X + t."""

Part = tuple[tuple[int, ...], np.ndarray, np.ndarray]
"""(bodies, W (6k,), dW/dξ (6k, 6k)): one part of the wrench (a load, a spring, a contact
interface) on k bodies (indices into `Problem.bodies`), the wrenches on each stacked, and
their tangent for the stacked twists of those bodies."""

WrenchFn = Callable[[Sequence[BodyPose]], Sequence[Part]]
"""(pose of every body) → the parts of the wrench, summed per body here."""

ConstraintFn = Callable[[Sequence[BodyPose], Sequence[Part]],
                        tuple[float, tuple[int, ...], np.ndarray, np.ndarray]]
"""(poses, parts of this evaluation) → (g, bodies, w = -∂g/∂ξ (6k,), ∂w/∂ξ (6k, 6k)):
a scalar constraint g = 0 between k bodies."""


class NoEquilibrium(FecheckError):
    """The unbalanced load moved the bodies without meeting an equilibrium: no contact
    along the load within 1 m, or none with a lower residual. The model adds what it
    knows of the cause (e.g. a load below the tibia's weight)."""


class NoStiffness(FecheckError):
    """Free DOFs that nothing resists at the current contact (`_no_stiffness_message`)."""


def cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b for two 3-vectors (np.cross costs ~10x more on single vectors)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])


def _frame(q: np.ndarray, base: np.ndarray | None = None
           ) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, ...]]:
    """R, t (mm) and the rotation axes (a_x, a_y, a_z) (world) of body coordinates q; with
    a `base` rotation Q the angles turn about Q's axes: R = Q·Rx·Ry·Rz·Qᵀ."""
    rx = rot_x(q[3])
    rxy = rx @ rot_y(q[4])
    rot, t = rxy @ rot_z(q[5]), np.asarray(q[:3], dtype=float)
    if base is None:
        return rot, t, (E_X, rx[:, 1], rxy[:, 2])
    return base @ rot @ base.T, t, (base[:, 0], base @ rx[:, 1], base @ rxy[:, 2])


def body_pose(q: np.ndarray, base: np.ndarray | None = None) -> BodyPose:
    """Rotation R and translation t (mm) of a body at q = (x, y, z, θx, θy, θz) (`Body`'s
    `base`: the axes the angles turn about)."""
    return _frame(q, base)[:2]


def _basis(t: np.ndarray, axes: Sequence[np.ndarray]) -> np.ndarray:
    b = np.zeros((6, 6))
    b[0, 0] = b[1, 1] = b[2, 2] = 1.0
    for i, a in enumerate(axes):
        b[:3, 3 + i] = cross3(t, a)
        b[3:, 3 + i] = a
    return b


def _geometric(t: np.ndarray, wrench: np.ndarray, axes: Sequence[np.ndarray]) -> np.ndarray:
    """Σ_k (∂B/∂q_k)ᵀ·W e_kᵀ (6, 6): row j, column k is (∂B_j/∂q_k)·W. A rotation
    column B_j = (t × a_j, a_j) changes with t_k by (e_k × a_j, 0), and with an earlier
    angle θ_k of the chain Rx·Ry·Rz by (t × b, b), b = ∂a_j/∂θ_k = a_k × a_j."""
    f, m = wrench[:3], wrench[3:]
    k = np.zeros((6, 6))
    for j in range(3):
        k[3 + j, :3] = cross3(axes[j], f)          # (e_k × a)·F = (a × F)_k
        for i in range(j):
            b = cross3(axes[i], axes[j])
            k[3 + j, 3 + i] = cross3(t, b) @ f + b @ m
    return k


def body_basis(q: np.ndarray, base: np.ndarray | None = None) -> np.ndarray:
    """B (6, 6): the twist ξ = (v, ω) about the world origin for δq (mm, rad)."""
    _, t, axes = _frame(q, base)
    return _basis(t, axes)


def body_geometric(q: np.ndarray, wrench: np.ndarray, base: np.ndarray | None = None
                   ) -> np.ndarray:
    """Σ_k (∂B/∂q_k)ᵀ·W e_kᵀ (6, 6): the tangent part from B's dependence on q."""
    _, t, axes = _frame(q, base)
    return _geometric(t, wrench, axes)


def tibia_coordinates(q: np.ndarray, theta_x: float = 0.0) -> np.ndarray:
    """Body coordinates (6,) of the tibia's q = (x, y, z, θy, θz) at flexion θx (rad)."""
    return np.array([q[0], q[1], q[2], theta_x, q[3], q[4]], dtype=float)


def pose(q: np.ndarray, theta_x: float = 0.0, base: np.ndarray | None = None) -> BodyPose:
    """Rotation R and translation t (mm) of the tibia for q = (x, y, z, θy, θz) (`base`:
    the axes the angles turn about, as in `Body`)."""
    return body_pose(tibia_coordinates(q, theta_x), base)


def twist_basis(q: np.ndarray, theta_x: float = 0.0, base: np.ndarray | None = None
                ) -> np.ndarray:
    """B (6, 5) of the tibia's q = (x, y, z, θy, θz) (mm, rad)."""
    b = body_basis(tibia_coordinates(q, theta_x), base)
    return np.ascontiguousarray(b[:, TIBIA_COORDINATES])


def geometric_tangent(q: np.ndarray, wrench: np.ndarray, theta_x: float = 0.0,
                      base: np.ndarray | None = None) -> np.ndarray:
    """Σ_k (∂B/∂q_k)ᵀ·W e_kᵀ (5, 5) of the tibia's q = (x, y, z, θy, θz)."""
    k = body_geometric(tibia_coordinates(q, theta_x), wrench, base)
    return k[np.ix_(TIBIA_COORDINATES, TIBIA_COORDINATES)]


def point_force(x: np.ndarray, f: np.ndarray, df_dx: np.ndarray | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """Wrench (6,) of force `f` (N) at a body point `x` (mm, world) and dW/dξ (6, 6).

    `df_dx` (3, 3) is how the force changes as the point moves (None: constant force).
    """
    w = np.concatenate([f, cross3(x, f)])
    sf = skew(f)
    if df_dx is None:                              # dM/dξ = -[F]× [I, -[x]×]
        out = np.zeros((6, 6))
        out[3:, :3] = -sf
        out[3:, 3:] = sf @ skew(x)
        return w, out
    dx = np.hstack([np.eye(3), -skew(x)])          # δx = dx @ ξ
    dfx = df_dx @ dx
    return w, np.vstack([dfx, -sf @ dx + skew(x) @ dfx])


def carried(wrench: np.ndarray) -> np.ndarray:
    """C(W) (6, 6): how a wrench W (about the world origin) between two bodies changes when
    both move by the same twist ξ, dW = C(W)·ξ (it moves with them: δF = ω × F,
    δM = v × F + ω × M)."""
    out = np.zeros((6, 6))
    sf = skew(wrench[:3])
    out[:3, 3:] = -sf
    out[3:, :3] = -sf
    out[3:, 3:] = -skew(wrench[3:])
    return out


def master_tangent(wrench: np.ndarray, tangent: np.ndarray) -> np.ndarray:
    """d(-W)/dξ_m (6, 6): the tangent of the wrench on the master body, -W, for the
    master's twist, from the contact wrench W on the slave and K = dW/dξ_s (slave's twist,
    master held). W depends on the relative pose only, so dW/dξ_s + dW/dξ_m = C(W)
    (`carried`) and d(-W)/dξ_m = K - C(W)."""
    return tangent - carried(wrench)


def interface_part(slave: int, master: int, wrench: np.ndarray, tangent: np.ndarray) -> Part:
    """The `Part` of a contact interface: W on the slave body, -W on the master, with the
    blocks [[K, C - K], [-K, K - C]] (K = dW/dξ_s, C = `carried` of W)."""
    c = carried(wrench)
    dw = np.block([[tangent, c - tangent], [-tangent, tangent - c]])
    return (slave, master), np.concatenate([wrench, -wrench]), dw


def two_point_force(x_a: np.ndarray, x_b: np.ndarray, f: np.ndarray, df_dx: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Wrenches (12,) of force `f` (N) on body b at its point x_b and -f on body a at x_a
    (mm, world), f depending on x_b - x_a with ∂f/∂x_b = `df_dx` (3, 3), and their tangent
    (12, 12) for the twists (ξ_a, ξ_b): a spring or a rod between two bodies."""
    da = np.hstack([np.eye(3), -skew(x_a)])        # δx_a = da @ ξ_a
    db = np.hstack([np.eye(3), -skew(x_b)])
    dfa, dfb = -df_dx @ da, df_dx @ db             # δf = dfa ξ_a + dfb ξ_b
    sf, sxa, sxb = skew(f), skew(x_a), skew(x_b)
    w = np.concatenate([-f, cross3(x_a, -f), f, cross3(x_b, f)])
    dw = np.block([[-dfa, -dfb],
                   [sf @ da - sxa @ dfa, -sxa @ dfb],
                   [dfa, dfb],
                   [sxb @ dfa, -sf @ db + sxb @ dfb]])
    return w, dw


@dataclass(frozen=True)
class Body:
    """A rigid body of a `Problem`.

    name : how messages name it ("tibia", "medial meniscus")
    q_start : (6,) start coordinates (x, y, z mm, θx, θy, θz rad); the coordinates not in
        `free` stay at their value (driven, or fixed)
    free : indices of the free coordinates in `BODY_DOFS` (empty: a fixed body)
    free_key : the scene key that lists the free DOFs (for messages); "" for a body whose
        DOFs are all free, with no key to fix them (the patella)
    start_keys : the scene keys the start coordinates come from (for messages)
    base : (3, 3) rotation Q whose columns are the axes θx, θy, θz turn about at q = 0
        (R = Q·Rx·Ry·Rz·Qᵀ; a flexion axis off world x); None: the world axes
    """

    name: str
    q_start: np.ndarray
    free: tuple[int, ...]
    free_key: str = "dofs.free"
    start_keys: str = "dofs.*_mm/_deg"
    base: np.ndarray | None = None


def tibia_body(q: np.ndarray, free: Sequence[int], theta_x: float = 0.0,
               base: np.ndarray | None = None) -> Body:
    """The tibia as a `Body`: its q = (x, y, z, θy, θz) with θx driven, and the indices
    `free` of its free DOFs in (x, y, z, θy, θz); `base` as in `Body`."""
    return Body("tibia", tibia_coordinates(q, theta_x),
                tuple(TIBIA_COORDINATES[i] for i in free), base=base)


def on_body(parts: Callable[[np.ndarray, np.ndarray], Sequence[tuple[np.ndarray, np.ndarray]]],
            body: int = 0) -> WrenchFn:
    """A `WrenchFn` from wrench parts (W (6,), dW/dξ (6, 6)) on one body at its pose."""
    index = (body,)

    def wrench(poses: Sequence[BodyPose]) -> list[Part]:
        return [(index, w, dw) for w, dw in parts(*poses[body])]

    return wrench


def constraint_on_body(con: Callable, body: int = 0) -> ConstraintFn:
    """A `ConstraintFn` from a one-body constraint (R, t, [(W, dW/dξ)]) → (g, w, ∂w/∂ξ)
    (the parts passed on are this evaluation's, without their body indices)."""
    index = (body,)

    def constraint(poses: Sequence[BodyPose], parts: Sequence[Part]):
        g, w, dw = con(*poses[body], [(wp, dp) for _, wp, dp in parts])
        return g, index, w, dw

    return constraint


@dataclass(frozen=True)
class Problem:
    """An equilibrium problem.

    bodies : the rigid bodies; their free coordinates are solved all at once
    wrench : the parts of the wrench (contact, load, gravity, springs); their sum on each
        body is balanced, and each part's stiffness tells parts that cancel from none
    constraints : scalar constraints with multipliers (rods, equal forces)
    force_scale_N : load magnitude the tolerance is relative to
    length_scale_mm : converts rotations and moments to mm and N in the residual norm
    """

    bodies: tuple[Body, ...]
    wrench: WrenchFn
    constraints: Sequence[ConstraintFn] = ()
    force_scale_N: float = 1.0
    length_scale_mm: float = 50.0
    tolerance: float = 1e-8
    max_iterations: int = 60
    touching: Callable[[], bool] | None = None
    """After a `wrench` call: whether any contact was active (None: always)."""

    def __post_init__(self) -> None:
        names = [b.name for b in self.bodies]
        if len(set(names)) < len(names):
            raise FecheckError(f"bodies {names} share a name: give each body its own")

    @property
    def n_free(self) -> int:
        """Number of free coordinates of all bodies."""
        return sum(len(b.free) for b in self.bodies)

    def free_names(self) -> list[tuple[str, str]]:
        """(body name, DOF name) of every free coordinate, in the stacked order."""
        return [(b.name, BODY_DOFS[i]) for b in self.bodies for i in b.free]


@dataclass(frozen=True)
class Solution:
    """Newton result: coordinates q (6,) of every body, multipliers (one per constraint),
    convergence data."""

    q: tuple[np.ndarray, ...]
    multipliers: np.ndarray
    converged: bool
    iterations: int
    residual_norm: float
    evaluations: int
    history: tuple[float, ...] = field(default=())


def _scatter(parts: Sequence[Part], n_bodies: int
             ) -> tuple[list[np.ndarray], dict[tuple[int, int], np.ndarray]]:
    """Sum the parts per body: W_b (6,) and the tangent blocks dW_b/dξ_c (6, 6)."""
    w = [np.zeros(6) for _ in range(n_bodies)]
    dw: dict[tuple[int, int], np.ndarray] = {}
    for bodies, wp, dp in parts:
        if len(bodies) == 1:                       # a load or a spring to the world
            b = bodies[0]
            w[b] += wp
            if (b, b) in dw:
                dw[b, b] += dp
            else:
                dw[b, b] = dp.copy()
            continue
        for i, b in enumerate(bodies):
            w[b] += wp[6 * i:6 * i + 6]
            for j, c in enumerate(bodies):
                block = dp[6 * i:6 * i + 6, 6 * j:6 * j + 6]
                if (b, c) in dw:
                    dw[b, c] += block
                else:
                    dw[b, c] = block.copy()
    return w, dw


class _System:
    """Residual and Jacobian of the augmented system in scaled units."""

    def __init__(self, p: Problem):
        self.p = p
        self.nf = p.n_free
        self.nc = len(p.constraints)
        self.slices, start = [], 0
        for b in p.bodies:
            self.slices.append(slice(start, start + len(b.free)))
            start += len(b.free)
        self.sq = np.concatenate([np.where(np.array(b.free, dtype=int) >= 3,
                                           p.length_scale_mm, 1.0) for b in p.bodies])
        self.sq2 = np.outer(self.sq, self.sq)   # scaled δq = sq · δq_true (mm)
        self.evaluations = 0
        self.touching = True
        self.parts: Sequence[Part] = ()

    def z_of(self, qs: Sequence[np.ndarray]) -> np.ndarray:
        """Scaled free coordinates (nf,) of the body coordinates `qs`."""
        return np.concatenate([np.asarray(q, dtype=float)[list(b.free)]
                               for b, q in zip(self.p.bodies, qs, strict=True)]) * self.sq

    def q_of(self, z: np.ndarray) -> list[np.ndarray]:
        out = []
        for b, s in zip(self.p.bodies, self.slices, strict=True):
            q = np.array(b.q_start, dtype=float)
            q[list(b.free)] = z[s] / self.sq[s]
            out.append(q)
        return out

    def _frames(self, z: np.ndarray) -> tuple[list[BodyPose], list[np.ndarray], list]:
        """Poses, twist bases of the free coordinates (6, nf_b) and frames at z."""
        poses, bases, frames = [], [], []
        for b, q in zip(self.p.bodies, self.q_of(z), strict=True):
            r, t, axes = _frame(q, b.base)
            poses.append((r, t))
            bases.append(np.ascontiguousarray(_basis(t, axes)[:, list(b.free)]))
            frames.append((t, axes))
        return poses, bases, frames

    def _tangent(self, bases: list[np.ndarray], dw: dict[tuple[int, int], np.ndarray]
                 ) -> np.ndarray:
        """Σ B_bᵀ·(dW_b/dξ_c)·B_c over the blocks (b, c) of `dw`, (nf, nf), unscaled."""
        k = np.zeros((self.nf, self.nf))
        for (b, c), block in dw.items():
            k[self.slices[b], self.slices[c]] += bases[b].T @ block @ bases[c]
        return k

    def _geometric(self, frames: list, w: list[np.ndarray]) -> np.ndarray:
        """The geometric part Σ_k (∂B_b/∂q_k)ᵀ·W_b e_kᵀ of every body, (nf, nf), unscaled."""
        k = np.zeros((self.nf, self.nf))
        for i, body in enumerate(self.p.bodies):
            free = list(body.free)
            t, axes = frames[i]
            k[self.slices[i], self.slices[i]] = _geometric(t, w[i], axes)[np.ix_(free, free)]
        return k

    def __call__(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p, nf = self.p, self.nf
        lam = z[nf:]
        poses, bases, frames = self._frames(z)
        parts = p.wrench(poses)
        w, dw = _scatter(parts, len(p.bodies))
        self.evaluations += 1
        self.touching = True if p.touching is None else bool(p.touching())
        self.parts = parts
        k = self._tangent(bases, dw)
        res = np.empty(nf + self.nc)
        jac = np.zeros((nf + self.nc, nf + self.nc))
        for i, con in enumerate(p.constraints):
            g, bodies, wc, dwc = con(poses, parts)
            wcs, dwcs = _scatter([(bodies, wc, dwc)], len(p.bodies))
            k += lam[i] * self._tangent(bases, dwcs)
            for b in bodies:
                w[b] = w[b] + lam[i] * wcs[b]
                qc = bases[b].T @ wcs[b] / self.sq[self.slices[b]]
                jac[self.slices[b], nf + i] = qc
                jac[nf + i, self.slices[b]] = -qc
            res[nf + i] = g
        k += self._geometric(frames, w)
        for i, s in enumerate(self.slices):
            res[s] = bases[i].T @ w[i] / self.sq[s]  # forces N, moments / L
        jac[:nf, :nf] = k / self.sq2
        return res, jac

    def gross_stiffness(self, z: np.ndarray, v: np.ndarray) -> float:
        """Σ over the wrench's parts of |vᵀ·K_part·v| at z (the last evaluation), for a
        unit direction v of the free DOFs (scaled, N/mm): the stiffness acting along v
        before the parts cancel."""
        _, bases, frames = self._frames(z)
        total = 0.0
        for part in self.parts:
            w, dw = _scatter([part], len(self.p.bodies))
            k = (self._tangent(bases, dw) + self._geometric(frames, w)) / self.sq2
            total += abs(float(v @ k @ v))
        return total


def generalised_force(p: Problem, qs: Sequence[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The generalised force Q (n_free,) of `p`'s wrench on its bodies' free coordinates at
    the body coordinates `qs` (N, and N·mm per rad), and its tangent ∂Q/∂q (n_free,
    n_free) with the twist bases' own change (what `solve` balances, unscaled; `p`'s
    constraints left out)."""
    sysm = _System(replace(p, constraints=()))
    res, jac = sysm(sysm.z_of(qs))
    return res * sysm.sq, jac * sysm.sq2


def _null_space(jac: np.ndarray, rtol: float = 1e-4) -> np.ndarray:
    _, s, vt = np.linalg.svd(jac)
    if s[0] == 0.0:
        return np.eye(len(s))
    return vt[s <= rtol * s[0]].T


STEP_TOL_MM = 1e-5
"""A converged solve's last step is below this (scaled: rotations · length scale), mm."""
STALL_EVALUATIONS = 9
"""A step whose line search took this many evaluations or more (the Newton step halved 8
times) made no headway; `stopping_stalls` counts such steps. Measured on 220 solves of the
scanned knee's population (196 samples): no step of a converged solve took more than 8,
a stalled one 9 to 40 from its 8th-12th step on."""

_stalls = threading.local()
"""The running `stopping_stalls` block's step count (``steps``), per thread."""


@contextmanager
def stopping_stalls(steps: int) -> Iterator[None]:
    """Within the block, a `solve` in this thread stops, not converged, after `steps`
    consecutive steps of `STALL_EVALUATIONS` evaluations or more, instead of spending
    the iteration limit on a residual it no longer lowers (a population's sample then
    goes on with its continuation). A solve that converges never takes such a run of
    steps on the scanned knee, so its numbers are those it has outside the block."""
    outer = getattr(_stalls, "steps", 0)
    _stalls.steps = int(steps)
    try:
        yield
    finally:
        _stalls.steps = outer


def solve(p: Problem) -> Solution:
    """Solve the equilibrium `p` by safeguarded Newton-Raphson.

    Converged when the scaled residual norm is below `tolerance`·`force_scale_N` (N),
    the constraints hold to `tolerance`·`length_scale_mm` (mm) and the last step was
    below `STEP_TOL_MM`. Raises `FecheckError` when free DOFs have neither stiffness
    nor load, or when the constraints leave no motion.
    """
    if p.constraints and len(p.constraints) >= p.n_free:
        raise FecheckError(f"{len(p.constraints)} constraints (ligament rods, equal forces) on "
                           f"{p.n_free} free DOFs {_labels(p)} leave no motion for the "
                           f"contact: the system is over-constrained; free more DOFs "
                           f"({_keys(p)}) or use ligaments.model = 'spring'")
    sysm = _System(p)
    nf = sysm.nf
    z = np.zeros(nf + sysm.nc)
    z[:nf] = sysm.z_of([b.q_start for b in p.bodies])
    f_tol = p.tolerance * p.force_scale_N

    def merit(res: np.ndarray) -> float:
        return float(np.hypot(np.linalg.norm(res[:nf]),
                              np.linalg.norm(res[nf:]) * p.force_scale_N / p.length_scale_mm))

    res, jac = sysm(z)
    phi = merit(res)
    history = [phi]
    converged = False
    step = np.inf
    it = 0
    stall_limit, stalled = getattr(_stalls, "steps", 0), 0
    for it in range(1, p.max_iterations + 1):
        if _converged(res, nf, f_tol, p) and step <= STEP_TOL_MM:
            converged = True
            it -= 1
            break
        if stall_limit and stalled >= stall_limit:
            it -= 1
            break
        before = sysm.evaluations
        z_new, res, jac, phi = _step(sysm, z, res, jac, phi, merit)
        stalled = stalled + 1 if sysm.evaluations - before >= STALL_EVALUATIONS else 0
        step = float(np.linalg.norm((z_new - z)[:nf]))
        z = z_new
        history.append(phi)
    else:
        converged = _converged(res, nf, f_tol, p) and step <= STEP_TOL_MM
    null = _null_space(jac)
    if null.shape[1] and (converged or sysm.touching):
        raise NoStiffness(_no_stiffness_message(p, null))
    return Solution(tuple(sysm.q_of(z)), z[nf:].copy(), converged, it, phi, sysm.evaluations,
                    tuple(history))


def _converged(res: np.ndarray, nf: int, f_tol: float, p: Problem) -> bool:
    return (bool(np.linalg.norm(res[:nf]) <= f_tol)
            and bool(np.all(np.abs(res[nf:]) <= p.tolerance * p.length_scale_mm)))


def _labels(p: Problem, names: Sequence[tuple[str, str]] | None = None) -> list[str]:
    """The free DOFs `names` (all by default) as DOF names, prefixed by the body's name
    where the problem has more than one body."""
    names = p.free_names() if names is None else names
    return [dof if len(p.bodies) == 1 else f"{body} {dof}" for body, dof in names]


def _keys(p: Problem) -> str:
    return ", ".join(dict.fromkeys(b.free_key for b in p.bodies if b.free and b.free_key))


def _no_stiffness_message(p: Problem, null: np.ndarray) -> str:
    nf = p.n_free
    weight = np.linalg.norm(null[:nf], axis=1)
    names = p.free_names()
    loose = [names[i] for i in range(nf) if weight[i] > 0.1]
    if not loose:
        return (f"the {len(p.constraints)} constraints (ligament rods) over-constrain the free "
                f"DOFs {_labels(p)}: their forces are indeterminate; free more DOFs "
                f"({_keys(p)}) or use ligaments.model = 'spring'")
    kept: dict[str, list[str]] = {}     # a key shared by bodies keeps what all of them keep
    keys: dict[str, str] = {}
    keyless: list[str] = []             # bodies with loose DOFs and no key to fix them
    for body in p.bodies:
        mine = [dof for name, dof in names if name == body.name]
        held = [dof for dof in mine if (body.name, dof) not in loose]
        if len(held) == len(mine):
            continue
        if not body.free_key:
            keyless.append(body.name)
            continue
        before = kept.get(body.free_key, held)
        kept[body.free_key] = [dof for dof in before if dof in held]
        keys[body.free_key] = body.start_keys
    drive = [f"{key} = {dofs!r}" for key, dofs in kept.items()]
    who = f"the {p.bodies[0].name} DOFs" if len(p.bodies) == 1 else "the DOFs"
    fix = (f"drive them by setting {' and '.join(drive)} (their values come from "
           f"{', '.join(keys.values())}), or add ligaments" if drive else "add ligaments")
    if keyless:
        fix += (f"; nothing holds the {' and the '.join(keyless)} here: it may have left the "
                f"surface it rests on (approach this pose in smaller steps)")
    return (f"{who} {', '.join(_labels(p, loose))} have no stiffness (nothing resists "
            f"them, e.g. sliding on frictionless plateaus): {fix}")


MAX_STEP_MM = 5.0
"""Trust radius of a Newton step (scaled: translations mm, rotations · length scale)."""


def _step(sysm: _System, z, res, jac, phi, merit):
    """One safeguarded Newton step; returns the new (z, res, jac, merit)."""
    p, nf = sysm.p, sysm.nf
    null = _null_space(jac)
    touching = sysm.touching
    if touching and null.shape[1]:
        r_null = float(np.linalg.norm(null.T @ res))
        if r_null <= 1e-6 * max(phi, p.tolerance * p.force_scale_N):
            raise NoStiffness(_no_stiffness_message(p, null))
    if touching and sysm.nc == 0:
        lam, vec = np.linalg.eigh(-0.5 * (jac + jac.T))
        scale = float(np.abs(lam).max())
        if (lam[0] < 1e-4 * scale
                and sysm.gross_stiffness(z, vec[:, 0]) > CANCELLING_STIFFNESS_RTOL * scale):
            return _descent_step(sysm, z, res, lam, vec, merit)
    if not touching or null.shape[1]:
        return _free_flight(sysm, z, res, jac, phi, merit, touching, null)
    dz = np.linalg.solve(jac, -res)
    size = np.linalg.norm(dz[:nf])
    alpha = min(1.0, MAX_STEP_MM / size) if size > 0 else 1.0
    for _ in range(40):
        z_new = z + alpha * dz
        res_new, jac_new = sysm(z_new)
        phi_new = merit(res_new)
        if phi_new <= (1.0 - 1e-4 * alpha) * phi or phi_new <= p.tolerance * p.force_scale_N:
            return z_new, res_new, jac_new, phi_new
        alpha *= 0.5
    return z_new, res_new, jac_new, phi_new


CANCELLING_STIFFNESS_RTOL = 1e-3
"""Where K = -sym(∂Q/∂q) is singular or indefinite along v (its lowest eigenvector)
but its parts' stiffnesses along v add up, in magnitude, to more than this x K's
largest |eigenvalue|, they cancel (a domed plateau against ligaments): the DOFs are held,
and `_descent_step` goes on. Below it (a frictionless plane: only mesh faceting, ~1e-4)
the DOFs have no stiffness."""


def _descent_step(sysm: _System, z, res, lam, vec, merit):
    """An energy-descent step where the stiffness K is indefinite (no constraints).

    A negative stiffness (e.g. a condyle on a plateau domed in the sagittal plane, held
    by ligament bundles mostly slack at the start pose) makes the Newton step head for a
    saddle, and the residual norm must rise on the way to the stable equilibrium: Newton
    stalls where K turns singular, which is no lack of stiffness. The residual is
    the generalised force -dE/dq of a conservative system (load, gravity, springs, contact
    potential), so step along d = (K + μI)⁻¹·r, μ = -λ_min + |r|/MAX_STEP_MM (a descent
    direction, |d| ≤ MAX_STEP_MM), and accept when the work of r along the step (the
    energy released, trapezoidal rule) is positive (Armijo, 1e-4). Only stable
    equilibria are approached this way.
    """
    r0 = res[:sysm.nf]
    shift = -lam[0] + float(np.linalg.norm(r0)) / MAX_STEP_MM
    dz = vec @ ((vec.T @ r0) / (lam + shift))
    slope = float(r0 @ dz)
    alpha = 1.0
    for _ in range(40):
        z_new = z + alpha * dz
        res_new, jac_new = sysm(z_new)
        work = 0.5 * alpha * float((r0 + res_new[:sysm.nf]) @ dz)
        if work >= 1e-4 * alpha * slope:
            break
        alpha *= 0.5
    return z_new, res_new, jac_new, merit(res_new)


def _free_flight(sysm, z, res, jac, phi, merit, was_touching, null):
    """Regularised steps of growing length Δ: the DOFs get a stiffness |residual|/Δ (the
    constraints stay linearised), so the unbalanced load moves the tibia by about Δ.
    Δ doubles until contact is made with a lower residual, then is bisected; from a
    touching start where no Δ ≥ 0.5 mm helps, Δ then halves until the residual drops."""
    nf = sysm.nf
    reg = np.zeros(len(z))
    reg[:nf] = 1.0
    r_norm = float(np.linalg.norm(res[:nf])) or 1.0

    def trial(delta):
        # J = -stiffness; least squares: a constraint may have no gradient before contact
        dz = np.linalg.lstsq(jac - np.diag(reg * (r_norm / delta)), -res, rcond=None)[0]
        res_new, jac_new = sysm(z + dz)
        return z + dz, res_new, jac_new, merit(res_new), sysm.touching

    lo, hi = 0.0, 0.5
    for _ in range(12):                     # Δ up to 0.5·2^11 ≈ 1000 mm
        z_new, res_new, jac_new, phi_new, touching = trial(hi)
        if touching and phi_new < phi:
            return z_new, res_new, jac_new, phi_new
        if touching and not was_touching:
            break                           # contact made, but overshot
        lo, hi = hi, 2.0 * hi
    else:
        if was_touching:
            # In contact, a stiffness-free direction (e.g. rocking about the one touching
            # compartment) moves on the scale the load sets, which can be far below 0.5 mm
            # (µm at µN loads): shorter steps, down to ~1e-12 mm, before giving up.
            delta = 0.25
            for _ in range(40):
                z_new, res_new, jac_new, phi_new, touching = trial(delta)
                if touching and phi_new <= (1.0 - 1e-4) * phi:
                    return z_new, res_new, jac_new, phi_new
                delta *= 0.5
        if was_touching and null.shape[1]:
            raise NoStiffness(_no_stiffness_message(sysm.p, null))
        raise NoEquilibrium("no equilibrium found along the load within 1 m: check the load "
                            "direction, the start pose (solver.start_gap_mm) and dofs.free")
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        z_new, res_new, jac_new, phi_new, touching = trial(mid)
        if touching and phi_new < phi:
            return z_new, res_new, jac_new, phi_new
        if touching:
            hi = mid
        else:
            lo = mid
    raise NoEquilibrium("could not bring the bodies into contact along the load; check the "
                        "load direction and the start pose (solver.start_gap_mm)")
