"""The statics' hot path: a contact pair and a compiled foundation law → the wrench on the
slave and its tangent, in one compiled call.

Newton needs, per compartment and iteration, the force, the moment, the 6x6 tangent and
whether anything touches. The full path (`ContactPair.evaluate` → `ContactSurface` → law
→ `LawResult`) also builds the per-point arrays and Python objects that a result or a
plot reads; here the master's contact kernel, the quadrature and the law's resultant run
in one compiled function that writes only the reduction, into one array (`Wrench`). For a
plane or sphere master that function also checks the poses and reuses or rebuilds the
candidate set (`closed_form_wrench`), so an evaluation is one compiled call; a
`HotPath` binds a pair and a law once, so that the call is made without per-call
lookups. The arithmetic is that of the full path, in the same order (tested equal to
1e-12), except for the linear law on a plane master (`plane_linear_wrench`, the case
`fecheck.studies.bench_peers` times): there the plane's normal, the same at every point,
is taken out of the sums, so that a quadrature point adds to a few running sums and the
tangent is formed once (the same terms regrouped; equal to 1e-12), and a rebuilt
candidate set is read as the ranks the tree query found, its faces' data not gathered
(`fecheck.contact.broadphase.region_ranks`). Masters without a compiled kernel
(polynomial, the thesis's detectors) and a mesh master whose candidate set is new, or
whose closest-point walk does not settle, go through the full path.

Units: mm, N, MPa; forces on the slave, moments about the world origin, tangent
d[F, M]/dξ for the slave's twist ξ = (v, ω) relative to the master.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from fecheck.contact.broadphase import checked_relative_pose, region_ranks, region_set
from fecheck.contact.clip import RULE, face_rule
from fecheck.contact.kernels import (
    mat_vec,
    plane_surface,
    sphere_surface,
    walked_mesh_surface,
)
from fecheck.contact.mesh_master import MAX_STEPS
from fecheck.contact.pair import checked_poses, raise_bad_pose
from fecheck.contact.surface import ContactSurface
from fecheck.errors import FecheckError
from fecheck.laws.foundation import foundation
from fecheck.laws.kernel import (
    LINEAR,
    close_resultant,
    law_function,
    law_values,
    pressure_resultant,
)

ORIGIN = np.zeros(3)
PACKED = 44
"""Length of a `Wrench`'s packed array."""


class Wrench:
    """The contact's resultant on the slave, held in one array ``packed`` (44,) that the
    compiled path fills in place: force (3,) N, moment (3,) N·mm, tangent (6, 6) row by
    row, contact area mm² and the largest vertex depth mm (0 without contact). The
    properties are views of it."""

    __slots__ = ("packed",)

    def __init__(self, packed: np.ndarray) -> None:
        self.packed = packed

    @classmethod
    def of(cls, force: np.ndarray, moment: np.ndarray, tangent: np.ndarray, area: float,
           max_depth: float) -> Wrench:
        """A `Wrench` of the given parts."""
        return cls(np.concatenate([force, moment, np.ravel(tangent), [area, max_depth]]))

    @property
    def wrench(self) -> np.ndarray:
        """[force, moment] (6,), N and N·mm."""
        return self.packed[:6]

    @property
    def force(self) -> np.ndarray:
        """Force (3,) on the slave, N."""
        return self.packed[:3]

    @property
    def moment(self) -> np.ndarray:
        """Moment (3,) about the world origin, N·mm."""
        return self.packed[3:6]

    @property
    def tangent(self) -> np.ndarray:
        """d[F, M]/dξ (6, 6)."""
        return self.packed[6:42].reshape(6, 6)

    @property
    def area(self) -> float:
        """Contact area, mm²."""
        return float(self.packed[42])

    @property
    def max_depth(self) -> float:
        """Largest vertex depth, mm (0 without contact)."""
        return float(self.packed[43])


@dataclass(frozen=True, eq=False)
class CompiledLaw:
    """A foundation law the hot path evaluates in compiled code: p = s_f·g(d), g the law
    `kind` with `params` (`fecheck.laws.kernel.law_values`), s_f the per-slave-face
    factor `face_scale` (empty: 1). `full` is the same law on a `ContactSurface`."""

    kind: int
    params: np.ndarray
    face_scale: np.ndarray
    full: object

    def __call__(self, surface: ContactSurface):
        return self.full(surface)


