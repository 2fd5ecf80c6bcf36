"""Static equilibrium of the tibia (femur fixed) by safeguarded Newton-Raphson.

Generalised coordinates (thesis §1.3, eq. 1.14): q = (x, y, z, θy, θz) in mm and rad,
the tibia pose x_world = R·X + t with R = Rx(θx)·Ry(θy)·Rz(θz), t = (x, y, z); θx is
driven. Loads are wrenches W = (F, M) on the tibia, M about the world origin (N, N·mm);
a small tibia motion is the twist ξ = (v, ω) with δx = v + ω × x, and ξ = B(q)·δq. The
generalised force is Q = Bᵀ·W and its exact tangent dQ/dq = Bᵀ·(dW/dξ)·B + Σ_k
(∂B/∂q_k)ᵀ·W e_kᵀ.

Constraints g(q) = 0 (ligament rods) add multipliers λ whose wrench is λ·w with
w = -∂g/∂ξ (for a rod, λ is its tension, N). Newton solves
[Q + Σ λ_i Bᵀ w_i = 0, g = 0] with a backtracking line search on the residual norm;
where the stiffness is indefinite because the wrench's parts cancel (no constraints) it
takes energy-descent steps instead (`_descent_step`), so it reaches stable equilibria; a
start without contact (no stiffness along the load) is handled by a growing step along
the unbalanced load until contact is made. DOFs with no stiffness and no load are
reported as a `FecheckError` telling the scene to drive them.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from fecheck.errors import FecheckError
from fecheck.scene.constants import DOF_NAMES
from fecheck.statics.frames import rot_x, rot_y, rot_z, skew

E_Y = np.array([0.0, 1.0, 0.0])
E_Z = np.array([0.0, 0.0, 1.0])

Part = tuple[np.ndarray, np.ndarray]
"""(W (6,), dW/dξ (6, 6)): one part of the wrench on the tibia and its tangent."""

WrenchFn = Callable[[np.ndarray, np.ndarray], Sequence[Part]]
"""(R, t) → the parts of the wrench on the tibia (contact, load, springs), summed here."""

ConstraintFn = Callable[[np.ndarray, np.ndarray, Sequence[Part]],
                        tuple[float, np.ndarray, np.ndarray]]
"""(R, t, parts of this evaluation) → (g, w = -∂g/∂ξ (6,), ∂w/∂ξ (6, 6)): a scalar
constraint g = 0."""


class NoEquilibrium(FecheckError):
    """The unbalanced load moved the tibia without meeting an equilibrium: no contact
    along the load within 1 m, or none with a lower residual. The model adds what it
    knows of the cause (e.g. a load below the tibia's weight)."""


def cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b for two 3-vectors (np.cross costs ~10x more on single vectors)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])


