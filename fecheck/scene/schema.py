"""The scene schema: every key with its type, default, allowed range and documentation.

A scene is a flat mapping of dotted keys (``contact.poisson``) to values; every key has
a type, a default, an allowed range and a line of documentation in `SCHEMA`. The
packaged ``fecheck/scenes/baseline.toml`` documents every key with comments.

>>> SCHEMA["contact.poisson"].default
0.3
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from fecheck.scene.constants import DOF_NAMES, MODEL_KINDS
from fecheck.scene.knee import PRESETS


@dataclass(frozen=True)
class Key:
    """One scene key: kind ("int", "float", "bool", "str", "vec3", "pair", "strings",
    "table", "matrix"), default, allowed choices or numeric bounds, and documentation.
    Numbers must be finite unless `allow_inf` (then +inf is allowed, e.g. a rigid body)."""

    kind: str
    default: Any
    doc: str
    choices: tuple = ()
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    allow_inf: bool = False


def _lig(name: str, stiffness_N: float, reference_strain: float) -> dict[str, Key]:
    return {
        f"ligaments.{name}.stiffness_N": Key(
            "float", stiffness_N, f"{name} spring stiffness, N per unit strain", low=0.0),
        f"ligaments.{name}.reference_strain": Key(
            "float", reference_strain, f"{name} strain at the reference pose", low=-0.5,
            high=1.0),
    }


# Spring defaults: Lenhart et al. 2015 (J. Biomech. Eng. 137, 081006), as shipped in
# /work/shared/data/knee/lenhart2015/ligaments.json: per ligament the sum of its bundles'
# Blankevoort1991Ligament linear stiffnesses (MCL 16 x 500 N, ACL 12 x 820 N,
# PCL 5 x 900 + 5 x 300 N) and the mean of its bundles' strains at rest.
SCHEMA: dict[str, Key] = {
    "name": Key("str", "", "free-text scene name"),
    "gravity": Key("bool", True, "apply the tibia's weight (tibia.mass_kg · 9.81 N, -z)"),
    "model.kind": Key("str", "sphere-plane", "model: rigid (point contacts, linear statics) "
                      "or sphere-plane (meshed condyles on plateaus)", choices=MODEL_KINDS),
    "mesh.sphere_subdivisions": Key("int", 4, "icosphere level: 20·4^n faces per condyle",
                                    low=0, high=7),
    "mesh.method": Key("str", "gmsh", "icosphere builder", choices=("gmsh", "trimesh")),
    "mesh.plateau_radius_mm": Key("float", 14.0, "contact.master = condyle: radius of the "
                                  "meshed plateau disc around each contact point, mm",
                                  low=1.0, high=100.0),
    "mesh.plateau_size_mm": Key("float", 2.0, "plateau element size away from the contact, mm",
                                low=0.01, high=20.0),
    "mesh.plateau_refine_mm": Key("float", 0.8, "plateau element size under the contact, mm",
                                  low=0.01, high=20.0),
    "mesh.plateau_refine_radius_mm": Key("float", 9.0, "radius of the refined zone, mm",
                                         low=0.0, high=100.0),
    "knee.preset": Key("str", "baseline-right", "landmarks: thesis Table B.1, Table B.3 or "
                       "custom (knee.side + knee.landmarks)",
                       choices=tuple(PRESETS) + ("custom",)),
    "knee.side": Key("str", "right", "custom knee side", choices=("right", "left")),
    "knee.landmarks": Key("table", None, "custom landmarks (see fecheck.scene.knee)"),
    "plateau.kind": Key("str", "transverse", "tibial plateau: transverse planes, inclined "
                        "planes, or z = f(x, y) polynomials",
                        choices=("transverse", "inclined", "polynomial")),
    "plateau.medial_angles_deg": Key("pair", [-0.36, -5.93], "medial plane slopes (λ sagittal, "
                                     "γ frontal), deg, thesis Table 2.1 without outliers"),
    "plateau.lateral_angles_deg": Key("pair", [-0.34, 9.82], "lateral plane (λ, γ)"),
    "plateau.medial_coefficients": Key("matrix", None, "medial z = Σ c[i][j] x^i y^j, "
                                       "tibia frame, mm"),
    "plateau.lateral_coefficients": Key("matrix", None, "lateral z = Σ c[i][j] x^i y^j"),
    "contact.law": Key("str", "ef", "contact law", choices=("ef", "hertz", "volumetric",
                                                            "blankevoort")),
    "contact.area": Key("str", "clipped", "in-contact area of a face: clipped at zero depth "
                        "(exact) or the whole face (thesis)", choices=("clipped", "whole-face")),
    "contact.master": Key("str", "condyle", "analytic master: plateau (plane master, "
                          "icosphere slave) or condyle (sphere master, meshed plateau slave)",
                          choices=("plateau", "condyle")),
    "contact.detection": Key("str", "auto", "detection method",
                             choices=("auto", "closed-form", "bvh", "ray-parity", "fcl")),
    "contact.margin_mm": Key("float", 2.0, "broad-phase margin, mm", low=0.0),
    "contact.youngs_MPa": Key("float", 20.0, "cartilage Young's modulus, MPa", low=0.0,
                              low_open=True),
    "contact.poisson": Key("float", 0.3, "cartilage Poisson's ratio", low=0.0, high=0.5,
                           high_open=True),
    "contact.thickness_mm": Key("float", 6.0, "cartilage thickness h, mm", low=0.0,
                                low_open=True),
    "contact.volumetric_stiffness_N_per_mm3": Key(
        "float", 1e-2, "volumetric k_V, N/mm³ (thesis 1e7 N/m³ = 1e-2 N/mm³)", low=0.0,
        low_open=True),
    "contact.indenter_youngs_MPa": Key("float", math.inf, "Hertz: indenter modulus, MPa "
                                       "(inf = rigid)", low=0.0, low_open=True,
                                       allow_inf=True),
    "contact.indenter_poisson": Key("float", 0.3, "Hertz: indenter Poisson's ratio",
                                    low=0.0, high=0.5, high_open=True),
    "load.force_N": Key("float", 800.0, "external load magnitude, N", low=0.0),
    "load.point_mm": Key("vec3", [7.9, 12.8, -380.0], "load point in the tibia frame, mm "
                         "(x = +7.9 reproduces the thesis's Table 5.1; it prints -7.9 in error)"),
    "load.frame": Key("str", "world", "the load point is fixed in the world (line of action "
                      "fixed, e.g. a ground reaction) or moves with the tibia",
                      choices=("world", "tibia")),
    "load.direction": Key("vec3", [0.0, 0.0, 1.0], "load direction (normalised), world"),
    "tibia.mass_kg": Key("float", 2.0, "tibia mass, kg", low=0.0),
    "tibia.com_mm": Key("vec3", [0.0, 12.8, -190.0], "tibia centre of mass, tibia frame, mm"),
    "ligaments.model": Key("str", "none", "ligaments: none, rods of constant length "
                           "(Lagrange multipliers) or Blankevoort 1991 springs",
                           choices=("none", "rod", "spring")),
    "ligaments.transition_strain": Key("float", 0.06, "spring: 2ε_l, end of the toe region",
                                       low=0.0, low_open=True, high=1.0),
    **_lig("ACL", 9840.0, -0.0708),
    **_lig("PCL", 6000.0, -0.057),
    **_lig("MCL", 8000.0, 0.0289),
    "dofs.free": Key("strings", ["z", "abduction"], "free tibia DOFs (others driven)",
                     choices=DOF_NAMES),
    "dofs.x_mm": Key("float", 0.0, "tibia x: driven value or start, mm"),
    "dofs.y_mm": Key("float", 0.0, "tibia y, mm"),
    "dofs.z_mm": Key("float", 0.0, "tibia z, mm"),
    "dofs.abduction_deg": Key("float", 0.0, "θy, deg", low=-45.0, high=45.0),
    "dofs.internal_deg": Key("float", 0.0, "θz, deg", low=-45.0, high=45.0),
    "dofs.flexion_deg": Key("float", 0.0, "θx (always driven), deg", low=-45.0, high=45.0),
    "constraints.equal_forces": Key("bool", False, "constrain medial force = lateral force"),
    "solver.start_gap_mm": Key("float", 0.0, "start with the tibia this far below the "
                               "reference pose, mm", low=0.0, high=50.0),
    "solver.max_iterations": Key("int", 60, "Newton iteration cap", low=1, high=1000),
    "solver.tolerance": Key("float", 1e-8, "residual tolerance relative to the load",
                            low=0.0, low_open=True, high=1e-2),
    # Scanned knee (fecheck.scene.scanned, fecheck.model.scanned): sphere-tibia, femur-tibia.
    "scanned.data_dir": Key("str", "", "scanned knee folder; '' = $FECHECK_KNEE_DIR or "
                            "<repo>/../shared/data/knee/lenhart2015"),
    "scanned.thickness": Key("str", "uniform", "sphere-tibia/femur-tibia foundation "
                             "thickness: contact.thickness_mm, or per face the tibial + "
                             "femoral cartilage to bone",
                             choices=("uniform", "bone-distance")),
    "scanned.decimate_faces": Key("int", 0, "sphere-tibia/femur-tibia: 0 = full meshes, "
                                  "N = about N tibial faces",
                                  low=0),
    "scanned.condyle": Key("str", "sphere", "sphere-tibia condyles: spheres or hemispheres "
                           "cut towards the notch", choices=("sphere", "hemisphere")),
    "scanned.hemisphere_cut_mm": Key("float", 10.0, "hemisphere cut: distance of the "
                                     "sagittal cut plane from the centre towards the notch, mm",
                                     low=0.0),
    "scanned.ligaments": Key("str", "none", "the scanned knee's 55 Blankevoort bundles as "
                             "springs (any contact model)", choices=("none", "bundles")),
    # FE cross-check (fecheck.fe, `fecheck fe`).
    "fe.size_mm": Key("float", 1.5, "3D FE element size under the contact, mm", low=0.05,
                      high=10.0),
    "fe.far_size_mm": Key("float", 5.0, "3D FE element size away from the contact, mm",
                          low=0.1, high=20.0),
    "fe.half_extent_mm": Key("float", 30.0, "FE layer half-extent (disc radius), mm",
                             low=1.0, high=200.0),
    "fe.footprint": Key("str", "ellipse", "FE layer outline", choices=("ellipse", "rectangle")),
    "fe.gap": Key("str", "reference", "FE contact gap: vertical in the reference or the "
                  "deformed configuration", choices=("reference", "deformed")),
    "fe.solver": Key("str", "cholmod", "FE sparse factorization",
                     choices=("cholmod", "superlu")),
    "fe.axisym_size_mm": Key("float", 0.1, "axisymmetric FE element size under the contact, mm",
                             low=0.005, high=2.0),
}