def compiled_law(kind: int, params: np.ndarray, full=None,
                 face_scale: np.ndarray | None = None) -> CompiledLaw:
    """A `CompiledLaw` (float arrays; no per-face factor by default). Without `full`, the
    full path is `fecheck.laws.foundation.foundation` of the same law (the linear law's
    own branch for LINEAR)."""
    params = np.ascontiguousarray(params, dtype=float)
    scale = np.zeros(0) if face_scale is None else np.ascontiguousarray(face_scale, dtype=float)
    pressure = float(params[0]) if kind == LINEAR else law_function(kind, params)

    def same_law(surface: ContactSurface):
        return foundation(surface, pressure)

    return CompiledLaw(kind, params, scale, same_law if full is None else full)


def linear_law(k_N_per_mm3: float) -> CompiledLaw:
    """The linear EF p = k·d (N/mm³) as a `CompiledLaw`."""
    return compiled_law(LINEAR, np.array([float(k_N_per_mm3)]))


@njit(cache=True, fastmath=False)
def pack(out, force, moment, tangent, area, deepest) -> None:
    """Write a wrench into `out` (44,): force, moment, the 6x6 tangent row-major, the
    contact area (mm²) and the deepest vertex depth (mm)."""
    out[:3] = force
    out[3:6] = moment
    for i in range(6):
        for k in range(6):
            out[6 + 6 * i + k] = tangent[i, k]
    out[42] = area
    out[43] = deepest


@njit(cache=True, fastmath=False)
def _reduce(surface, slave_normals, faces, kind, params, face_scale, about, out):
    """Resultant of the law over `surface`, the arrays a contact kernel returns, as
    `fecheck.laws.foundation.foundation` forms it, written into `out` (a `Wrench`'s
    packed array)."""
    (hit, normal, vertex_depth, qp_face, _, qp_point, qp_depth, qp_weight, qp_depth_twist,
     qp_weight_twist, qp_clip, clip_share, clip_face, clip_edge, clip_rate) = surface
    slide = np.zeros((0, 3, 6))
    if hit.size == 0:
        out[:] = 0.0
        return
    if kind == LINEAR and face_scale.size == 0:
        stiffness, p, slope = params[0], np.zeros(0), np.zeros(0)
    else:
        stiffness = 0.0
        p, slope = law_values(kind, params, np.maximum(qp_depth, 0.0))
        if face_scale.size:
            for q in range(p.size):
                s = face_scale[faces[hit[qp_face[q]]]]
                p[q] *= s
                slope[q] *= s
    _, force, moment, tangent, area = pressure_resultant(
        stiffness, p, slope, qp_depth, qp_weight, qp_depth_twist, qp_weight_twist, qp_point,
        normal, qp_face, slave_normals, slide, qp_clip, clip_share, clip_face, clip_edge,
        clip_rate, about)
    pack(out, force, moment, tangent, area, vertex_depth.max())


