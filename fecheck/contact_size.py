"""Expected contact size before the solve, and the plateau mesh sized from it.

A meshed plateau (sphere-plane model, ``contact.master = condyle``) must resolve the
contact (enough faces across it) and contain it (the disc wider than it). Both follow
from the closed-form sphere-on-plane contact radius at the scene's load, known before
the solve (DESIGN §5): for a foundation law of stiffness k (N/mm³), the depth d from
F = k·πd²(R − d/3) and a = √(2Rd − d²); for Hertz a = (3FR / 4E*)^(1/3).

Only plateau keys left at their defaults are sized; the defaults themselves are kept
wherever they already suffice (the 800 N baseline mesh is unchanged). Sizes are rounded
(element size to the default over a power of two, disc radius up to whole mm) so that
a load sweep reuses a few cached meshes.
"""

from __future__ import annotations

import math

from fecheck import laws
from fecheck.model import GRAVITY_MPS2
from fecheck.scene import SCHEMA, Scene

ELEMENTS_PER_CONTACT_RADIUS = 8
"""Refined plateau elements across the smallest expected contact radius."""

DISC_MARGIN = 1.25
"""Meshed disc radius over the contact radius at the whole load on one compartment."""


def total_load_N(scene: Scene) -> float:
    """Magnitude of the external load plus the tibia's weight (if on), N."""
    return scene["load.force_N"] + scene["tibia.mass_kg"] * GRAVITY_MPS2 * scene["gravity"]


def expected_contact_radius_mm(scene: Scene, force_N: float, radius_mm: float) -> float:
    """Contact radius (mm) of a sphere of `radius_mm` on a plane pressed by `force_N` (N)
    under the scene's law: the EF law (Blankevoort by its small-depth EF stiffness, a
    slight overestimate), the volumetric k_V, or Hertz. Capped at the sphere radius."""
    r = float(radius_mm)
    if force_N <= 0.0:
        return 0.0
    e, nu, h = scene["contact.youngs_MPa"], scene["contact.poisson"], scene["contact.thickness_mm"]
    if scene["contact.law"] == "hertz":
        e_star = laws.hertz_modulus(e, nu, scene["contact.indenter_youngs_MPa"],
                                    scene["contact.indenter_poisson"])
        return min(r, (3.0 * force_N * r / (4.0 * e_star)) ** (1.0 / 3.0))
    k = (scene["contact.volumetric_stiffness_N_per_mm3"] if scene["contact.law"] == "volumetric"
         else laws.ef_stiffness(e, nu, h))
    if force_N >= k * math.pi * r ** 3 * (2.0 / 3.0):     # d ≥ R: the whole hemisphere
        return r
    d = (force_N / (k * math.pi * r)) ** 0.5              # Newton on F = kπd²(R − d/3)
    for _ in range(50):
        d -= (k * math.pi * d * d * (r - d / 3.0) - force_N) / (k * math.pi * d * (2 * r - d))
    return math.sqrt(max(2.0 * r * d - d * d, 0.0))


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
