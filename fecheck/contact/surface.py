"""The contact surface: the data object between detection and contact laws.

Conventions (mm, world frame = the thesis frame, see `fecheck.statics.frames`):

* The **slave** is a triangle mesh; the **master** is an analytic surface or a mesh.
* Depth is positive where the slave is inside the master. `normal` is the unit
  **foundation normal** of each face: the direction in which the elastic foundation's
  springs act, i.e. the direction of the pressure ON THE SLAVE (out of the master).

  - Plane master: the plane's outward normal; depth along it.
  - Polynomial master z = f(x, y) (inside below): the upward surface normal at the
    vertical foot of the face centroid; depth (f - z)/√(1 + |∇f|²), the first-order
    normal distance (exact for a plane; see `fecheck.contact.analytic`).
  - Analytic sphere master over a meshed plateau: MINUS the slave face's outward
    normal (the plateau is pushed down into itself); depth along that line from the
    slave point to the sphere, so that a flat plateau gets the exact cap volume.
  - Mesh master: minus the slave face's outward normal; depth = signed closest-point
    distance to the master (see `fecheck.contact.mesh_master`).

* Depth is linear over each face (interpolated from its vertices). The in-contact
  part of a face is the face clipped at zero depth. In the thesis's ``whole-face``
  mode every face with a vertex in contact counts whole and all its points carry its
  largest vertex depth (this reproduces the thesis's Table 5.3 depths, see
  `fecheck.contact.pair`). Integrals are given as a quadrature: points with
  barycentric coordinates on their face and area weights. For master normals
  (plane, polynomial) weights are areas projected onto the plane normal to `normal`,
  so that for a sphere against a plane Σ w·d is the cap volume; for slave normals
  (sphere and mesh masters) they are the plain slave areas.
* A rule of degree 2 is exact for the linear EF law; nonlinear laws use the same points.

Derivatives (for the analytic tangent) are with respect to a small rigid motion of the
slave relative to the master, the twist ``ξ = (v, ω)``: a slave point moves by
``δx = v + ω × x`` (x in world coordinates, about the world origin), its normal by
``ω × n`` if the normal is fixed in the slave (``normal_body == "slave"``) and not at
all if it is fixed in the master (``normal_body == "master"``), except for the
polynomial master's normals, which slide with the contact (`normal_slide`;
`normal_twist` gives the total ∂normal/∂ξ in every case). Quadrature points on whole
faces keep their barycentric coordinates under the motion; those on a face cut by the
clip line move with it (their depth and weight twists include that motion, and the
`clip_*` fields give their slide within the face), so that every law's tangent is the
exact derivative of its discrete resultant.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Literal

import numpy as np

from fecheck.contact.kernels import surface_quadrature


@dataclass(eq=False)
class ContactSurface:
    """Penetration of a slave mesh into a master at one relative pose (read-only by
    convention: not frozen, because a frozen dataclass's constructor costs ~1 µs more
    per contact evaluation, measured).

    Per contact face (m faces with some positive depth):

    face : (m,) int, slave face index
    normal : (m, 3) unit foundation normal (direction of the pressure on the slave)
    vertex_depth : (m, 3) signed depth at the face's vertices, mm

    Per quadrature point (Q points):

    qp_face : (Q,) int, index into the m contact faces
    qp_bary : (Q, 3) barycentric coordinates on that face
    qp_point : (Q, 3) world position, mm
    qp_depth : (Q,) depth, mm (may be ≤ 0 in whole-face mode; laws clamp at 0)
    qp_weight : (Q,) projected area weight, mm²
    qp_depth_twist : (Q, 6) ∂depth/∂ξ, (1, mm) for (v, ω)
    qp_weight_twist : (Q, 6) ∂weight/∂ξ, (mm, mm²)

    Faces cut by the clip line (C faces; none in whole-face mode): a point on a cut face
    slides within it, beyond the rigid motion δx = v + ω × x, by
    ``Σ_e clip_share[q, e] · clip_edge[c, e] ⊗ clip_rate[c, e]`` (c = qp_clip[q]):

    qp_clip : (Q,) int, the cut face of each point (−1: none; empty in whole-face mode)
    clip_share : (Q, 2) the point's rule weights of the two moving corners
    clip_face : (C,) int, index into the m contact faces
    clip_edge : (C, 2, 3) world vectors X_j − X_i of the two cut edges, mm
    clip_rate : (C, 2, 6) ∂t/∂ξ of their zero-depth points t = d_i/(d_i − d_j), (1/mm, 1)

    normal_body : "master" or "slave", which body the normals are fixed in
    n_slave_faces : faces of the whole slave mesh (for reporting per-face fields)
    normal_slide : (m, 3, 6) or None, the part of ∂normal/∂ξ of master normals that
        slide over a curved master (polynomial: the normal is taken at the contact);
        None means zero. `normal_twist` adds the rotation ``ω × n`` of slave normals.
    """

    face: np.ndarray
    normal: np.ndarray
    vertex_depth: np.ndarray
    qp_face: np.ndarray
    qp_bary: np.ndarray
    qp_point: np.ndarray
    qp_depth: np.ndarray
    qp_weight: np.ndarray
    qp_depth_twist: np.ndarray
    qp_weight_twist: np.ndarray
    qp_clip: np.ndarray
    clip_share: np.ndarray
    clip_face: np.ndarray
    clip_edge: np.ndarray
    clip_rate: np.ndarray
    normal_body: Literal["master", "slave"]
    n_slave_faces: int
    normal_slide: np.ndarray | None = None

    @cached_property
    def normal_twist(self) -> np.ndarray:
        """(m, 3, 6) ∂normal/∂ξ, (1/mm, 1): ``ω × n`` for slave normals, zero for a plane
        master, the curvature term `normal_slide` for a polynomial master."""
        out = np.zeros((self.n_faces, 3, 6))
        if self.normal_body == "slave":
            n = self.normal
            out[:, 0, 4], out[:, 0, 5] = n[:, 2], -n[:, 1]     # ω × n = -[n]× ω
            out[:, 1, 3], out[:, 1, 5] = -n[:, 2], n[:, 0]
            out[:, 2, 3], out[:, 2, 4] = n[:, 1], -n[:, 0]
        if self.normal_slide is not None:
            out += self.normal_slide
        return out

    @property
    def n_faces(self) -> int:
        """Number of slave faces in contact."""
        return len(self.face)

    @property
    def area(self) -> float:
        """Total in-contact (projected) area, mm²."""
        return float(self.qp_weight.sum())

    @property
    def max_depth(self) -> float:
        """Largest vertex depth among the contact faces, mm (0 with no contact)."""
        return float(self.vertex_depth.max()) if self.vertex_depth.size else 0.0

    def face_sum(self, values: np.ndarray) -> np.ndarray:
        """Sum per-quadrature-point values onto their contact faces, shape (m, …)."""
        values = np.asarray(values)
        out = np.zeros((self.n_faces,) + values.shape[1:])
        np.add.at(out, self.qp_face, values)
        return out

    @property
    def face_area(self) -> np.ndarray:
        """(m,) in-contact projected area of each contact face, mm²."""
        return np.bincount(self.qp_face, self.qp_weight, minlength=self.n_faces)

    @property
    def face_depth_integral(self) -> np.ndarray:
        """(m,) ∫ depth dA over each contact face, mm³ (depth clamped at 0)."""
        d = np.maximum(self.qp_depth, 0.0)
        return np.bincount(self.qp_face, self.qp_weight * d, minlength=self.n_faces)

    @classmethod
    def empty(cls, n_slave_faces: int, normal_body: Literal["master", "slave"]) -> ContactSurface:
        """A contact surface with no contact."""
        z = np.zeros
        return cls(z(0, int), z((0, 3)), z((0, 3)), z(0, int), z((0, 3)), z((0, 3)), z(0),
                   z(0), z((0, 6)), z((0, 6)), z(0, int), z((0, 2)), z(0, int), z((0, 2, 3)),
                   z((0, 2, 6)), normal_body, n_slave_faces)


def apply_pose(a: np.ndarray, R: np.ndarray, t: np.ndarray | None = None) -> np.ndarray:
    """R a (+ t) for an array of 3-vectors of any leading shape."""
    out = a.reshape(-1, 3) @ R.T
    if t is not None:
        out += t
    return out.reshape(a.shape)


def cross_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b over the last axis (cheaper than np.cross on small arrays)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def build_surface(master, area_mode: str, n_slave_faces: int, cand, hit: np.ndarray,
                  D: np.ndarray, Y: np.ndarray, R: np.ndarray, Rm: np.ndarray,
                  tm: np.ndarray, Rs: np.ndarray, g: np.ndarray | None = None
                  ) -> ContactSurface:
    """Quadrature, twist derivatives and normals of the contact faces `hit` of `cand`,
    for masters with a depth gradient per point (polynomial, the thesis's ray parity;
    `Plane`, `Sphere` and mesh masters have compiled kernels, `fecheck.contact.kernels`).

    D (m, 3) vertex depths and Y (m, 3, 3) vertex positions in the master frame (mm);
    R the slave-to-master rotation; (Rm, tm) the master pose; Rs the slave rotation;
    g (m, 3, 3) the depth gradients if already known (master frame).
    """
    m = len(hit)
    X = apply_pose(Y, Rm, tm)                                 # (m, 3, 3) world vertices
    if g is None:
        g = master.depth_gradients(Y)[0]
    gw = apply_pose(g, Rm)
    T = np.concatenate([gw, cross_rows(X, gw)], axis=-1)      # ∂d/∂v, ∂d/∂ω per vertex
    slide = None
    if master.normal_body == "slave":
        N = -apply_pose(cand.normals[hit], Rs)
        cos_abs, rate = np.ones(m), np.zeros((m, 6))
    else:
        nf_w = apply_pose(cand.normals[hit], Rs)
        Nm, dN = master.foundation_normals(Y)
        N = apply_pose(Nm, Rm)
        cos = np.einsum("ij,ij->i", nf_w, N)
        dcos = np.zeros((m, 6))
        dcos[:, 3:] = cross_rows(nf_w, N)
        if dN is not None:
            A = Rm @ dN @ Rm.T                           # ∂N/∂(centroid), world
            slide = np.concatenate([A, -A @ skew_rows(X.sum(axis=1) / 3.0)], axis=-1)
            dcos += np.einsum("ij,ijk->ik", nf_w, slide)
        cos_abs, rate = np.abs(cos), np.sign(cos)[:, None] * dcos
    qp = surface_quadrature(area_mode == "clipped", True, np.ascontiguousarray(D),
                            np.ascontiguousarray(X), np.ascontiguousarray(T),
                            np.ascontiguousarray(cand.areas[hit], dtype=float), cos_abs,
                            np.ascontiguousarray(rate))
    return ContactSurface(cand.faces[hit], N, D, *qp, master.normal_body, n_slave_faces,
                          normal_slide=slide)


def skew_rows(v: np.ndarray) -> np.ndarray:
    """(m, 3, 3) cross-product matrices: skew_rows(v) @ b == v × b."""
    out = np.zeros(v.shape + (3,))
    out[:, 0, 1], out[:, 0, 2] = -v[:, 2], v[:, 1]
    out[:, 1, 0], out[:, 1, 2] = v[:, 2], -v[:, 0]
    out[:, 2, 0], out[:, 2, 1] = -v[:, 1], v[:, 0]
    return out