# One fused compiled loop over the faces for speed (the cases of one face kept together).
@njit(cache=True, fastmath=False)
def plane_linear_wrench(clipped, ranks, corners, normals, areas, points, size, R, t,  # noqa: C901
                        Rm, tm, Rs, plane_point, plane_normal, stiffness, about, out):
    """The linear law p = k·d (`stiffness` k, N/mm³) against a plane master, written into
    `out` (a `Wrench`'s packed array): `fecheck.contact.kernels.plane_surface`, its
    `surface_quadrature` (points fixed in the face: the linear law's case) and
    `_reduce`'s `pressure_resultant` in one pass over the candidate faces, each
    quadrature point's contribution summed as it is formed, with no per-point arrays.

    The candidates are the faces `ranks` (m,) of the broad phase's tables in rank order
    (`fecheck.contact.bvh.owner_tables`): corners (n_faces, 3) slave vertex indices,
    outward normals (n_faces, 3), areas (n_faces,) mm²; points (n_points, 3) the slave
    vertices (slave frame, mm), all within `size` mm of the slave origin. A face is
    skipped when no corner can be below the plane (its depth along the plane normal
    carried into the slave frame, within a round-off bound); the others get the vertex
    depths and positions of `plane_surface`, by the same arithmetic. Poses and the
    plane as for `plane_surface`.
    """
    n0, n1, n2 = plane_normal[0], plane_normal[1], plane_normal[2]
    offset = plane_point[0] * n0 + plane_point[1] * n1 + plane_point[2] * n2
    s0, s1, s2 = (R[0, 0] * n0 + R[1, 0] * n1 + R[2, 0] * n2,      # Rᵀn, slave frame
                  R[0, 1] * n0 + R[1, 1] * n1 + R[2, 1] * n2,
                  R[0, 2] * n0 + R[1, 2] * n1 + R[2, 2] * n2)
    level = offset - (t[0] * n0 + t[1] * n1 + t[2] * n2)        # depth = level - Rᵀn·p
    slack = 1e-9 * (1.0 + abs(offset) + abs(level) + 3.0 * size)   # ≫ round-off, mm
    w0, w1, w2 = mat_vec(Rm, n0, n1, n2)                  # the normal in the world
    g0, g1, g2 = -w0, -w1, -w2                            # ∂d/∂x of every vertex
    D = np.empty(3)
    X = np.empty((3, 3))
    bary = np.empty((6, 3))
    frac = np.empty(6)
    corner = np.empty((6, 3))
    RA = np.zeros(3)                                      # Σ_f rate_f Σ_q p·a
    RX = np.zeros((3, 3))                                 # Σ_f (Σ_q p·a·x) rate_fᵀ
    S = S0 = S1 = S2 = area = 0.0                         # Σ_q s_q, Σ_q s_q x_q
    Sd = Sd0 = Sd1 = Sd2 = Se0 = Se1 = Se2 = 0.0          # Σ dpw, Σ dpw x, Σ dpw e
    M00 = M01 = M02 = M10 = M11 = M12 = M20 = M21 = M22 = 0.0   # Σ dpw x eᵀ
    hits, deepest_vertex = 0, -np.inf
    for f in ranks:
        near = False
        for j in range(3):
            v = corners[f, j]
            depth = level - (s0 * points[v, 0] + s1 * points[v, 1] + s2 * points[v, 2])
            near |= depth > -slack
        if not near:
            continue
        for j in range(3):
            v = corners[f, j]
            y0, y1, y2 = mat_vec(R, points[v, 0], points[v, 1], points[v, 2])
            y0, y1, y2 = y0 + t[0], y1 + t[1], y2 + t[2]
            D[j] = offset - (y0 * n0 + y1 * n1 + y2 * n2)
            x0, x1, x2 = mat_vec(Rm, y0, y1, y2)
            x0, x1, x2 = x0 + tm[0], x1 + tm[1], x2 + tm[2]
            X[j, 0], X[j, 1], X[j, 2] = x0, x1, x2
        if not (D[0] > 0.0 or D[1] > 0.0 or D[2] > 0.0):
            continue
        hits += 1
        deepest_vertex = max(deepest_vertex, D[0], D[1], D[2])
        a0, a1, a2 = mat_vec(Rs, normals[f, 0], normals[f, 1], normals[f, 2])
        cos = a0 * w0 + a1 * w1 + a2 * w2
        sign = 1.0 if cos > 0.0 else (-1.0 if cos < 0.0 else 0.0)
        cos_abs = abs(cos)
        rate3 = sign * (a1 * w2 - a2 * w1)                # ∂cos/∂ω = n_face × n
        rate4 = sign * (a2 * w0 - a0 * w2)
        rate5 = sign * (a0 * w1 - a1 * w0)
        if clipped:
            n_q = face_rule(D[0], D[1], D[2], bary, frac, 0, corner)
        else:
            n_q = 3
            for q in range(3):
                for k in range(3):
                    bary[q, k] = RULE[q, k]
                frac[q] = 1.0 / 3.0
        deepest = 0
        for j in range(1, 3):
            if D[j] > D[deepest]:
                deepest = j
        pa = pa0 = pa1 = pa2 = 0.0
        for q in range(n_q):
            b0, b1, b2 = bary[q, 0], bary[q, 1], bary[q, 2]
            x0 = b0 * X[0, 0] + b1 * X[1, 0] + b2 * X[2, 0]
            x1 = b0 * X[0, 1] + b1 * X[1, 1] + b2 * X[2, 1]
            x2 = b0 * X[0, 2] + b1 * X[1, 2] + b2 * X[2, 2]
            if clipped:                                   # the depth and its arm e
                depth = b0 * D[0] + b1 * D[1] + b2 * D[2]
                e0, e1, e2 = x0, x1, x2
            else:
                depth = D[deepest]
                e0, e1, e2 = X[deepest, 0], X[deepest, 1], X[deepest, 2]
            a = frac[q] * areas[f]
            w = a * cos_abs
            if depth <= 0.0:
                continue
            p = stiffness * depth
            dpw = stiffness * w
            s = w * p
            area += w
            Sd += dpw
            Sd0, Sd1, Sd2 = Sd0 + dpw * x0, Sd1 + dpw * x1, Sd2 + dpw * x2
            Se0, Se1, Se2 = Se0 + dpw * e0, Se1 + dpw * e1, Se2 + dpw * e2
            c0, c1, c2 = dpw * x0, dpw * x1, dpw * x2
            M00, M01, M02 = M00 + c0 * e0, M01 + c0 * e1, M02 + c0 * e2
            M10, M11, M12 = M10 + c1 * e0, M11 + c1 * e1, M12 + c1 * e2
            M20, M21, M22 = M20 + c2 * e0, M21 + c2 * e1, M22 + c2 * e2
            pa_q = p * a
            pa += pa_q
            pa0, pa1, pa2 = pa0 + pa_q * x0, pa1 + pa_q * x1, pa2 + pa_q * x2
            S += s
            S0 += s * x0
            S1 += s * x1
            S2 += s * x2
        rate = (rate3, rate4, rate5)                      # the weight's twist, ∂w/∂ω / a
        for k in range(3):
            RA[k] += pa * rate[k]
            RX[0, k] += pa0 * rate[k]
            RX[1, k] += pa1 * rate[k]
            RX[2, k] += pa2 * rate[k]
    if hits == 0:
        out[:] = 0.0
        return
    # gq = dpw·(g, e × g) + p·a·(0, rate) (the depth twist of a point, at arm e: the point
    # itself on clipped faces, the deepest vertex on whole faces; g = -w the depth
    # gradient); with the unit wrench [w, x × w], the tangent Σ [w, x × w] gqᵀ follows
    # from G = Σ gq and XG = Σ x gqᵀ, formed from Σ dpw, Σ dpw x, Σ dpw e, M = Σ dpw x eᵀ
    # and the rate sums RA, RX; the force, moment and Σ x Fᵀ from S = Σ s and Σ s x
    G = np.empty(6)
    XG = np.empty((3, 6))
    G[0], G[1], G[2] = g0 * Sd, g1 * Sd, g2 * Sd
    G[3] = Se1 * g2 - Se2 * g1 + RA[0]
    G[4] = Se2 * g0 - Se0 * g2 + RA[1]
    G[5] = Se0 * g1 - Se1 * g0 + RA[2]
    for i, (sd, mi0, mi1, mi2) in enumerate(((Sd0, M00, M01, M02), (Sd1, M10, M11, M12),
                                            (Sd2, M20, M21, M22))):
        XG[i, 0], XG[i, 1], XG[i, 2] = sd * g0, sd * g1, sd * g2
        XG[i, 3] = mi1 * g2 - mi2 * g1 + RX[i, 0]
        XG[i, 4] = mi2 * g0 - mi0 * g2 + RX[i, 1]
        XG[i, 5] = mi0 * g1 - mi1 * g0 + RX[i, 2]
    tangent = np.empty((6, 6))
    for k in range(6):
        tangent[0, k], tangent[1, k], tangent[2, k] = w0 * G[k], w1 * G[k], w2 * G[k]
        tangent[3, k] = XG[1, k] * w2 - XG[2, k] * w1
        tangent[4, k] = XG[2, k] * w0 - XG[0, k] * w2
        tangent[5, k] = XG[0, k] * w1 - XG[1, k] * w0
    xf = np.empty((3, 3))
    for i, si in enumerate((S0, S1, S2)):
        xf[i, 0], xf[i, 1], xf[i, 2] = si * w0, si * w1, si * w2
    force, moment = close_resultant(tangent, S * w0, S * w1, S * w2, S1 * w2 - S2 * w1,
                                    S2 * w0 - S0 * w2, S0 * w1 - S1 * w0, xf, False, about)
    pack(out, force, moment, tangent, area, deepest_vertex)


