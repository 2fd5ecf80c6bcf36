"""Layer stiffness from thickness: per-face thickness over bone and the foundation it sets.

Scanned cartilage often comes as the articular SURFACE only (an open sheet), with the
bone mesh as its back surface (OpenSim-JAM's convention, README of the lenhart2015 data).
The thickness under a face is then the distance from the face centroid, along the
inward normal -n, to the bone: one ray per face through a compiled BVH (Embree, via
trimesh). Where the ray misses the bone (sheet borders overhanging the bone edge) the
closest-point distance to the bone (libigl AABB) is used instead. A bone face on an edge
shared by three or more faces (a non-manifold defect of the bone file) is refused only
when a ray (or a closest point) lands on it: elsewhere the defect changes no distance.
Thicknesses are
floored at `MIN_THICKNESS_MM`: a vanishing layer would make the foundation infinitely
stiff (k ∝ 1/h).

Two layers in contact (femoral and tibial cartilage) are two foundations in series:
k = c/h_1 and c/h_2 give k = c/(h_1 + h_2) for the same material, so the spring of a
slave face uses h_slave + h_master, the master's thickness taken at the master face
closest to the slave face at the rest pose (`series_thickness`).

>>> import numpy as np
>>> k = face_ef_stiffness(np.array([6.0, 3.0]), 20.0, 0.3)
>>> np.round(k, 4).tolist()
[4.4872, 8.9744]
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from fecheck.errors import FecheckError
from fecheck.laws.foundation import foundation
from fecheck.laws.fused import compiled_law
from fecheck.laws.kernel import LINEAR
from fecheck.laws.materials import ef_stiffness
from fecheck.laws.result import LawResult
from geometry.checks import non_manifold_faces
from geometry.distance import closest_distance, ray_hits
from geometry.mesh import TriMesh

MIN_THICKNESS_MM = 0.5
"""Floor of a per-face thickness, mm (the data set's 5th percentile is 0.14-0.26 mm)."""


def bone_distance_thickness(cartilage: TriMesh, bone: TriMesh, *,
                            max_mm: float = 10.0,
                            min_mm: float = MIN_THICKNESS_MM,
                            name: str = "the bone") -> np.ndarray:
    """Per-face cartilage thickness (mm): distance from each face centroid to the bone
    along the inward normal (closest-point distance where the ray misses or runs
    further than `max_mm`), floored at `min_mm`.

    `cartilage` faces must have normals pointing away from the bone (outward).
    `FecheckError` naming `name` and the place where a ray (or closest point) lands on
    a face of a non-manifold edge of `bone`.
    """
    if cartilage.n_faces == 0 or bone.n_faces == 0:
        raise FecheckError("thickness needs a non-empty cartilage surface and bone mesh")
    if not (0 < min_mm < max_mm):
        raise FecheckError(f"need 0 < min_mm < max_mm, got {min_mm}, {max_mm}")
    c, n = cartilage.face_centroids, cartilage.face_normals
    along, face = ray_hits(c, -n, bone)
    miss = ~(along <= max_mm)
    if miss.any():
        along[miss], face[miss] = closest_distance(c[miss], bone)
    on_defect = np.isin(face, non_manifold_faces(bone))
    if on_defect.any():
        x, y, z = bone.face_centroids[face[on_defect]].mean(axis=0)
        raise FecheckError(
            f"{name}: the thickness rays of {int(on_defect.sum())} cartilage faces land on "
            f"faces of an edge shared by three or more faces (non-manifold), around "
            f"({x:+.1f}, {y:+.1f}, {z:+.1f}) mm: the distance to the bone is undefined there; "
            "remove the extra faces (e.g. MeshLab: Select Non Manifold Edges, then delete) "
            "and export the bone again")
    return np.maximum(along, min_mm)


def uniform_thickness(mesh: TriMesh, thickness_mm: float) -> np.ndarray:
    """The same thickness (mm) for every face of `mesh`."""
    if not (np.isfinite(thickness_mm) and thickness_mm > 0):
        raise FecheckError(f"cartilage thickness must be a positive number of mm, "
                           f"got {thickness_mm}")
    return np.full(mesh.n_faces, float(thickness_mm))


def series_thickness(slave: TriMesh, slave_h: np.ndarray, master: TriMesh,
                     master_h: np.ndarray) -> np.ndarray:
    """Total thickness (mm) of two layers in series under each slave face: its own plus
    that of the master face closest to its centroid (rest pose)."""
    return np.asarray(slave_h, dtype=float) + opposite_thickness(slave, master, master_h)


def opposite_thickness(slave: TriMesh, master: TriMesh, master_h: np.ndarray) -> np.ndarray:
    """The thickness (mm) of the master face closest to each slave face's centroid (rest
    pose): the other layer of the pair under that slave face."""
    _, face = closest_distance(slave.face_centroids, master)
    return np.asarray(master_h, dtype=float)[face]


def face_ef_stiffness(thickness_mm: np.ndarray, youngs_MPa: float, poisson: float
                      ) -> np.ndarray:
    """EF stiffness per face, k = (1−ν)E/((1+ν)(1−2ν)h), N/mm³ (thesis eq. 4.3)."""
    h = np.asarray(thickness_mm, dtype=float)
    if h.ndim != 1 or not np.all(np.isfinite(h)) or np.any(h <= 0):
        raise FecheckError("per-face thicknesses must be finite and positive (mm)")
    return ef_stiffness(youngs_MPa, poisson, 1.0) / h


def face_elastic_foundation(k_face_N_per_mm3: np.ndarray):
    """Linear EF law p = k_f·d with a stiffness per slave face (N/mm³).

    Returns a law (`ContactSurface` → `LawResult`, and compiled for the hot path,
    `fecheck.laws.fused`) whose maximum pressure is the largest k_f times the deepest
    vertex depth of face f.
    """
    k_face = np.asarray(k_face_N_per_mm3, dtype=float)

    def law(surface) -> LawResult:
        if surface.n_slave_faces != len(k_face):
            raise FecheckError(f"{len(k_face)} face stiffnesses for a slave mesh of "
                               f"{surface.n_slave_faces} faces")
        k_contact = k_face[surface.face]
        kq = k_contact[surface.qp_face]

        def pressure(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            # `laws.foundation` calls this with the quadrature depths, then once with the
            # maximum depth alone for its p_max, which is replaced below
            k = kq if d.shape == kq.shape else k_contact.max()
            return k * d, np.broadcast_to(k, d.shape)

        res = foundation(surface, pressure)
        if surface.n_faces == 0:
            return res
        p_max = float((k_contact * np.maximum(surface.vertex_depth.max(axis=1), 0.0)).max())
        return replace(res, max_pressure=p_max)

    return compiled_law(LINEAR, np.array([1.0]), law, face_scale=k_face)


@dataclass(frozen=True)
class Sides:
    """The two cartilage layers of a scene: their column moduli c = (1−ν)E/((1+ν)(1−2ν))
    (MPa, `fecheck.laws.materials.ef_stiffness` at h = 1), the femoral layer's share of a
    uniform total thickness, and whether the scene gives the femoral cartilage a material
    of its own (``contact.femoral_youngs_MPa`` or ``contact.femoral_poisson`` set)."""

    c_tibial: float
    c_femoral: float
    femoral_share: float
    own_material: bool

    @property
    def given(self) -> bool:
        """The scene sets either layer apart (a share other than ½ or a femoral material):
        the run reports each layer's compression."""
        return self.own_material or self.femoral_share != 0.5

    def equivalent_thickness(self, tibial_mm: np.ndarray, femoral_mm: np.ndarray
                             ) -> np.ndarray:
        """The thickness (mm) of one tibial-material layer as compliant as the two in
        series: h_t + h_f·c_t/c_f, so that c_t/h = 1/(h_t/c_t + h_f/c_f)."""
        t, f = np.asarray(tibial_mm, dtype=float), np.asarray(femoral_mm, dtype=float)
        return t + f * (self.c_tibial / self.c_femoral) if self.own_material else t + f

    def tibial_ratio(self, tibial_mm: np.ndarray, femoral_mm: np.ndarray) -> np.ndarray:
        """The tibial layer's part of the depth, δ_t/δ = (h_t/c_t)/(h_t/c_t + h_f/c_f)
        (the femoral layer's is one minus it)."""
        t = np.asarray(tibial_mm, dtype=float) / self.c_tibial
        return t / (t + np.asarray(femoral_mm, dtype=float) / self.c_femoral)


def sides(scene) -> Sides:
    """The `Sides` of a scene (a mapping of the dotted keys): tibial cartilage of
    ``contact.youngs_MPa``/``contact.poisson``, femoral of ``contact.femoral_youngs_MPa``/
    ``contact.femoral_poisson`` where set (else the same), femoral share
    ``contact.femoral_share``."""
    e, nu = scene["contact.youngs_MPa"], scene["contact.poisson"]
    e_f, nu_f = scene["contact.femoral_youngs_MPa"], scene["contact.femoral_poisson"]
    own = e_f is not None or nu_f is not None
    e_f, nu_f = e if e_f is None else e_f, nu if nu_f is None else nu_f
    return Sides(ef_stiffness(e, nu, 1.0), ef_stiffness(e_f, nu_f, 1.0),
                 float(scene["contact.femoral_share"]), own)


def uniform_sides(scene) -> tuple[float, float]:
    """(tibial, femoral) thickness (mm) of a uniform layer: contact.thickness_mm shared by
    contact.femoral_share."""
    h, share = float(scene["contact.thickness_mm"]), float(scene["contact.femoral_share"])
    return (1.0 - share) * h, share * h
