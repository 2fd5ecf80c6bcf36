"""Meshes of the sphere-plane model: condyles, plateau discs and masters, sized from the
expected contact.

A meshed plateau (sphere-plane model, ``contact.master = condyle``) must resolve the
contact (enough faces across it) and contain it (the disc wider than it). Both follow
from the closed-form sphere-on-plane contact radius at the scene's load, known before
the solve (`fecheck.reference.closed_forms`): for a foundation law of stiffness k
(N/mm³), the depth d from F = k·πd²(R − d/3) and a = √(2Rd − d²); for Hertz a = (3FR / 4E*)^(1/3).

Only plateau keys left at their defaults are sized; the defaults themselves are kept
wherever they already suffice (the 800 N baseline mesh is unchanged). Sizes are rounded
(element size to the default over a power of two, disc radius up to whole mm) so that
a load sweep reuses a few cached meshes.
"""

from __future__ import annotations

import math

import numpy as np

from fecheck.errors import FecheckError
from fecheck.laws.registry import spec_of
from fecheck.model.assembly import plateau_normals
from fecheck.scene import SCHEMA, Scene
from fecheck.scene.constants import GRAVITY_MPS2
from fecheck.scene.knee import Knee

ELEMENTS_PER_CONTACT_RADIUS = 8
"""Refined plateau elements across the smallest expected contact radius."""

DISC_MARGIN = 1.25
"""Meshed disc radius over the contact radius at the whole load on one compartment."""

SCENE_KEYS = {"size": "mesh.plateau_size_mm", "refine_size": "mesh.plateau_refine_mm",
              "subdivisions": "mesh.sphere_subdivisions"}
"""Builder parameter → scene key, for the size guards' messages (`geometry.budget`)."""


def total_load_N(scene: Scene) -> float:
    """Magnitude of the external load plus the tibia's weight (if on), N."""
    return scene["load.force_N"] + scene["tibia.mass_kg"] * GRAVITY_MPS2 * scene["gravity"]


def expected_contact_radius_mm(scene: Scene, force_N: float, radius_mm: float) -> float:
    """Contact radius (mm) of a sphere of `radius_mm` on a plane pressed by `force_N` (N)
    under the scene's law: the EF law (Blankevoort by its small-depth EF stiffness, a
    slight overestimate), the volumetric k_V, or Hertz. Capped at the sphere radius."""
    return spec_of(scene).expected_contact_radius(scene, force_N, radius_mm)


def plateau_mesh_sizes(scene: Scene, radius_mm: float) -> dict[str, float]:
    """Disc radius, element sizes and refined-zone radius (mm) of a meshed plateau under a
    condyle of `radius_mm`: the scene's ``mesh.plateau_*`` values, with those left at
    their defaults sized from the expected contact (module docstring).

    The smallest contact is taken at half the load (an even split between the
    compartments), the largest at the whole load on one compartment.
    """
    keys = ("radius", "size", "refine", "refine_radius")
    value = {k: scene[f"mesh.plateau_{k}_mm"] for k in keys}
    default = {k: SCHEMA[f"mesh.plateau_{k}_mm"].default for k in keys}
    is_default = {k: value[k] == default[k] for k in keys}
    load = total_load_N(scene)
    a_half = expected_contact_radius_mm(scene, 0.5 * load, radius_mm)
    a_full = expected_contact_radius_mm(scene, load, radius_mm)
    out = dict(value)
    if is_default["radius"]:
        out["radius"] = max(value["radius"], float(math.ceil(DISC_MARGIN * a_full)))
    if is_default["refine"] and 0.0 < a_half < ELEMENTS_PER_CONTACT_RADIUS * value["refine"]:
        halvings = math.ceil(math.log2(ELEMENTS_PER_CONTACT_RADIUS * value["refine"] / a_half))
        out["refine"] = value["refine"] / 2 ** halvings
    if is_default["refine_radius"]:
        if out["refine"] < value["refine"]:           # small contact: a small refined zone
            out["refine_radius"] = min(value["refine_radius"],
                                       float(math.ceil(2.0 * a_full / out["refine"]))
                                       * out["refine"])
        else:                                         # wide contact: the zone covers it
            out["refine_radius"] = max(value["refine_radius"], float(math.ceil(a_half)))
    return {"radius": out["radius"], "size": out["size"], "refine_size": out["refine"],
            "refine_radius": out["refine_radius"]}


def condyle_mesh(scene: Scene, knee: Knee, c: str):
    from geometry.budget import policy
    from geometry.icosphere import icosphere

    with policy(keys=SCENE_KEYS):
        return icosphere(knee.radius_mm(c), scene["mesh.sphere_subdivisions"],
                         knee.condyle_center[c], method=scene["mesh.method"])


def plateau_box(scene: Scene, knee: Knee, c: str):
    """The plateau plane as the top of a closed 40 x 40 x 10 mm box (mesh detection)."""
    from geometry.plateau import plateau_box

    if scene["plateau.kind"] == "polynomial":
        raise FecheckError("mesh detection (contact.detection = 'bvh', 'ray-parity' or "
                           "'fcl') needs plane plateaus here; use contact.detection = 'auto' "
                           "for polynomial plateaus")
    n = plateau_normals(scene)[c]
    lam, gam = ((0.0, 0.0) if scene["plateau.kind"] == "transverse"
                else scene[f"plateau.{c}_angles_deg"])
    return plateau_box(knee.condyle_center[c] - knee.radius_mm(c) * n, 40.0, 40.0, 10.0,
                       sagittal_deg=lam, frontal_deg=gam)


def plateau_master(scene: Scene, knee: Knee, c: str):
    from fecheck.contact.analytic import Plane, PolynomialSurface
    from geometry.polynomial import Polynomial2D

    if scene["plateau.kind"] == "polynomial":
        return PolynomialSurface(Polynomial2D(np.asarray(scene[f"plateau.{c}_coefficients"])))
    n = plateau_normals(scene)[c]
    return Plane(knee.condyle_center[c] - knee.radius_mm(c) * n, n)


def plateau_mesh(scene: Scene, knee: Knee, c: str, scale: float = 1.0):
    """The meshed plateau disc under condyle `c`, sized to resolve and contain the
    expected contact (`plateau_mesh_sizes`); `scale` multiplies its element sizes (2: the
    coarse level of `fecheck.studies.estimate`), not its radii."""
    from geometry.budget import policy
    from geometry.plateau import plane_patch, polynomial_patch
    from geometry.polynomial import Polynomial2D

    foot = knee.condyle_center[c] - knee.radius_mm(c) * np.array([0.0, 0.0, 1.0])
    size = plateau_mesh_sizes(scene, knee.radius_mm(c))
    radius = size.pop("radius")
    size["size"] *= scale
    size["refine_size"] *= scale
    with policy(keys=SCENE_KEYS):
        if scene["plateau.kind"] == "polynomial":
            poly = Polynomial2D(np.asarray(scene[f"plateau.{c}_coefficients"]))
            return polynomial_patch(poly, footprint="ellipse", center_xy=foot[:2],
                                    half_x=radius, half_y=radius, refine_point=foot[:2], **size)
        n = plateau_normals(scene)[c]
        point = knee.condyle_center[c] - knee.radius_mm(c) * n
        return plane_patch(point, n, radius=radius, refine_point=point, **size)

