"""What the FE meshes for a scene: per compartment the tibial articular surface the EF run
used, its thickness and the femoral surface that presses it.

- Tibial surface (tibia frame, outward normals): the meshed plateau disc of a
  sphere-plane scene (transverse, inclined or polynomial, the same mesh the EF run
  evaluates), or the tibial articular surface file of a sphere-tibia or femur-tibia
  scene (``geometry.tibia``; decimated as the EF run decimates it).
- Thickness (mm, one value per surface vertex): ``contact.thickness_mm`` everywhere, or
  with ``scanned.thickness = "bone-distance"`` the EF run's per-face foundation
  thickness (tibial plus femoral cartilage in series) averaged onto the vertices.
  The FE then models that total thickness as one deformable layer on the tibia under a
  rigid femoral surface — the EF's own assumption (``fe.cartilage = "series"``). With
  ``fe.cartilage = "two-layer"`` the tibial cartilage alone: its bone distance, or its
  share of ``contact.thickness_mm``, 1 − ``contact.femoral_share`` (the femoral layer,
  `fecheck.fe.knee.femoral`, takes the rest).
  With ``geometry.tibia_solid`` and ``fe.body`` "layer": the solid's own thickness map
  (`fecheck.fe.bodies.volume.solid_thickness`).
- Tibial solid (``fe.body`` "solid", or "auto" with ``geometry.tibia_solid``): the closed
  solid itself (`fecheck.fe.bodies.volume`), each compartment's articular face the part of its
  boundary on that compartment's sheet (`fecheck.scene.tibia_solid.on_sheet`).
- Femoral surface (world = femur frame, fixed): the analytic condyle sphere, or the
  femoral surface file (``geometry.femur``; or the closed hemisphere mesh) as a rigid
  mesh indenter.

Units: mm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fecheck.contact.analytic import Sphere
from fecheck.errors import FecheckError
from fecheck.fe.bodies.indenter import MeshIndenter, SphereIndenter
from fecheck.fe.bodies.volume import TibiaSolid, solid_thickness
from fecheck.model.knee_surfaces import tibial_slaves
from fecheck.model.scanned import femoral_masters, series_thicknesses
from fecheck.scene import Scene, surfaces
from fecheck.scene.constants import COMPARTMENTS
from fecheck.scene.relevance import SCANNED_KINDS
from geometry.mesh import TriMesh

PLATEAU_NAMES = {"transverse": "plane", "inclined": "inclined", "polynomial": "polynomial"}
"""`fe_geometry.tibial_surface` of each plateau kind."""


@dataclass(frozen=True, eq=False)
class FEBody:
    """One compartment's geometry for the FE.

    surface : tibial articular surface, tibia frame, outward normals (mm)
    thickness_mm : (n_points,) layer thickness along the surface normal at each vertex
    indenter : the rigid femoral surface, world frame
    tibial_surface, femoral_surface : what was meshed ("plane", "inclined",
        "polynomial", "mesh:<name>"; "sphere R <r> mm", "mesh:<name>")
    thickness_source : "uniform", "bone-distance", "solid" (the solid itself) or
        "solid-distance" (a layer with the solid's thickness map)
    solid : the closed tibial solid the FE meshes instead of extruding `surface` (shared
        by the compartments of a one-piece solid), or None
    carrier : the frame name of the rigid body the layer is bonded to ("T" the tibia, "P"
        the patella: `fecheck.fe.knee.patella_layer`); `surface` is in that body's frame
    """

    name: str
    surface: TriMesh
    thickness_mm: np.ndarray
    indenter: SphereIndenter | MeshIndenter
    tibial_surface: str
    femoral_surface: str
    thickness_source: str
    solid: TibiaSolid | None = None
    carrier: str = "T"


def vertex_values(surface: TriMesh, face_values: np.ndarray) -> np.ndarray:
    """Face values averaged onto the vertices, weighted by the adjacent face areas."""
    w = surface.face_areas
    total = np.zeros(surface.n_points)
    weight = np.zeros(surface.n_points)
    np.add.at(total, surface.faces.ravel(), np.repeat(w * face_values, 3))
    np.add.at(weight, surface.faces.ravel(), np.repeat(w, 3))
    return total / np.where(weight > 0, weight, 1.0)


def _indenter(master, label: str) -> tuple[SphereIndenter | MeshIndenter, str]:
    if isinstance(master, Sphere):
        radius = float(master.radius)
        return (SphereIndenter(np.asarray(master.center, dtype=float), radius),
                f"sphere R {radius:.2f} mm")
    return MeshIndenter(master), f"mesh:{label}"


def _sphere_plane_bodies(scene: Scene) -> list[FEBody]:
    from fecheck.model.meshing import plateau_mesh

    knee = scene.knee
    h = float(scene["contact.thickness_mm"])
    out = []
    for c in COMPARTMENTS:
        surface = plateau_mesh(scene, knee, c)
        indenter, femoral = _indenter(Sphere(knee.condyle_center[c], knee.radius_mm(c)), "")
        out.append(FEBody(c, surface, np.full(surface.n_points, h), indenter,
                          PLATEAU_NAMES[scene["plateau.kind"]], femoral, "uniform"))
    return out


def _scanned_bodies(scene: Scene) -> list[FEBody]:
    slaves, masters = tibial_slaves(scene), femoral_masters(scene)
    source = scene["scanned.thickness"]
    femur_name = (surfaces.file_path(scene, "femur").name
                  if scene["model.kind"] == "femur-tibia" else "condyle hemisphere")
    sheet = surfaces.file_path(scene, "tibia") or surfaces.file_path(scene, "tibia_solid")
    tibia_name = {c: sheet.name for c in COMPARTMENTS}      # no sheet: the solid's top
    if surfaces.file_path(scene, "tibia_lateral") is not None:
        tibia_name["lateral"] = surfaces.file_path(scene, "tibia_lateral").name
    body = _tibial_body(scene)
    solid = None if body == "none" else _tibia_solid(scene)
    out = []
    for c in COMPARTMENTS:
        surface = slaves[c]
        if solid is not None:
            h = solid_thickness(solid, surface, c)
        elif scene["fe.cartilage"] == "two-layer":
            h = _tibial_thickness(scene, surface)
        elif source == "uniform":
            h = np.full(surface.n_points, float(scene["contact.thickness_mm"]))
        else:
            h = scene["scanned.thickness_scale"] * vertex_values(
                surface, series_thicknesses(scene)[c])
        indenter, femoral = _indenter(masters[c], femur_name)
        if body == "solid":
            out.append(FEBody(c, surface, h, indenter, f"solid:{solid.name}", femoral,
                              "solid", solid))
        else:
            out.append(FEBody(c, surface, h, indenter, f"mesh:{tibia_name[c]}", femoral,
                              "solid-distance" if solid is not None else source))
    return out


def _tibial_thickness(scene: Scene, surface: TriMesh) -> np.ndarray:
    """The tibial cartilage's own thickness at the vertices of `surface` (two layers):
    the distance to geometry.tibia_bone, or the tibial share of contact.thickness_mm
    (`fecheck.laws.layer.uniform_sides`), mm."""
    from fecheck.laws.layer import bone_distance_thickness, uniform_sides

    if scene["scanned.thickness"] == "bone-distance":
        return scene["scanned.thickness_scale"] * vertex_values(surface, bone_distance_thickness(
            surface, surfaces.bone(scene, "tibia"), name="geometry.tibia_bone"))
    return np.full(surface.n_points, uniform_sides(scene)[0])


def _tibial_body(scene: Scene) -> str:
    """What the FE makes of the tibia: "solid" (mesh geometry.tibia_solid), "layer"
    (extrude the sheet by the solid's thickness map) or "none" (no solid: extrude the
    sheet by the EF's thickness)."""
    given = surfaces.file_path(scene, "tibia_solid") is not None
    body = scene["fe.body"]
    if body == "auto":
        return "solid" if given else "none"
    if body == "solid" or given:
        return body
    return "none"


def _tibia_solid(scene: Scene) -> TibiaSolid:
    """The closed solid of ``geometry.tibia_solid`` with each compartment's articular
    face (the faces on its undecimated sheet)."""
    from fecheck.scene.tibia_solid import on_sheet

    solid = surfaces.solid_surface(scene)
    name = surfaces.file_path(scene, "tibia_solid").name
    articular, taken = {}, np.zeros(0, dtype=np.int64)
    for c, sheet in surfaces.tibial_compartments(scene).items():
        articular[c] = np.setdiff1d(on_sheet(solid, sheet), taken)   # one compartment each
        taken = np.union1d(taken, articular[c])
        if len(articular[c]) == 0:
            raise FecheckError(f"geometry.tibia_solid = {name!r}: no face of the solid lies "
                               f"on the {c} tibial sheet (within 0.1 mm): the sheet "
                               "geometry.tibia must be the solid's articular face, in the "
                               "same frame")
    return TibiaSolid(solid, articular, name)


def refuse_unmodelled(scene: Scene) -> None:
    """`FecheckError` for a scene the FE cannot model as the EF does: no cartilage
    (``model.kind = "rigid"``), or menisci (``menisci.dir``: the FE has no meniscus
    bodies, and an FE without them would answer for another knee)."""
    if scene["model.kind"] == "rigid":
        raise FecheckError("model.kind = 'rigid' has no cartilage: nothing to cross-check "
                           "with the FE")
    if scene["menisci.dir"]:
        raise FecheckError("the FE cross-check does not model menisci (menisci.dir = "
                           f"{scene['menisci.dir']!r}): set menisci.dir = '' to cross-check "
                           "the knee without them (`fecheck fe` on this scene runs the FE "
                           "with menisci, fecheck.fe.knee.knee_menisci)")


def scene_bodies(scene: Scene) -> list[FEBody]:
    """The FE geometry of every compartment of `scene` (module docstring); refuses a
    scene it cannot model (`refuse_unmodelled`)."""
    refuse_unmodelled(scene)
    if scene["model.kind"] in SCANNED_KINDS:
        return _scanned_bodies(scene)
    if scene["fe.body"] == "solid":
        raise FecheckError(f"model.kind = {scene['model.kind']!r} presses plateau discs: a "
                           "closed tibial solid (geometry.tibia_solid, fe.body = 'solid') "
                           "needs model.kind = 'sphere-tibia' or 'femur-tibia'")
    return _sphere_plane_bodies(scene)