@njit(cache=True, fastmath=False)
def closed_form_wrench(state, Rs, ts, Rm, tm, sphere, master, clipped, kind, params,
                       face_scale, about, out):
    """One evaluation against a plane or sphere master in one compiled call: the poses
    checked, the candidate set reused or rebuilt (`fecheck.contact.broadphase.region_set`
    on the pair's `BroadPhaseState`), the master's contact kernel
    (`fecheck.contact.kernels.plane_surface` for master = (point, normal), or
    `sphere_surface` for master = (centre, radius)) and the law's resultant, written into
    `out` (a `Wrench`'s packed array).

    Returns the slave's and the master's pose status (`pose_status`); `out` holds no
    contact when one is not 0.
    """
    out[:] = 0.0
    R, t, slave_status, master_status = checked_relative_pose(Rs, ts, Rm, tm)
    if slave_status or master_status:
        return slave_status, master_status
    moving = kind != LINEAR
    if not (sphere or moving or face_scale.size):      # the set's face data not gathered
        region_ranks(state, R, t)
        c = state.centroid
        size = np.sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]) + state.radius
        plane_linear_wrench(clipped, state.cand_ranks, state.corners, state.normals,
                            state.areas, state.points, size, R, t, Rm, tm, Rs,
                            master[:3], master[3:], params[0], about, out)
        return 0, 0
    region_set(state, R, t)
    if state.cand_faces.size == 0:
        return 0, 0
    if sphere:
        surface = sphere_surface(clipped, moving, state.cand_points, state.cand_local,
                                 state.cand_normals, state.cand_areas, R, t, Rm, tm, Rs,
                                 master[:3], master[3])
    else:
        surface = plane_surface(clipped, moving, state.cand_points, state.cand_local,
                                state.cand_normals, state.cand_areas, R, t, Rm, tm, Rs,
                                master[:3], master[3:])
    _reduce(surface, sphere, state.cand_faces, kind, params, face_scale, about, out)
    return 0, 0


