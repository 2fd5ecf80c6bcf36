"""The statics' hot path: a contact pair and a compiled foundation law → the wrench on the
slave and its tangent, in one compiled call.

Newton needs, per compartment and iteration, the force, the moment, the 6x6 tangent and
whether anything touches. The full path (`ContactPair.evaluate` → `ContactSurface` → law
→ `LawResult`) also builds the per-point arrays and Python objects that a result or a
plot reads; here the master's contact kernel, the quadrature and the law's resultant run
in one compiled function that returns only the reduction. For a plane or sphere master
that function also checks the poses and reuses or rebuilds the candidate set
(`closed_form_wrench`), so an evaluation is one compiled call. The arithmetic is that of
the full path, in the same order (tested equal to 1e-12). Masters without a compiled kernel
(polynomial, the thesis's detectors) and a mesh master whose candidate set is new, or
whose closest-point walk does not settle, go through the full path.

Units: mm, N, MPa; forces on the slave, moments about the world origin, tangent
d[F, M]/dξ for the slave's twist ξ = (v, ω) relative to the master.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import njit

from fecheck.contact.broadphase import checked_relative_pose, region_set
from fecheck.contact.kernels import plane_surface, sphere_surface, walked_mesh_surface
from fecheck.contact.mesh_master import MAX_STEPS
from fecheck.contact.pair import checked_poses, raise_bad_pose
from fecheck.contact.surface import ContactSurface
from fecheck.errors import FecheckError
from fecheck.laws.foundation import foundation
from fecheck.laws.kernel import LINEAR, law_function, law_values, pressure_resultant

ORIGIN = np.zeros(3)


class Wrench(NamedTuple):
    """Force (3,) N and moment (3,) N·mm on the slave, tangent (6, 6), contact area mm²
    and the largest vertex depth mm (0 without contact)."""

    force: np.ndarray
    moment: np.ndarray
    tangent: np.ndarray
    area: float
    max_depth: float


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
def _reduce(surface, slave_normals, faces, kind, params, face_scale, about):
    """Resultant of the law over `surface`, the arrays a contact kernel returns, as
    `fecheck.laws.foundation.foundation` forms it: (force, moment, tangent, area,
    max_depth)."""
    (hit, normal, vertex_depth, qp_face, _, qp_point, qp_depth, qp_weight, qp_depth_twist,
     qp_weight_twist, qp_clip, clip_share, clip_face, clip_edge, clip_rate) = surface
    slide = np.zeros((0, 3, 6))
    if hit.size == 0:
        return np.zeros(3), np.zeros(3), np.zeros((6, 6)), 0.0, 0.0
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
    return force, moment, tangent, area, vertex_depth.max()


@njit(cache=True, inline="always")
def _no_contact():
    return np.zeros(3), np.zeros(3), np.zeros((6, 6)), 0.0, 0.0


@njit(cache=True, fastmath=False)
def closed_form_wrench(state, Rs, ts, Rm, tm, sphere, master, clipped, kind, params,
                       face_scale, about):
    """One evaluation against a plane or sphere master in one compiled call: the poses
    checked, the candidate set reused or rebuilt (`fecheck.contact.broadphase.region_set`
    on the pair's `BroadPhaseState`), the master's contact kernel
    (`fecheck.contact.kernels.plane_surface` for master = (point, normal), or
    `sphere_surface` for master = (centre, radius)) and the law's resultant.

    Returns (slave pose status, master pose status (`pose_status`), (force, moment,
    tangent, area, max_depth)); no contact when a status is not 0.
    """
    R, t, slave_status, master_status = checked_relative_pose(Rs, ts, Rm, tm)
    if slave_status or master_status:
        return slave_status, master_status, _no_contact()
    region_set(state, R, t)
    if state.cand_faces.size == 0:
        return 0, 0, _no_contact()
    moving = kind != LINEAR
    if sphere:
        surface = sphere_surface(clipped, moving, state.cand_points, state.cand_local,
                                 state.cand_normals, state.cand_areas, R, t, Rm, tm, Rs,
                                 master[:3], master[3])
    else:
        surface = plane_surface(clipped, moving, state.cand_points, state.cand_local,
                                state.cand_normals, state.cand_areas, R, t, Rm, tm, Rs,
                                master[:3], master[3:])
    return 0, 0, _reduce(surface, sphere, state.cand_faces, kind, params, face_scale, about)


@njit(cache=True, fastmath=False)
def walked_mesh_wrench(clipped, points, local_faces, normals, areas, faces, R, t, Rm, tm, Rs,
                       E, ring_ptr, ring_index, master_normals, face, position, upper,
                       travel, ring, max_steps, kind, params, face_scale, about):
    """`fecheck.contact.kernels.walked_mesh_surface` and the law's resultant in one call;
    (settled, force, moment, tangent, area, max_depth)."""
    out = walked_mesh_surface(clipped, kind != LINEAR, points, local_faces, normals, areas, R,
                              t, Rm, tm, Rs, E, ring_ptr, ring_index, master_normals, face,
                              position, upper, travel, ring, max_steps)
    return (out[0],) + _reduce(out[1:], True, faces, kind, params, face_scale, about)


_NO_CONTACT = (np.zeros(3), np.zeros(3), np.zeros((6, 6)), 0.0, 0.0)


def contact_wrench(pair, slave_pose, master_pose, law) -> Wrench:
    """The wrench of `law` over the contact of `pair` at the given poses (see the module).

    Parameters
    ----------
    pair : `fecheck.contact.ContactPair`
    slave_pose, master_pose : (R (3, 3), t (3,) mm), body frame to world
    law : a `CompiledLaw` (compiled path), or any law on a `ContactSurface` (full path)

    Moments are about the world origin, as the laws give them.
    """
    if not isinstance(law, CompiledLaw) or pair.resolved_method not in ("closed-form", "bvh"):
        return _full(pair, slave_pose, master_pose, law)
    if law.face_scale.size and law.face_scale.size != pair.slave.n_faces:
        raise FecheckError(f"{law.face_scale.size} face stiffnesses for a slave mesh of "
                           f"{pair.slave.n_faces} faces")
    clipped = pair.area_mode == "clipped"
    closed_form = pair.closed_form_master
    if closed_form is not None:
        Rs, ts, Rm, tm = checked_poses(slave_pose, master_pose)
        slave_status, master_status, out = closed_form_wrench(
            pair.cache.state, Rs, ts, Rm, tm, *closed_form, clipped, law.kind, law.params,
            law.face_scale, ORIGIN)
        if slave_status or master_status:
            raise_bad_pose(slave_status, "slave")
            raise_bad_pose(master_status, "master")
        return Wrench(*out)
    cand, R, t, Rs, _, Rm, tm = pair.prepare(slave_pose, master_pose)
    if cand.faces.size == 0:
        return Wrench(*_NO_CONTACT)
    state = pair.warm_state(cand)
    master = pair.master
    if pair.resolved_method == "closed-form" or state is None or master.sign != "normal":
        return _full(pair, slave_pose, master_pose, law)
    settled, *out = walked_mesh_wrench(
        clipped, cand.points, cand.local_faces, cand.normals, cand.areas, cand.faces, R, t,
        Rm, tm, Rs, *master.walk_tables, state.face, state.position, state.upper,
        state.travel, state.ring, MAX_STEPS, law.kind, law.params, law.face_scale, ORIGIN)
    if settled:
        return Wrench(*out)
    return _full(pair, slave_pose, master_pose, law)


def _full(pair, slave_pose, master_pose, law) -> Wrench:
    res = law(pair.evaluate(slave_pose, master_pose))
    return Wrench(res.force, res.moment, res.tangent, res.area, res.max_depth)


def load(pair, law) -> None:
    """Compile the hot-path kernel that `pair` with `law` will use, or load it from
    numba's on-disk cache, now (a model's build) rather than in the first solve."""
    if not isinstance(law, CompiledLaw) or pair.resolved_method not in ("closed-form", "bvh"):
        return
    eye, zero = np.eye(3), np.zeros(3)
    closed_form = pair.closed_form_master
    if closed_form is not None:                 # a NaN pose returns before any work
        closed_form_wrench(pair.cache.state, eye, np.full(3, np.nan), eye, zero,
                           *closed_form, True, law.kind, law.params, law.face_scale, ORIGIN)
    elif pair.resolved_method == "bvh" and pair.master.sign == "normal":
        no_points, none = np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
        empty = (True, no_points, np.zeros((0, 3), dtype=np.int64), no_points, np.zeros(0),
                 none, eye, zero, eye, zero, eye)
        state = pair.master.empty_state()
        walked_mesh_wrench(*empty, *pair.master.walk_tables, state.face, state.position,
                           state.upper, state.travel, state.ring, MAX_STEPS, law.kind,
                           law.params, law.face_scale, ORIGIN)