def pose(q: np.ndarray, theta_x: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Rotation R and translation t (mm) of the tibia for q = (x, y, z, θy, θz)."""
    return rot_x(theta_x) @ rot_y(q[3]) @ rot_z(q[4]), np.asarray(q[:3], dtype=float)


def _axes(q: np.ndarray, theta_x: float) -> tuple[np.ndarray, np.ndarray]:
    rx = rot_x(theta_x)
    return rx @ E_Y, rx @ rot_y(q[3]) @ E_Z


def _basis(q: np.ndarray, a_y: np.ndarray, a_z: np.ndarray) -> np.ndarray:
    """B (6, 5) from the abduction and internal-rotation axes a_y, a_z (world)."""
    b = np.zeros((6, 5))
    b[0, 0] = b[1, 1] = b[2, 2] = 1.0
    b[:3, 3] = cross3(q[:3], a_y)
    b[:3, 4] = cross3(q[:3], a_z)
    b[3:, 3] = a_y
    b[3:, 4] = a_z
    return b


def _geometric(q: np.ndarray, wrench: np.ndarray, a_y: np.ndarray, a_z: np.ndarray
               ) -> np.ndarray:
    """Σ_k (∂B/∂q_k)ᵀ·W e_kᵀ (5, 5) from the axes a_y, a_z (world)."""
    f, m = wrench[:3], wrench[3:]
    k = np.zeros((5, 5))
    k[3, :3] = cross3(a_y, f)              # row k of (F × e_k)·a = (a × F)_k
    k[4, :3] = cross3(a_z, f)
    b = cross3(a_y, a_z)
    k[4, 3] = cross3(q[:3], b) @ f + b @ m
    return k


def twist_basis(q: np.ndarray, theta_x: float = 0.0) -> np.ndarray:
    """B (6, 5): the twist ξ = (v, ω) about the world origin for δq (mm, rad)."""
    return _basis(q, *_axes(q, theta_x))


def geometric_tangent(q: np.ndarray, wrench: np.ndarray, theta_x: float = 0.0) -> np.ndarray:
    """Σ_k (∂B/∂q_k)ᵀ·W e_kᵀ (5, 5): the tangent part from B's dependence on q."""
    return _geometric(q, wrench, *_axes(q, theta_x))


def point_force(x: np.ndarray, f: np.ndarray, df_dx: np.ndarray | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """Wrench (6,) of force `f` (N) at tibia point `x` (mm, world) and dW/dξ (6, 6).

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


@dataclass(frozen=True)
class Problem:
    """An equilibrium problem.

    q_start : (5,) start pose; driven DOFs stay at their value
    free : indices of the free DOFs in (x, y, z, θy, θz)
    wrench : the parts of the wrench on the tibia (contact, load, gravity, springs); their
        sum is balanced, and each part's stiffness tells parts that cancel from none
    constraints : scalar constraints with multipliers (rods, equal forces)
    force_scale_N : load magnitude the tolerance is relative to
    length_scale_mm : converts rotations and moments to mm and N in the residual norm
    """

    q_start: np.ndarray
    free: tuple[int, ...]
    wrench: WrenchFn
    constraints: Sequence[ConstraintFn] = ()
    theta_x: float = 0.0
    force_scale_N: float = 1.0
    length_scale_mm: float = 50.0
    tolerance: float = 1e-8
    max_iterations: int = 60
    touching: Callable[[], bool] | None = None
    """After a `wrench` call: whether any contact was active (None: always)."""


@dataclass(frozen=True)
class Solution:
    """Newton result: pose q (5,), multipliers (one per constraint), convergence data."""

    q: np.ndarray
    multipliers: np.ndarray
    converged: bool
    iterations: int
    residual_norm: float
    evaluations: int
    history: tuple[float, ...] = field(default=())


class _System:
    """Residual and Jacobian of the augmented system in scaled units."""

    def __init__(self, p: Problem):
        self.p = p
        self.nf = len(p.free)
        self.nc = len(p.constraints)
        s = np.ones(5)
        s[3:] = p.length_scale_mm
        self.free = list(p.free)
        self.sq = s[self.free]                 # scaled δq = sq · δq_true (mm)
        self.block = np.ix_(self.free, self.free)
        self.sq2 = np.outer(self.sq, self.sq)
        self.rx = rot_x(p.theta_x)
        self.a_y = self.rx @ E_Y
        self.evaluations = 0
        self.touching = True
        self.parts: Sequence[Part] = ()

    def q_of(self, z: np.ndarray) -> np.ndarray:
        q = np.array(self.p.q_start, dtype=float)
        q[self.free] = z[:self.nf] / self.sq
        return q

    def __call__(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p, nf, free = self.p, self.nf, self.free
        q = self.q_of(z)
        lam = z[nf:]
        rxy = self.rx @ rot_y(q[3])
        r, t = rxy @ rot_z(q[4]), q[:3]             # `pose`
        a_z = rxy[:, 2].copy()                      # rx ry e_z
        b = _basis(q, self.a_y, a_z)                # `twist_basis`
        parts = p.wrench(r, t)
        w, dw = np.zeros(6), np.zeros((6, 6))
        for wp, dp in parts:
            w += wp
            dw += dp
        self.evaluations += 1
        self.touching = True if p.touching is None else bool(p.touching())
        self.parts = parts
        k_full = b.T @ dw @ b
        w_tot = w.copy()
        res = np.empty(nf + self.nc)
        jac = np.zeros((nf + self.nc, nf + self.nc))
        cols = []
        for i, con in enumerate(p.constraints):
            g, wc, dwc = con(r, t, parts)
            w_tot += lam[i] * wc
            k_full += lam[i] * (b.T @ dwc @ b)
            qc = (b.T @ wc)[free]
            cols.append(qc)
            res[nf + i] = g
        k_full += _geometric(q, w_tot, self.a_y, a_z)
        res[:nf] = (b.T @ w_tot)[free] / self.sq   # forces N, moments / L
        jac[:nf, :nf] = k_full[self.block] / self.sq2
        for i, qc in enumerate(cols):
            jac[:nf, nf + i] = qc / self.sq
            jac[nf + i, :nf] = -qc / self.sq
        return res, jac

    def gross_stiffness(self, z: np.ndarray, v: np.ndarray) -> float:
        """Σ over the wrench's parts of |vᵀ·K_part·v| at z (the last evaluation), for a
        unit direction v of the free DOFs (scaled, N/mm): the stiffness acting along v
        before the parts cancel."""
        q = self.q_of(z)
        b = twist_basis(q, self.p.theta_x)
        total = 0.0
        for w, dw in self.parts:
            k = (b.T @ dw @ b + geometric_tangent(q, w, self.p.theta_x))[self.block] / self.sq2
            total += abs(float(v @ k @ v))
        return total


def _null_space(jac: np.ndarray, rtol: float = 1e-4) -> np.ndarray:
    _, s, vt = np.linalg.svd(jac)
    if s[0] == 0.0:
        return np.eye(len(s))
    return vt[s <= rtol * s[0]].T


def _dof_names(p: Problem, basis: np.ndarray) -> list[str]:
    nf = len(p.free)
    weight = np.linalg.norm(basis[:nf], axis=1)
    return [DOF_NAMES[p.free[i]] for i in range(nf) if weight[i] > 0.1]


STEP_TOL_MM = 1e-5
"""A converged solve's last step is below this (scaled: rotations · length scale), mm."""


def solve(p: Problem) -> Solution:
    """Solve the equilibrium `p` by safeguarded Newton-Raphson.

    Converged when the scaled residual norm is below `tolerance`·`force_scale_N` (N),
    the constraints hold to `tolerance`·`length_scale_mm` (mm) and the last step was
    below `STEP_TOL_MM`. Raises `FecheckError` when free DOFs have neither stiffness
    nor load, or when the constraints leave no motion.
    """
    if p.constraints and len(p.constraints) >= len(p.free):
        raise FecheckError(f"{len(p.constraints)} constraints (ligament rods, equal forces) on "
                           f"{len(p.free)} free DOFs {[DOF_NAMES[i] for i in p.free]} leave "
                           f"no motion for the contact: the system is over-constrained; free "
                           f"more DOFs (dofs.free) or use ligaments.model = 'spring'")
    sysm = _System(p)
    nf = sysm.nf
    z = np.zeros(nf + sysm.nc)
    z[:nf] = np.asarray(p.q_start)[list(p.free)] * sysm.sq
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
    for it in range(1, p.max_iterations + 1):
        if _converged(res, nf, f_tol, p) and step <= STEP_TOL_MM:
            converged = True
            it -= 1
            break
        z_new, res, jac, phi = _step(sysm, z, res, jac, phi, merit)
        step = float(np.linalg.norm((z_new - z)[:nf]))
        z = z_new
        history.append(phi)
    else:
        converged = _converged(res, nf, f_tol, p) and step <= STEP_TOL_MM
    null = _null_space(jac)
    if null.shape[1] and (converged or sysm.touching):
        raise FecheckError(_no_stiffness_message(p, null))
    return Solution(sysm.q_of(z), z[nf:].copy(), converged, it, phi, sysm.evaluations,
                    tuple(history))


def _converged(res: np.ndarray, nf: int, f_tol: float, p: Problem) -> bool:
    return (bool(np.linalg.norm(res[:nf]) <= f_tol)
            and bool(np.all(np.abs(res[nf:]) <= p.tolerance * p.length_scale_mm)))


def _no_stiffness_message(p: Problem, null: np.ndarray) -> str:
    names = _dof_names(p, null)
    if not names:
        return (f"the {len(p.constraints)} constraints (ligament rods) over-constrain the free "
                f"DOFs {[DOF_NAMES[i] for i in p.free]}: their forces are indeterminate; free "
                f"more DOFs (dofs.free) or use ligaments.model = 'spring'")
    driven = [DOF_NAMES[i] for i in p.free if DOF_NAMES[i] not in names]
    return (f"the tibia DOFs {', '.join(names)} have no stiffness (nothing resists them, "
            f"e.g. sliding on frictionless plateaus): drive them by setting dofs.free = "
            f"{driven!r} (their values come from dofs.*_mm/_deg), or add ligaments")


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
            raise FecheckError(_no_stiffness_message(p, null))
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
            raise FecheckError(_no_stiffness_message(sysm.p, null))
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
