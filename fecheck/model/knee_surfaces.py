"""The scanned knee's contact surfaces as the models read them (mm, thesis frame): the
tibial compartments and the femoral surface of the scene's ``[geometry]`` files
(`fecheck.scene.surfaces`), decimated to ``scanned.decimate_faces`` in total. Shared by the
runners (`fecheck.model.scanned`), the fingerprint of a calibration file
(`fecheck.model.fingerprint`) and the FE's bodies, so none of them has to import another;
within one run or cross-check (`fecheck.model.reuse.building_once`) each is built once and
all of them read the same objects.
"""

from __future__ import annotations

from fecheck.errors import FecheckError
from fecheck.model.reuse import reusable
from fecheck.scene import Scene, surfaces
from geometry.decimate import decimated

MIN_DECIMATED_FACES = 100
"""Fewest tibial faces ``scanned.decimate_faces`` may ask for: the shipped knee decimated to
100 faces still balances its load; at 3 faces the contact spans a face or two and Newton
finds no equilibrium (the compartments' shapes are gone)."""


def _target(scene: Scene) -> int:
    """``scanned.decimate_faces`` (0: the full meshes); `FecheckError` below
    `MIN_DECIMATED_FACES`."""
    target = scene["scanned.decimate_faces"]
    if 0 < target < MIN_DECIMATED_FACES:
        raise FecheckError(f"scanned.decimate_faces = {target}: too few faces to keep the "
                           f"compartments' shapes; give 0 (the full meshes) or at least "
                           f"{MIN_DECIMATED_FACES}")
    return target


@reusable
def tibial_slaves(scene: Scene) -> dict:
    """{compartment: tibial articular surface} (decimated to scanned.decimate_faces in
    total, shared in proportion to the two compartments' face counts)."""
    meshes = surfaces.tibial_compartments(scene)
    target = _target(scene)
    if target:
        total = sum(m.n_faces for m in meshes.values())
        meshes = {c: decimated(m, max(4, round(target * m.n_faces / total)))
                  for c, m in meshes.items()}
    return meshes


@reusable
def femoral_master(scene: Scene):
    """The femoral articular surface, decimated in proportion to the tibial slaves."""
    femur = surfaces.femoral_surface(scene)
    target = _target(scene)
    if target:
        tibia = sum(m.n_faces for m in surfaces.tibial_compartments(scene).values())
        femur = decimated(femur, max(4, round(target * femur.n_faces / tibia)))
    return femur