@njit(cache=True, fastmath=False)
def walked_mesh_wrench(clipped, points, local_faces, normals, areas, faces, R, t, Rm, tm, Rs,
                       E, ring_ptr, ring_index, master_normals, rim, rim_mm, face, position,
                       upper, travel, ring, max_steps, kind, params, face_scale, about, out):
    """`fecheck.contact.kernels.walked_mesh_surface` and the law's resultant (into `out`,
    a `Wrench`'s packed array) in one call; whether the walk settled."""
    surface = walked_mesh_surface(clipped, kind != LINEAR, points, local_faces, normals,
                                  areas, R, t, Rm, tm, Rs, E, ring_ptr, ring_index,
                                  master_normals, rim, rim_mm, face, position, upper, travel,
                                  ring, max_steps)
    _reduce(surface[1:], True, faces, kind, params, face_scale, about, out)
    return surface[0]


def _entry_point(dispatcher, args: tuple):
    """The compiled function that numba's `dispatcher` runs for `args` (compiled or loaded
    from the on-disk cache now), to be called with arguments of exactly `args`' types.

    A dispatcher types every argument on every call; for the broad-phase state object
    that goes through Python (~0.6 µs) and the whole typing costs ~1 µs of a ~12 µs
    evaluation. Where numba does not expose the compiled function, the dispatcher."""
    dispatcher(*args)
    try:
        return dispatcher.overloads[tuple(dispatcher.typeof_pyval(a) for a in args)].entry_point
    except (AttributeError, KeyError, TypeError):
        return dispatcher


