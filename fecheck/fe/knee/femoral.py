"""The femoral cartilage as a deformable layer of its own (``fe.cartilage = "two-layer"``).

The femoral articular sheet (world frame, normals toward the tibia) is cropped to the
faces within `CROP_MM` of the points where the tibial contact candidates' rays meet it,
extruded toward the femoral bone by its thickness (the distance to ``geometry.femur_bone``
with ``scanned.thickness = "bone-distance"``, else ``contact.femoral_share`` of
``contact.thickness_mm``, the series model's total) and bonded there, with the same levels
and grading as the tibial layers and the femoral cartilage's material
(``contact.femoral_youngs_MPa`` and ``contact.femoral_poisson``, where unset the tibial
one's); its cut walls are free. Where faces of that crop invert in extrusion (a fold of a
coarse or rough sheet), the crop ends `TRIM_MM` before the nearest of them, down to
`MIN_CROP_MM` from the contact. The vertices of the faces hit and those within `RING_MM`
of the hit points are condensed in three dofs for the node-to-surface contact
(`fecheck.fe.solve.joint.FemoralLayer`).

Units: mm, N, MPa.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from fecheck.errors import FecheckError
from fecheck.fe.bodies.indenter import MeshIndenter
from fecheck.fe.bodies.pose import FramePose
from fecheck.fe.bodies.scene_bodies import vertex_values
from fecheck.fe.bodies.settings import FESettings
from fecheck.fe.bodies.solid import layer_solid, release_freed_heap
from fecheck.fe.solve.joint import FemoralLayer
from fecheck.scene import Scene, surfaces
from geometry.extrude import ExtrusionError, densest, extrusion_directions, extrusion_offsets
from geometry.mesh import TriMesh

CROP_MM = 6.0
"""The femoral layer covers the femoral faces whose centroid lies within this distance of
a point a tibial candidate's ray hits, mm (several cartilage thicknesses beyond the
contact: its free cut walls barely change the compliance under the contact)."""
MIN_CROP_MM = 4.0
"""Where faces of the sheet invert in extrusion, the layer ends `TRIM_MM` before the nearest
of them, but no nearer the contact than this (else the two-layer FE is refused), mm."""
TRIM_MM = 0.5
RING_MM = 0.5
"""The vertices of the faces the candidates' rays hit, and those within this distance of a
hit point, are condensed (three dofs each): the faces a ray can hit as the pose settles
from the EF pose, mm (a ray that moves further is refused, not left unpaired)."""


@dataclass(frozen=True, eq=False)
class FemoralSheet:
    """The whole femoral articular sheet (world), its thickness at every vertex (mm), where
    that comes from ("bone-distance" or "uniform") and the material (MPa, -)."""

    mesh: TriMesh
    thickness_mm: np.ndarray
    source: str
    youngs_MPa: float
    poisson: float


def refuse_two_layer(scene: Scene, settings: FESettings) -> None:
    """`FecheckError` for a scene the two-layer FE does not model, or a femoral material of
    its own under the one-layer series FE (before any solve)."""
    if settings.cartilage != "two-layer":
        given = [k for k in ("contact.femoral_youngs_MPa", "contact.femoral_poisson")
                 if scene[k] is not None]
        if given:
            raise FecheckError(f"fe.cartilage = 'series' models both cartilages as one layer "
                               f"of contact.youngs_MPa and contact.poisson, but "
                               f"{' and '.join(given)} gives the femoral one its own: use "
                               "fe.cartilage = 'two-layer', or unset it")
        return
    where = "fe.cartilage = 'two-layer'"
    if scene["model.kind"] != "femur-tibia":
        raise FecheckError(f"{where} needs a femoral cartilage sheet to extrude: model.kind = "
                           f"'femur-tibia' (got {scene['model.kind']!r}); or fe.cartilage = "
                           "'series'")
    if settings.body == "solid" or surfaces.file_path(scene, "tibia_solid") is not None:
        raise FecheckError(f"{where} extrudes both articular sheets: drop geometry.tibia_solid "
                           "and fe.body = 'solid', or use fe.cartilage = 'series'")
    if settings.prepare == "on":
        raise FecheckError(f"{where} meshes the sheets as read: set fe.prepare = 'auto' or "
                           "'off', or use fe.cartilage = 'series'")


def femoral_sheet(scene: Scene, femur: TriMesh) -> FemoralSheet:
    """The femoral sheet `femur` (the EF run's, world frame) with its thickness."""
    from fecheck.laws.layer import bone_distance_thickness, uniform_sides

    if scene["scanned.thickness"] == "bone-distance":
        faces = scene["scanned.thickness_scale"] * bone_distance_thickness(
            femur, surfaces.bone(scene, "femur"), name="geometry.femur_bone")
        h, source = vertex_values(femur, faces), "bone-distance"
    else:
        h = np.full(femur.n_points, uniform_sides(scene)[1])
        source = "uniform"
    return FemoralSheet(femur, h, source, *femoral_material(scene))


def femoral_material(scene: Scene) -> tuple[float, float]:
    """(E MPa, ν) of the femoral cartilage: contact.femoral_youngs_MPa and
    contact.femoral_poisson, each where unset the tibial cartilage's (contact.*)."""
    e, nu = scene["contact.femoral_youngs_MPa"], scene["contact.femoral_poisson"]
    return (float(scene["contact.youngs_MPa"] if e is None else e),
            float(scene["contact.poisson"] if nu is None else nu))


def _crop(mesh: TriMesh, faces: np.ndarray) -> tuple[TriMesh, np.ndarray, np.ndarray]:
    """The sub-mesh of `faces`, its vertices' indices in `mesh` and each `mesh` vertex's
    index in it (-1: not in it)."""
    used = np.unique(mesh.faces[faces])
    remap = np.full(mesh.n_points, -1)
    remap[used] = np.arange(len(used))
    return TriMesh(mesh.points[used], remap[mesh.faces[faces]]), used, remap


def femoral_layer(sheet: FemoralSheet, name: str, hit_points: np.ndarray,
                  hit_faces: np.ndarray, settings: FESettings, log: Callable[[str], None]
                  ) -> FemoralLayer:
    """The femoral layer under the points `hit_points` (k, 3) (world, mm) where a
    compartment's tibial candidates' rays meet the sheet, on its faces `hit_faces` (k,)
    (module docstring)."""
    from scipy.spatial import cKDTree

    if len(hit_points) == 0:
        raise FecheckError(f"no {name} tibial contact candidate's normal meets the femoral "
                           "sheet: nothing for the femoral layer to carry")
    tree = cKDTree(hit_points)
    levels = settings.levels(sheet.poisson)
    radius = CROP_MM
    while True:
        near, _ = tree.query(sheet.mesh.face_centroids, distance_upper_bound=radius)
        crop, used, remap = _crop(sheet.mesh, np.flatnonzero(np.isfinite(near)))
        h = sheet.thickness_mm[used]
        try:
            directions, rounds = extrusion_directions(crop, h, layers=levels,
                                                      ratio=settings.grading)
            break
        except ExtrusionError as err:
            x, y, z = densest(err.where)
            reach = float(tree.query(err.where)[0].min()) - TRIM_MM
            if reach < MIN_CROP_MM:
                raise FecheckError(
                    f"the femoral sheet over the {name} compartment cannot be extruded into "
                    f"a cartilage layer: {len(err.where)} faces invert, e.g. at ({x:.1f}, "
                    f"{y:.1f}, {z:.1f}) mm, {reach + TRIM_MM:.1f} mm from the contact; use "
                    "fe.cartilage = 'series'") from None
            log(f"{name} femoral layer: {len(err.where)} faces at ({x:.1f}, {y:.1f}, {z:.1f}) "
                f"mm invert in extrusion: the layer ends {reach:.1f} mm from the contact")
            radius = reach
    solid = layer_solid(crop, h, sheet.youngs_MPa, sheet.poisson, layers=levels,
                        ratio=settings.grading,
                        offsets=extrusion_offsets(crop, h, directions),
                        formulation=settings.formulation_for(sheet.poisson))
    release_freed_heap()
    ring, _ = tree.query(crop.points, distance_upper_bound=RING_MM)
    candidates = np.union1d(np.flatnonzero(np.isfinite(ring)),
                            remap[sheet.mesh.faces[hit_faces]].ravel())
    log(f"{name} femoral layer: {crop.n_faces} faces within {radius:.3g} mm of the contact, "
        f"{len(solid.mesh.tets)} quadratic tetrahedra, {solid.n_dofs} dofs, thickness "
        f"{h.min():.2f}-{h.max():.2f} mm ({sheet.source})"
        + (f" (extruded along normals smoothed {rounds} times)" if rounds else ""))
    return FemoralLayer(f"{name} femoral", solid, candidates)


class FemoralBuilder:
    """(layers, candidates, R, t) → the femoral layer of every tibial layer, under the
    points where its candidates' rays (tibia pose R, t) meet the femoral sheet; `seconds`
    the time spent building them."""

    def __init__(self, sheet: FemoralSheet, settings: FESettings,
                 log: Callable[[str], None]):
        self.sheet, self.settings, self.log = sheet, settings, log
        self.indenter = MeshIndenter(sheet.mesh)
        self.seconds = 0.0

    def __call__(self, layers: Sequence, candidates: Sequence[np.ndarray], X_WT: FramePose
                 ) -> list[FemoralLayer]:
        t0 = time.perf_counter()
        out = []
        for lay, cand in zip(layers, candidates, strict=True):
            pts = X_WT.points(lay.surface.points[cand])
            nrm = X_WT.vectors(lay.solid.normals[cand])
            gap, face, _ = self.indenter.hits(pts, nrm)
            hit = face >= 0
            y = pts[hit] + gap.gap_mm[hit, None] * nrm[hit]
            out.append(femoral_layer(self.sheet, lay.body.name, y, face[hit], self.settings,
                                     self.log))
        self.seconds += time.perf_counter() - t0
        return out
