"""Notes and checks on a solved model: what a reader must know to trust its numbers."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from fecheck.contact.surface import ContactSurface
from fecheck.errors import FecheckError
from fecheck.laws import LawResult
from fecheck.laws.registry import spec_of
from fecheck.model.assembly import Compartment
from fecheck.model.meshing import plateau_mesh_sizes
from fecheck.model.results import CompartmentResult
from fecheck.scene import Scene

WHOLE_FACE_NOTE = ("whole-face area counting (thesis Fig. 3.20) reproduces the thesis's bias: "
                   "contact area overestimated and depth underestimated (Table 5.3); use "
                   "contact.area = 'clipped' for the exact values")


DEEPEST_VERTEX_NOTE = ("; Hertz from the deepest slave vertex: not smooth in the pose "
                       "(Newton may stall)")


MIN_CONTACT_FACES = 60
"""Fewer faces in contact than this get a note: area and pressure are then coarse. Icosphere
on a plane at the baseline load (fecheck stress): 1,280 faces put 36-46 faces in contact and
are 8-9 % off the exact EF answer; 5,120 faces put 88-96 in contact, 2 % off (faceting)."""


def mesh_resolution_notes(scene: Scene, comps: Sequence[Compartment],
                          results: Sequence[LawResult]) -> list[str]:
    """After the solve: `FecheckError` if a contact reaches the rim of a meshed plateau
    disc, plane or polynomial (it is cut there: area, pressures and the force balance are
    wrong; the disc is centred under the condyle at the reference pose, and a contact
    that slides off it, e.g. with ligaments turning the tibia, needs a wider
    ``mesh.plateau_radius_mm``); notes for contacts spanning fewer than
    `MIN_CONTACT_FACES`. `results` are the compartments' law results at the solution."""
    notes = []
    for comp, res in zip(comps, results, strict=True):
        surface = getattr(res, "surface", None)
        if not isinstance(surface, ContactSurface) or surface.n_faces == 0:
            continue
        rim = getattr(comp.pair, "boundary_vertex", None)
        if comp.slave_is_tibia and rim is not None:
            touching = comp.pair.slave.faces[surface.face][surface.vertex_depth > 0.0]
            if rim[touching].any():
                disc = plateau_mesh_sizes(scene, comp.radius_mm)["radius"]
                fix = "raise mesh.plateau_radius_mm"
                if scene["plateau.kind"] == "polynomial":
                    fix += (" (on a polynomial plateau, a rim contact away from the condyle "
                            "can be the fit rising beyond the cartilage it was fitted to: "
                            "then lower it)")
                raise FecheckError(f"{comp.name}: the contact reaches the rim of the meshed "
                                   f"plateau disc (radius {disc:g} mm) and is cut there; {fix}")
        if surface.n_faces < MIN_CONTACT_FACES:
            key = ("mesh.plateau_refine_mm" if comp.slave_is_tibia
                   else "mesh.sphere_subdivisions")
            notes.append(f"{comp.name}: the contact spans only {surface.n_faces} faces, so "
                         f"its area and pressures are coarse; refine the mesh ({key})")
    return notes


def layer_depth_notes(scene: Scene, compartments: Mapping[str, CompartmentResult]
                      ) -> list[str]:
    """Check solved depths (mm) against the cartilage thickness h = contact.thickness_mm.

    The EF and Blankevoort foundations model a layer of thickness h (Blankevoort's log law
    is continued linearly beyond 0.9 h, never beyond h): a depth ≥ h means the layer is
    crushed through and the answer is meaningless, so it raises `FecheckError` naming what
    to change. The volumetric law has no thickness: a note. Hertz: nothing.
    """
    spec, h = spec_of(scene), scene["contact.thickness_mm"]
    law = spec.name
    deep = {c: r.max_depth_mm for c, r in compartments.items() if r.max_depth_mm >= h}
    if not deep or spec.beyond_thickness == "ignore":
        return []
    where = ", ".join(f"{c} {d:.3g} mm" for c, d in deep.items())
    if spec.beyond_thickness == "note":
        return [(f"depth {where} ≥ the cartilage thickness {h:g} mm: the {spec.scene.title} "
                 "law has no thickness, but the bodies overlap deeper than the cartilage")]
    raise FecheckError(f"the cartilage layer is crushed through: solved depth {where} ≥ "
                       f"contact.thickness_mm = {h:g} mm, where the {law} foundation law does "
                       "not hold; use a stiffer material (contact.youngs_MPa), a thicker "
                       "layer (contact.thickness_mm) or a smaller load (load.force_N)")



def smoothing_notes(scene: Scene) -> list[str]:
    """With ``geometry.smooth_mm`` > 0, how far each articular sheet file moved when
    smoothed (RMS and max over its vertices, mm); [] otherwise."""
    import numpy as np

    from fecheck.scene import surfaces
    from fecheck.scene.relevance import SCANNED_KINDS
    from geometry.roughness import MIN_SMOOTHING_EDGES, median_edge, smooth_sheet

    length = scene["geometry.smooth_mm"]
    if length <= 0 or scene["model.kind"] not in SCANNED_KINDS:
        return []
    moved = []
    for key in surfaces.SHEET_KEYS:
        path = surfaces.file_path(scene, key)
        if path is None:
            continue
        raw = surfaces.read_surface(path, scene["geometry.units"],
                                    tuple(scene["geometry.rotation_deg"]),
                                    tuple(scene["geometry.translation_mm"]))
        d = np.linalg.norm(smooth_sheet(raw, length).points - raw.points, axis=1)
        moved.append(f"{key} RMS {np.sqrt(np.mean(d**2)):.3f} mm, max {d.max():.3f} mm")
        edge = median_edge(raw)
        if length < MIN_SMOOTHING_EDGES * edge:
            moved[-1] += (f" (too short for its {edge:.2f} mm edges to smooth it: use at "
                          f"least {MIN_SMOOTHING_EDGES * edge:.2f} mm)")
    if not moved:
        return []
    return [f"the articular sheets were smoothed over {length:g} mm (geometry.smooth_mm) "
            "for the EF and the FE alike; their vertices moved: " + "; ".join(moved)]
