"""The scanned knee's contact surfaces as the models read them (mm, thesis frame): the
tibial compartments and the femoral surface of the scene's ``[geometry]`` files
(`fecheck.scene.surfaces`), decimated to ``scanned.decimate_faces`` in total. Shared by the
runners (`fecheck.model.scanned`), the fingerprint of a calibration file
(`fecheck.model.fingerprint`) and the FE's bodies, so none of them has to import another.
"""

from __future__ import annotations

from fecheck.scene import Scene, surfaces
from geometry.decimate import decimated


def tibial_slaves(scene: Scene) -> dict:
    """{compartment: tibial articular surface} (decimated to scanned.decimate_faces in
    total, shared in proportion to the two compartments' face counts)."""
    meshes = surfaces.tibial_compartments(scene)
    target = scene["scanned.decimate_faces"]
    if target:
        total = sum(m.n_faces for m in meshes.values())
        meshes = {c: decimated(m, max(4, round(target * m.n_faces / total)))
                  for c, m in meshes.items()}
    return meshes


def femoral_master(scene: Scene):
    """The femoral articular surface, decimated in proportion to the tibial slaves."""
    femur = surfaces.femoral_surface(scene)
    target = scene["scanned.decimate_faces"]
    if target:
        tibia = sum(m.n_faces for m in surfaces.tibial_compartments(scene).values())
        femur = decimated(femur, max(4, round(target * femur.n_faces / tibia)))
    return femur
