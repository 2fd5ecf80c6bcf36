"""Ligaments between a femur point P (fixed, mm) and a tibia point Q (tibia frame, mm),
or between points of any two bodies of a `fecheck.statics.newton.Problem` (`BodySpring`,
`body_rod`; each point in its body's frame).

* Rods of constant length (thesis eq. 1.7, Lagrange multipliers): the constraint
  g = |P − x_Q| − L = 0; its multiplier is the rod tension (N, + pulls the tibia toward
  the femur; negative = compression).
* Springs (Blankevoort et al. 1991, J. Biomech. 24(11):1019-1031; thesis eq. 2.7 in its
  continuous form: the thesis prints the transition at ε_l, where the force jumps):
  strain ε = (l − l0)/l0 with slack length l0 = L_ref/(1 + ε_ref), ε_l =
  transition_strain/2 and stiffness k (N per unit strain): f = 0 for ε < 0,
  k·ε²/(4ε_l) for 0 ≤ ε ≤ 2ε_l, k·(ε − ε_l) beyond.
  Default k and ε_ref come from Lenhart et al. 2015 (J. Biomech. Eng. 137(8):081006) as
  shipped in ``shared/data/knee/lenhart2015/ligaments.json`` (see `fecheck.scene.schema`).
* Wrapping (`Wrapped`): a spring whose bundle has a wrap object takes the length of the
  shortest path over it (`fecheck.statics.wrapping`); the body the object is fixed to
  takes the equal and opposite force on the line of action at the free end.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from fecheck.errors import FecheckError
from fecheck.statics.frames import skew
from fecheck.statics.newton import BodyPose, ConstraintFn, Part, point_force, two_point_force
from fecheck.statics.wrapping import WrapObject, WrapObjects, length_derivatives, paths


def _direction(femur_point: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, float]:
    d = femur_point - x
    length = float(np.linalg.norm(d))
    if length < 1e-9:
        raise FecheckError("a ligament's attachments coincide (zero length); check the "
                           "knee landmarks")
    return d / length, length


def rod_constraint(femur_point: np.ndarray, tibia_point: np.ndarray, length_mm: float):
    """Constraint g = |P − x_Q| − L (mm) on the tibia
    (`fecheck.statics.newton.constraint_on_body` makes it one of `Problem.constraints`).

    Returns a function (R, t, parts) → (g, w, dw/dξ) with w = −∂g/∂ξ the wrench of a unit
    tension on the tibia (the wrench `parts` of the evaluation are not needed).
    """
    p = np.asarray(femur_point, dtype=float)
    q = np.asarray(tibia_point, dtype=float)

    def constraint(rot: np.ndarray, t: np.ndarray, parts=()):
        x = rot @ q + t
        u, length = _direction(p, x)
        w, dw = point_force(x, u, -(np.eye(3) - np.outer(u, u)) / length)
        return length - length_mm, w, dw

    return constraint


def blankevoort_tension(strain: np.ndarray | float, stiffness_N: float,
                        transition_strain: float) -> tuple[np.ndarray, np.ndarray]:
    """Spring force f(ε) (N) and df/dε (N) of Blankevoort 1991 (continuous form)."""
    e = np.asarray(strain, dtype=float)
    el = 0.5 * transition_strain
    toe = stiffness_N * e * e / (4 * el)
    lin = stiffness_N * (e - el)
    f = np.where(e < 0, 0.0, np.where(e <= 2 * el, toe, lin))
    df = np.where(e < 0, 0.0, np.where(e <= 2 * el, stiffness_N * e / (2 * el), stiffness_N))
    return f, df


def transition_strain_check(transition_strain: float) -> None:
    """Reject a non-positive transition strain (FecheckError)."""
    if not transition_strain > 0:
        raise FecheckError(f"ligaments.transition_strain must be > 0, got {transition_strain}")


@dataclass(frozen=True)
class SpringLigament:
    """A Blankevoort 1991 spring; call it with (R, t) for its wrench on the tibia."""

    femur_point: np.ndarray
    tibia_point: np.ndarray
    slack_length_mm: float
    stiffness_N: float
    transition_strain: float
    wrap: WrapObject | None = None
    """The wrap object of its path, None: straight (`tension` takes the length it is
    given)."""

    def tension(self, length_mm: float) -> float:
        """Spring force at a length, N (+ tension)."""
        f, _ = blankevoort_tension((length_mm - self.slack_length_mm) / self.slack_length_mm,
                                   self.stiffness_N, self.transition_strain)
        return float(f)

    def __call__(self, rot: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if self.wrap is not None:
            return SpringSet.of([self])(rot, t)
        x = rot @ self.tibia_point + t
        return point_force(x, *_pull(self, self.femur_point, x))


@dataclass(frozen=True, eq=False)
class Wrapped:
    """The bundles of a set whose paths wrap: their indices in the set (m,), their
    objects (`WrapObjects`, each in the frame of its body at rest, which is the data's
    frame) and whether each object is fixed to the set's second body b (m,) (else to
    its first body a)."""

    index: np.ndarray
    objects: WrapObjects
    on_b: np.ndarray

    @classmethod
    def of(cls, objects: Sequence[WrapObject | None], body_b: str) -> Wrapped | None:
        """The wrapping bundles among `objects` (None: a straight bundle), b the bone
        named `body_b`; None when no bundle wraps."""
        index = np.array([i for i, o in enumerate(objects) if o is not None], dtype=int)
        if not len(index):
            return None
        chosen = [objects[i] for i in index]
        return cls(index, WrapObjects.of(chosen), np.array([o.body == body_b for o in chosen]))

    def forces(self, points_a: np.ndarray, pose_a: BodyPose, points_b: np.ndarray,
               pose_b: BodyPose, slack_mm: np.ndarray, stiffness_N: np.ndarray,
               transition_strain: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """At the bodies' poses, for the wrapping bundles (their attachments `points_a`,
        `points_b` (m, 3) in their bodies' frames and spring constants (m,)): the path
        lengths (m,) mm, the free ends (m, 3) (world, mm), the pulls F (m, 3) N on them
        (the object's body takes −F on the same line, `free_and_object`) and dF/dx
        (m, 3, 3) N/mm as the free end moves relative to the object's body, world axes.
        """
        (ra, ta), (rb, tb) = pose_a, pose_b
        xa, xb = points_a @ ra.T + ta, points_b @ rb.T + tb
        on_b = self.on_b[:, None]
        rot = np.where(on_b[:, :, None], rb, ra)               # the object body's (m, 3, 3)
        origin = np.where(on_b, tb, ta)
        free = np.where(on_b, xa, xb)
        local = np.einsum("nji,nj->ni", rot, free - origin)
        ends = np.where(on_b, points_b, points_a)
        found = paths(self.objects, local, ends)
        length = found.length_mm
        g, hess = np.zeros((len(length), 3)), np.zeros((len(length), 3, 3))
        taut = length > slack_mm            # a slack bundle's force and tangent are 0
        if taut.any():
            _, g[taut], hess[taut] = length_derivatives(self.objects.take(taut), local[taut],
                                                        ends[taut], found.turn[taut])
        f, df = blankevoort_tension(length / slack_mm - 1.0, stiffness_N, transition_strain)
        force = -f[:, None] * g
        jac = (-(df / slack_mm)[:, None, None] * g[:, :, None] * g[:, None, :]
               - f[:, None, None] * hess)
        rot_t = np.transpose(rot, (0, 2, 1))
        return (length, free, np.einsum("nij,nj->ni", rot, force), rot @ jac @ rot_t)


def free_and_object(x: np.ndarray, force: np.ndarray, jac: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Forces F (n, 3) N at free ends x (n, 3) mm (world) of paths wrapped on objects fixed
    to another body, F changing by `jac` (n, 3, 3) as x moves relative to that body: the
    summed wrench (6,) on the free ends' body and its tangent for that body's twist (6, 6)
    and for the object body's (6, 6). The object's body takes −F on the same line of
    action (at x, or at the tangent point), so minus these: a common motion of both bodies
    only turns F with them (δF = ω × F), hence dF/dξ_object = −J·[I, −[x]×] + [0, −[F]×].
    """
    xs, fs = skew(x), skew(force)
    da = np.concatenate([np.broadcast_to(np.eye(3), jac.shape), -xs], axis=2)
    dfa = jac @ da                                  # δF = dfa ξ_free
    dfo = -dfa
    dfo[:, :, 3:] -= fs                             # δF = dfo ξ_object
    w = np.concatenate([force.sum(0), np.cross(x, force).sum(0)])
    d_free = np.vstack([dfa.sum(0), (xs @ dfa - fs @ da).sum(0)])
    d_object = np.vstack([dfo.sum(0), (xs @ dfo).sum(0)])
    return w, d_free, d_object


@dataclass(frozen=True, eq=False)
class SpringSet:
    """Many spring ligaments (`SpringLigament`) evaluated at once: called with (R, t) it
    gives the summed wrench (6,) of all their pulls on the tibia and its exact tangent
    dW/dξ (6, 6), the sum of their point forces (`point_force`) in one numpy evaluation.

    femur_points, tibia_points : (n, 3) mm (world; tibia frame)
    slack_mm, stiffness_N, transition_strain : (n,)
    wrapped : the bundles whose paths wrap (`Wrapped`, b the tibia; None: all straight)
    """

    femur_points: np.ndarray
    tibia_points: np.ndarray
    slack_mm: np.ndarray
    stiffness_N: np.ndarray
    transition_strain: np.ndarray
    wrapped: Wrapped | None = None

    @classmethod
    def of(cls, springs: Sequence[SpringLigament]) -> SpringSet:
        """The set of `springs` (at least one), wrapping those with a `wrap` object."""
        def col(name):
            return np.array([getattr(s, name) for s in springs], dtype=float)

        return cls(col("femur_point"), col("tibia_point"), col("slack_length_mm"),
                   col("stiffness_N"), col("transition_strain"),
                   Wrapped.of([s.wrap for s in springs], "tibia"))

    def _wrapped(self, rot: np.ndarray, t: np.ndarray):
        i = self.wrapped.index
        return self.wrapped.forces(self.femur_points[i], (np.eye(3), np.zeros(3)),
                                   self.tibia_points[i], (rot, t), self.slack_mm[i],
                                   self.stiffness_N[i], self.transition_strain[i])

    def lengths(self, rot: np.ndarray, t: np.ndarray) -> np.ndarray:
        """(n,) path lengths at the tibia pose (R, t), mm."""
        out = np.linalg.norm(self.femur_points - (self.tibia_points @ rot.T + t), axis=1)
        if self.wrapped is not None:
            out[self.wrapped.index] = self._wrapped(rot, t)[0]
        return out

    def tensions(self, rot: np.ndarray, t: np.ndarray) -> np.ndarray:
        """(n,) spring forces at the tibia pose (R, t), N (+ tension)."""
        strain = (self.lengths(rot, t) - self.slack_mm) / self.slack_mm
        return blankevoort_tension(strain, self.stiffness_N, self.transition_strain)[0]

    def __call__(self, rot: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        straight = np.ones(len(self.slack_mm), dtype=bool)
        if self.wrapped is not None:
            straight[self.wrapped.index] = False
        x = self.tibia_points[straight] @ rot.T + t
        d = self.femur_points[straight] - x
        length = np.linalg.norm(d, axis=1)
        if np.any(length < 1e-9):
            raise FecheckError("a ligament's attachments coincide (zero length); check the "
                               "knee landmarks")
        u = d / length[:, None]
        l0 = self.slack_mm[straight]
        f, df = blankevoort_tension((length - l0) / l0, self.stiffness_N[straight],
                                    self.transition_strain[straight])
        force = f[:, None] * u
        # the pull's Jacobian with x: -f'/l0·uuᵀ - f/l·(I - uuᵀ), per spring (n, 3, 3)
        uu = u[:, :, None] * u[:, None, :]
        jac = -(df / l0)[:, None, None] * uu - (f / length)[:, None, None] * (np.eye(3) - uu)
        w, dw = point_forces(x, force, jac)
        if self.wrapped is None:
            return w, dw
        _, free, pull, pull_jac = self._wrapped(rot, t)
        on_tibia = self.wrapped.on_b
        if on_tibia.any():          # the femoral end is free: the tibia takes -F
            wo, _, d_object = free_and_object(free[on_tibia], pull[on_tibia],
                                              pull_jac[on_tibia])
            w, dw = w - wo, dw - d_object
        if (~on_tibia).any():       # the object is on the femur: the tibial end is free
            wf, d_free, _ = free_and_object(free[~on_tibia], pull[~on_tibia],
                                            pull_jac[~on_tibia])
            w, dw = w + wf, dw + d_free
        return w, dw


def _pull(spring, a: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The force (3,) of a Blankevoort `spring` (its slack length, stiffness and
    transition strain) on its end at x toward its end at a (mm, world), and its
    derivative (3, 3) with x."""
    u, length = _direction(a, x)
    l0 = spring.slack_length_mm
    f, df = blankevoort_tension((length - l0) / l0, spring.stiffness_N,
                                spring.transition_strain)
    f, dfdl = float(f), float(df) / l0
    jac = -dfdl * np.outer(u, u) - (f / length) * (np.eye(3) - np.outer(u, u))
    return f * u, jac


@dataclass(frozen=True)
class BodySpring:
    """A Blankevoort 1991 spring between `point_a` of body `body_a` and `point_b` of body
    `body_b` (each in its body's frame, mm; bodies are indices into `Problem.bodies`).
    Called with the poses of all bodies, it gives its `Part`: the pull on both ends."""

    body_a: int
    point_a: np.ndarray
    body_b: int
    point_b: np.ndarray
    slack_length_mm: float
    stiffness_N: float
    transition_strain: float

    def ends(self, poses: Sequence[BodyPose]) -> tuple[np.ndarray, np.ndarray]:
        """World positions (mm) of the two attachments."""
        (ra, ta), (rb, tb) = poses[self.body_a], poses[self.body_b]
        return ra @ self.point_a + ta, rb @ self.point_b + tb

    def tension(self, poses: Sequence[BodyPose]) -> float:
        """Spring force at the poses, N (+ tension)."""
        x_a, x_b = self.ends(poses)
        return float(np.linalg.norm(_pull(self, x_a, x_b)[0]))

    def __call__(self, poses: Sequence[BodyPose]) -> Part:
        x_a, x_b = self.ends(poses)
        w, dw = two_point_force(x_a, x_b, *_pull(self, x_a, x_b))
        return (self.body_a, self.body_b), w, dw


def body_rod(body_a: int, point_a: np.ndarray, body_b: int, point_b: np.ndarray,
             length_mm: float) -> ConstraintFn:
    """Rod of constant length between two bodies' points (each in its body's frame, mm):
    the constraint g = |x_a − x_b| − L (mm); its multiplier is the rod tension (N)."""
    pa, pb = np.asarray(point_a, dtype=float), np.asarray(point_b, dtype=float)

    def constraint(poses: Sequence[BodyPose], parts=()):
        (ra, ta), (rb, tb) = poses[body_a], poses[body_b]
        x_a, x_b = ra @ pa + ta, rb @ pb + tb
        u, length = _direction(x_a, x_b)
        w, dw = two_point_force(x_a, x_b, u, -(np.eye(3) - np.outer(u, u)) / length)
        return length - length_mm, (body_a, body_b), w, dw

    return constraint


def spring_wrench(femur_point: np.ndarray, tibia_point: np.ndarray, reference_length_mm: float,
                  stiffness_N: float, reference_strain: float, transition_strain: float
                  ) -> SpringLigament:
    """A spring whose strain at `reference_length_mm` is `reference_strain`."""
    if reference_strain <= -1:
        raise FecheckError("ligament reference strain must be > -1")
    return SpringLigament(np.asarray(femur_point, float), np.asarray(tibia_point, float),
                          reference_length_mm / (1 + reference_strain), float(stiffness_N),
                          float(transition_strain))


def point_forces(x: np.ndarray, force: np.ndarray, jac: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Summed wrench (6,) of forces (n, 3) N at body points x (n, 3) mm (world) and its
    tangent dW/dξ (6, 6), each force changing with its point by `jac` (n, 3, 3)."""
    xs, fs = skew(x), skew(force)
    lower = xs @ jac - fs                       # dM/dx (n, 3, 3): [x]×J - [F]×
    dw = np.zeros((6, 6))
    dw[:3, :3] = jac.sum(axis=0)
    dw[:3, 3:] = -(jac @ xs).sum(axis=0)
    dw[3:, :3] = lower.sum(axis=0)
    dw[3:, 3:] = -(lower @ xs).sum(axis=0)
    return np.concatenate([force.sum(axis=0), np.cross(x, force).sum(axis=0)]), dw