class HotPath:
    """`contact_wrench` of one pair with one law, bound once (a compartment's, for every
    Newton iteration): which path applies, the master's and the law's arguments and the
    compiled function are looked up here, so that an evaluation is the pose checks and
    one compiled call. Binding compiles the kernel, or loads it from numba's on-disk
    cache (a model's build, not its first solve).

    ``evaluate(slave_pose, master_pose)`` → `Wrench` (see `contact_wrench`).
    """

    def __init__(self, pair, law) -> None:
        self.pair, self.law = pair, law
        if not isinstance(law, CompiledLaw) or pair.resolved_method not in ("closed-form",
                                                                             "bvh"):
            self.evaluate = self._full
            return
        if law.face_scale.size and law.face_scale.size != pair.slave.n_faces:
            raise FecheckError(f"{law.face_scale.size} face stiffnesses for a slave mesh of "
                               f"{pair.slave.n_faces} faces")
        self._clipped = pair.area_mode == "clipped"
        closed_form = pair.closed_form_master
        eye, zero = np.eye(3), np.zeros(3)
        if closed_form is not None:
            self._state = pair.cache.state
            self._args = (*closed_form, self._clipped, law.kind, law.params, law.face_scale,
                          ORIGIN)
            # a NaN pose returns before any work
            self._kernel = _entry_point(closed_form_wrench, (
                self._state, eye, np.full(3, np.nan), eye, zero, *self._args,
                np.empty(PACKED)))
            self.evaluate = self._closed_form
            return
        self.evaluate = self._walked
        if pair.resolved_method == "bvh" and pair.master.sign == "normal":
            no_points, none = np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
            state = pair.master.empty_state()
            walked_mesh_wrench(True, no_points, np.zeros((0, 3), dtype=np.int64), no_points,
                               np.zeros(0), none, eye, zero, eye, zero, eye,
                               *pair.walk_tables, state.face, state.position,
                               state.upper, state.travel, state.ring, MAX_STEPS, law.kind,
                               law.params, law.face_scale, ORIGIN, np.empty(PACKED))

    def _closed_form(self, slave_pose, master_pose) -> Wrench:
        """A plane or sphere master: `closed_form_wrench`."""
        Rs, ts, Rm, tm = checked_poses(slave_pose, master_pose)  # the kernel's exact types
        out = np.empty(PACKED)
        slave_status, master_status = self._kernel(self._state, Rs, ts, Rm, tm, *self._args,
                                                   out)
        if slave_status or master_status:
            raise_bad_pose(slave_status, "slave")
            raise_bad_pose(master_status, "master")
        return Wrench(out)

    def _walked(self, slave_pose, master_pose) -> Wrench:
        """A mesh master: `walked_mesh_wrench` from the warm closest-point state, or the
        full path where the set is new or the walk does not settle."""
        pair, law = self.pair, self.law
        cand, R, t, Rs, _, Rm, tm = pair.prepare(slave_pose, master_pose)
        if cand.faces.size == 0:
            return Wrench(np.zeros(PACKED))
        state = pair.warm_state(cand)
        master = pair.master
        if pair.resolved_method == "closed-form" or state is None or master.sign != "normal":
            return self._full(slave_pose, master_pose)
        out = np.empty(PACKED)
        if walked_mesh_wrench(
                self._clipped, cand.points, cand.local_faces, cand.normals, cand.areas,
                cand.faces, R, t, Rm, tm, Rs, *pair.walk_tables, state.face, state.position,
                state.upper, state.travel, state.ring, MAX_STEPS, law.kind, law.params,
                law.face_scale, ORIGIN, out):
            return Wrench(out)
        return self._full(slave_pose, master_pose)

    def _full(self, slave_pose, master_pose) -> Wrench:
        """The law on the full `ContactSurface`."""
        res = self.law(self.pair.evaluate(slave_pose, master_pose))
        return Wrench.of(res.force, res.moment, res.tangent, res.area, res.max_depth)


def contact_wrench(pair, slave_pose, master_pose, law) -> Wrench:
    """The wrench of `law` over the contact of `pair` at the given poses (see the module;
    for repeated evaluations bind a `HotPath` once).

    Parameters
    ----------
    pair : `fecheck.contact.ContactPair`
    slave_pose, master_pose : (R (3, 3), t (3,) mm), body frame to world
    law : a `CompiledLaw` (compiled path), or any law on a `ContactSurface` (full path)

    Moments are about the world origin, as the laws give them.
    """
    return HotPath(pair, law).evaluate(slave_pose, master_pose)
