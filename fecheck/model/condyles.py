"""Femoral condyle spheres fitted to a femoral articular surface (``knee.preset = "fit"``).

Each condyle's sphere is the least-squares sphere (`geometry.fits.fit_sphere`, weighted
by face area) through the face centroids of its posterior-distal cartilage: faces whose
normal, seen in the sagittal plane, points between 10° anterior of straight down and
100° towards posterior (-10° < atan2(-n_y, -n_z) < 100°), that face mostly sagittally
(|n_x| < 0.5), lie behind y = 15 mm (not the trochlea) and more than 8 mm from the
sagittal midplane on the condyle's side. On the lenhart2015 femoral cartilage this
selection gives the data set's own sphere fits (its fits.json) to 1 µm. The contact
point of each condyle is the lowest point of its sphere. Units: mm, thesis frame.
"""

from __future__ import annotations

import numpy as np

from fecheck.errors import FecheckError
from fecheck.scene import Scene, surfaces
from fecheck.scene.constants import COMPARTMENTS
from fecheck.scene.knee import Knee
from geometry.cache import per_mesh
from geometry.fits import fit_sphere
from geometry.mesh import TriMesh

MIDPLANE_GAP_MM = 8.0
"""Faces nearer the sagittal midplane than this belong to the notch, not a condyle."""
TROCHLEA_Y_MM = 15.0
"""Faces anterior of this are the trochlea (patellar groove), not a condyle."""
MIN_FACES = 20
"""Fewest faces a condyle fit takes."""


def condyle_faces(femur: TriMesh, compartment: str, side: str) -> np.ndarray:
    """(m,) face indices of one condyle's posterior-distal cartilage (module docstring)."""
    n, c = femur.face_normals, femur.face_centroids
    angle = np.degrees(np.arctan2(-n[:, 1], -n[:, 2]))
    keep = (angle > -10.0) & (angle < 100.0) & (np.abs(n[:, 0]) < 0.5)
    keep &= c[:, 1] < TROCHLEA_Y_MM
    medial_sign = -1.0 if side == "right" else 1.0
    sign = medial_sign if compartment == "medial" else -medial_sign
    keep &= sign * c[:, 0] > MIDPLANE_GAP_MM
    return np.flatnonzero(keep)


@per_mesh
def fitted_knee(femur: TriMesh, side: str, name: str = "the femoral surface") -> Knee:
    """A knee whose condyle spheres are fitted to `femur` (no ligament attachments);
    fitted once per femur mesh object (a scene's surfaces are read once per process)."""
    centre, contact = {}, {}
    for c in COMPARTMENTS:
        faces = condyle_faces(femur, c, side)
        if len(faces) < MIN_FACES:
            raise FecheckError(f"knee.preset = 'fit': only {len(faces)} faces of {name} look "
                               f"like the {c} condyle's posterior-distal cartilage (at least "
                               f"{MIN_FACES} needed); check knee.side and the frame, or give "
                               "the condyle spheres in [knee.landmarks]")
        fit = fit_sphere(femur.face_centroids[faces], weights=femur.face_areas[faces])
        centre[c] = np.asarray(fit.center, dtype=float)
        contact[c] = centre[c] - np.array([0.0, 0.0, fit.radius_mm])
    return Knee(side=side, condyle_center=centre, contact_point=contact, femur_attachment={},
                tibia_attachment={})


def scene_knee(scene: Scene) -> Knee:
    """The knee of a scene: its landmarks, or with ``knee.preset = "fit"`` the condyle
    spheres fitted to its femoral surface (``geometry.femur``)."""
    if scene["knee.preset"] != "fit":
        return scene.knee
    path = surfaces.required_path(scene, "femur", "knee.preset = 'fit' (the condyle spheres "
                                  "are fitted to the femoral surface)")
    return fitted_knee(surfaces.femoral_surface(scene), scene.side, path.name)


def fit_note(scene: Scene, knee: Knee) -> list[str]:
    """The fitted spheres, for the run's notes (none unless ``knee.preset = "fit"``)."""
    if scene["knee.preset"] != "fit":
        return []
    parts = [f"{c} centre ({', '.join(f'{v:.2f}' for v in knee.condyle_center[c])}) mm, "
             f"R {knee.radius_mm(c):.2f} mm" for c in COMPARTMENTS]
    return [f"condyle spheres fitted to {surfaces.file_path(scene, 'femur').name} "
            f"(knee.preset = 'fit'): {'; '.join(parts)}"]
