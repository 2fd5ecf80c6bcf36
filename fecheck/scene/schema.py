"""The scene schema: every key with its type, default, allowed range and documentation.

A scene is a flat mapping of dotted keys (``contact.poisson``) to values; every key has
a type, a default, an allowed range, a unit and a line of documentation in `SCHEMA`.
The documentation is written to be read alone (``fecheck keys``, ``docs/scene-keys.md``
and the comments of the packaged ``fecheck/scenes/baseline.toml`` are generated from it
by `fecheck.scene.document`).

>>> SCHEMA["contact.poisson"].default
0.3
>>> unit_of("contact.youngs_MPa"), unit_of("ligaments.ACL.stiffness_N")
('MPa', 'N per unit strain')
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from fecheck.scene.constants import DOF_NAMES, MODEL_KINDS
from fecheck.scene.knee import PRESETS
from fecheck.scene.law_keys import law_doc, law_names


@dataclass(frozen=True)
class Key:
    """One scene key: kind ("int", "float", "bool", "str", "vec3", "pair", "strings",
    "table", "matrix"), default, documentation, allowed choices or numeric bounds.

    Numbers must be finite unless `allow_inf` (then +inf is allowed, e.g. a rigid body).
    `unit` overrides the unit read from the key's name suffix (`unit_of`); `example` is a
    value shown in the generated documents for a key whose default is unset (None).
    """

    kind: str
    default: Any
    doc: str
    choices: tuple = ()
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    allow_inf: bool = False
    unit: str = ""
    example: Any = None


DIMENSIONLESS = "dimensionless"

UNIT_SUFFIXES = (("_N_per_mm3", "N/mm³"), ("_MPa", "MPa"), ("_mm", "mm"), ("_deg", "deg"),
                 ("_kg", "kg"), ("_N", "N"))
"""Key-name suffix → unit, longest first."""


def unit_of(key: str) -> str:
    """The unit of a scene key: its explicit `Key.unit`, else from its name suffix
    (`UNIT_SUFFIXES`), else "" (not a physical quantity: a name, switch or count)."""
    spec = SCHEMA[key]
    if spec.unit:
        return spec.unit
    for suffix, unit in UNIT_SUFFIXES:
        if key.endswith(suffix):
            return unit
    return ""


SECTIONS: dict[str, str] = {
    "": "Scene",
    "model": "Model kind",
    "mesh": "Meshes of the sphere-plane model (condyle icospheres and plateau discs)",
    "knee": "Knee landmarks",
    "plateau": "Tibial plateau shape",
    "contact": "Contact law, detection and cartilage material",
    "load": "External load on the tibia",
    "tibia": "Tibia mass",
    "ligaments": "Ligaments ACL, PCL and MCL of the knee landmarks",
    "dofs": "Tibia degrees of freedom and pose",
    "constraints": "Extra constraints",
    "solver": "Newton solver",
    "geometry": "Knee surfaces from mesh files: sphere-tibia and femur-tibia models",
    "scanned": "Sphere-tibia and femur-tibia models: thickness, decimation, condyles, "
               "ligament bundles",
    "menisci": "Femur-tibia model with menisci (rigid bodies between the cartilages)",
    "patella": "The patellofemoral joint in driven flexion (`fecheck flex`)",
    "fe": "FE cross-check (`fecheck fe`)",
    "flexion": "Driven flexion (`fecheck flex`)",
}
"""Section (first part of a dotted key; "" for top-level keys) → its title."""


def _lig(name: str, stiffness_N: float, reference_strain: float, bundles: str) -> dict[str, Key]:
    return {
        f"ligaments.{name}.stiffness_N": Key(
            "float", stiffness_N,
            f"Stiffness of the {name} spring in its linear region, N per unit strain "
            f"(ligaments.model = 'spring'). Default: the sum of the linear stiffnesses of "
            f"the {name} bundles of Lenhart et al. 2015 ({bundles}; ligaments.json of the "
            f"scanned knee data).",
            low=0.0, unit="N per unit strain"),
        f"ligaments.{name}.reference_strain": Key(
            "float", reference_strain,
            f"Strain of the {name} spring at the reference pose, dimensionless: its slack "
            f"length is the reference length / (1 + strain); negative = slack "
            f"(ligaments.model = 'spring'). Default: the mean rest strain of the {name} "
            f"bundles of Lenhart et al. 2015.", low=-0.5, high=1.0, unit=DIMENSIONLESS),
    }


def _dof(axis: str, what: str, extra: str = "") -> str:
    return (f"Tibia {what}: its driven value, or the start of the solve when "
            f"{axis} is in dofs.free.{extra}")


_LANDMARKS_EXAMPLE = {
    "condyle_center": {"medial": [-20.4, 12.8, 16.8], "lateral": [28.3, 12.8, 25.8]},
    "contact_point": {"medial": [-20.4, 12.8, -8.7], "lateral": [28.3, 12.8, -6.0]},
    "femur_attachment": {"ACL": [17.0, 31.4, 20.4], "PCL": [-7.9, 21.3, 8.8],
                         "MCL": [-38.0, 13.8, 11.2]},
    "tibia_attachment": {"ACL": [0.0, 0.0, 0.0], "PCL": [18.3, 35.5, -21.3],
                         "MCL": [-3.0, -1.0, -64.6]},
}
"""The baseline-right landmarks (thesis Table B.1), as a custom table."""

_FE = "`fecheck fe` only: "

SCHEMA: dict[str, Key] = {
    "name": Key("str", "", "Free-text name of the scene, shown in reports and result files "
                "('' shows the scene file's path)."),
    "gravity": Key("bool", True, "Apply the tibia's weight: tibia.mass_kg × 9.81 N along -z "
                   "at tibia.com_mm."),
    "model.kind": Key(
        "str", "sphere-plane",
        "Model: 'rigid' = each condyle a ball on a frictionless plateau plane, point "
        "contacts and linear statics (thesis §5.1); 'sphere-plane' = condyle spheres on "
        "transverse, inclined or polynomial plateaus with a contact law, Newton statics "
        "(§5.2.1); 'sphere-tibia' = the knee's condyle spheres on a tibial articular "
        "surface read from a file; 'femur-tibia' = a femoral on a tibial articular surface, "
        "both from files (§5.2.2-5.2.3; natural cartilage or implant; see [geometry]).",
        choices=MODEL_KINDS),
    "mesh.sphere_subdivisions": Key(
        "int", 4,
        "Icosphere level n of each meshed femoral condyle: 20·4^n faces (4 → 5,120 faces). "
        "A condyle is meshed with contact.master = 'plateau', with mesh detection "
        "(contact.detection 'bvh', 'ray-parity' or 'fcl') and for scanned.condyle = "
        "'hemisphere'; otherwise it is an exact sphere.", low=0, high=7),
    "mesh.method": Key("str", "gmsh", "How a meshed condyle icosphere is built: 'gmsh' "
                       "(refined icosahedron) or 'trimesh' (see mesh.sphere_subdivisions).",
                       choices=("gmsh", "trimesh")),
    "mesh.plateau_radius_mm": Key(
        "float", 14.0,
        "Radius of the meshed plateau disc around each contact point, mm (sphere-plane "
        "model with contact.master = 'condyle'; for the Hertz point contact it only draws "
        "the pressure). Left at the default it is widened to 1.25 × the expected contact "
        "radius at the whole load; raise it if a contact reaches the disc rim.",
        low=1.0, high=100.0),
    "mesh.plateau_size_mm": Key("float", 2.0, "Element size of the meshed plateau disc away "
                                "from the contact, mm (see mesh.plateau_radius_mm).",
                                low=0.01, high=20.0),
    "mesh.plateau_refine_mm": Key(
        "float", 0.8,
        "Element size of the meshed plateau disc under the contact, mm (see "
        "mesh.plateau_radius_mm). Left at the default it is halved until 8 elements span "
        "the expected contact radius at half the load.", low=0.01, high=20.0),
    "mesh.plateau_refine_radius_mm": Key(
        "float", 9.0,
        "Radius of the refined zone (element size mesh.plateau_refine_mm) of the meshed "
        "plateau disc around the contact point, mm. Left at the default it is fitted to "
        "the expected contact.", low=0.0, high=100.0),
    "knee.preset": Key(
        "str", "baseline-right",
        "Knee landmarks (condyle centres, contact points, ligament attachments): "
        "'baseline-right' = the thesis's right knee (Table B.1), 'additional-left' = its "
        "left knee (Table B.3), 'custom' = knee.side and the knee.landmarks table, 'fit' "
        "= the condyle spheres fitted to the femoral surface geometry.femur (its "
        "posterior-distal cartilage; sphere-tibia model without the three-ligament "
        "model; the fitted spheres are printed with the result).",
        choices=tuple(PRESETS) + ("custom", "fit")),
    "knee.side": Key("str", "right", "Side of a custom or fitted knee (knee.preset = "
                     "'custom' or 'fit'; and "
                     "of every femur-tibia knee without the three-ligament model): "
                     "'right' has its medial compartment at -x, 'left' at +x.",
                     choices=("right", "left")),
    "knee.landmarks": Key(
        "table", None,
        "Landmarks of a custom knee (knee.preset = 'custom'), mm, tibia frame at the "
        "reference pose: tables condyle_center and contact_point (keys medial, lateral) "
        "and femur_attachment and tibia_attachment (keys ACL, PCL, MCL), each value 3 "
        "coordinates. Condyle radius = centre-to-contact-point distance; ligament "
        "reference length = distance between its attachments.",
        unit="mm", example=_LANDMARKS_EXAMPLE),
    "plateau.kind": Key(
        "str", "transverse",
        "Tibial plateau shape: 'transverse' = horizontal planes through the contact "
        "points, 'inclined' = planes sloped by plateau.medial_angles_deg and "
        "plateau.lateral_angles_deg, 'polynomial' = surfaces z = Σ c[i][j] x^i y^j "
        "(plateau.medial_coefficients, plateau.lateral_coefficients).",
        choices=("transverse", "inclined", "polynomial")),
    "plateau.medial_angles_deg": Key(
        "pair", [-0.36, -5.93],
        "Slopes (λ sagittal, γ frontal) of the medial plateau plane for plateau.kind = "
        "'inclined', deg: the plane z = x·tan γ + y·tan λ + c touching the condyle sphere "
        "at the reference pose. Default: thesis Table 2.1 without outliers."),
    "plateau.lateral_angles_deg": Key(
        "pair", [-0.34, 9.82],
        "Slopes (λ sagittal, γ frontal) of the lateral plateau plane for plateau.kind = "
        "'inclined', deg (see plateau.medial_angles_deg). Default: thesis Table 2.1 "
        "without outliers."),
    "plateau.medial_coefficients": Key(
        "matrix", None,
        "Medial plateau surface for plateau.kind = 'polynomial': z = Σ c[i][j] x^i y^j, "
        "mm, tibia frame; a list of rows, c[i][j] multiplies x^i y^j.",
        unit="mm", example=[[-8.7, 0.0], [0.01, 0.0]]),
    "plateau.lateral_coefficients": Key(
        "matrix", None,
        "Lateral plateau surface for plateau.kind = 'polynomial': z = Σ c[i][j] x^i y^j, "
        "mm, tibia frame (see plateau.medial_coefficients).",
        unit="mm", example=[[-6.0, 0.0], [-0.01, 0.0]]),
    "contact.law": Key("str", "ef", law_doc(), choices=law_names()),
    "contact.calibration": Key(
        "str", "",
        "Calibration file of contact.law = 'ef-calibrated', written by `fecheck calibrate "
        "SCENE -o FILE` (the law's C and n per compartment, fitted to the FE of that scene); "
        "a path relative to the scene file's folder. '' = the built-in table (condyle "
        "spheres on a uniform layer)."),
    "contact.area": Key(
        "str", "clipped",
        "In-contact area of a mesh face: 'clipped' at its zero-depth line (exact) or "
        "'whole-face' (the thesis's counting: it overestimates the area and underestimates "
        "the depth by 12-16% at 5,000 faces, its Table 5.3).",
        choices=("clipped", "whole-face")),
    "contact.master": Key(
        "str", "condyle",
        "Which surface of the sphere-plane model is analytic (the master): 'condyle' = an "
        "exact sphere over a meshed plateau disc refined under the contact (depth, area "
        "and pressure within 0.2% of the exact EF values), or 'plateau' = an exact plane "
        "under a meshed icosphere, the thesis's way (at 5,120 faces the inscribed "
        "polyhedron holds less volume: depth and maximum pressure ~2% too large, area and "
        "force exact to 0.1%).", choices=("plateau", "condyle")),
    "contact.detection": Key(
        "str", "auto",
        "Contact detection: 'auto' (closed form for analytic masters), 'closed-form', "
        "'bvh', or the thesis's stacks 'ray-parity' and 'fcl'. The last three are mesh "
        "detection: the analytic master is meshed as well. 'ray-parity' and 'fcl' tell "
        "inside from outside and need a closed master mesh (they refuse an open sheet; "
        "'bvh' works on open sheets).",
        choices=("auto", "closed-form", "bvh", "ray-parity", "fcl")),
    "contact.margin_mm": Key("float", 2.0, "Broad-phase margin, mm: candidate faces within "
                             "this distance are found once and reused while the pose moves "
                             "less than 90 % of it (a mesh master) or half of it (an "
                             "analytic one).", low=0.0),
    "contact.youngs_MPa": Key("float", 20.0, "Young's modulus E of the cartilage, MPa (the "
                              "foundation and Hertz laws and the FE cross-check).", low=0.0,
                              low_open=True),
    "contact.poisson": Key("float", 0.3, "Poisson's ratio ν of the cartilage, "
                           "dimensionless, below 0.5 (the EF stiffness diverges as ν → 0.5).",
                           low=0.0, high=0.5, high_open=True, unit=DIMENSIONLESS),
    "contact.thickness_mm": Key(
        "float", 6.0,
        "Thickness h of the cartilage layer, mm: EF stiffness k = (1-ν)E / ((1+ν)(1-2ν)h); "
        "the Blankevoort law's layer; a solved depth ≥ h stops the foundation laws (the "
        "layer is crushed through).", low=0.0, low_open=True),
    "contact.femoral_share": Key(
        "float", 0.5,
        "The femoral cartilage's share of contact.thickness_mm where the two layers are "
        "uniform, dimensionless: femoral h·share, tibial h·(1 - share). The linear EF's "
        "depth split between the layers and the two-layer FE (fe.cartilage) read it; "
        "0.5 = equal layers.", low=0.0, high=1.0, low_open=True, high_open=True,
        unit=DIMENSIONLESS),
    "contact.femoral_youngs_MPa": Key(
        "float", None,
        "Young's modulus of the femoral cartilage, MPa; not set = contact.youngs_MPa (one "
        "material). Read by the linear EF (contact.law = 'ef': the layers in series, k = "
        "1/(h_t/c_t + h_f/c_f), c = (1-ν)E/((1+ν)(1-2ν))) and the two-layer FE; "
        "contact.youngs_MPa is then the tibial cartilage's.", low=0.0, low_open=True,
        example=10.0),
    "contact.femoral_poisson": Key(
        "float", None,
        "Poisson's ratio of the femoral cartilage, dimensionless, below 0.5; not set = "
        "contact.poisson. Read as contact.femoral_youngs_MPa is.", low=0.0, high=0.5,
        high_open=True, unit=DIMENSIONLESS, example=0.45),
    "contact.volumetric_stiffness_N_per_mm3": Key(
        "float", 1e-2,
        "Stiffness k_V of the volumetric law (contact.law = 'volumetric'), N/mm³: pressure "
        "= k_V × depth, force = k_V × overlap volume. The thesis's 1e7 N/m³ = 1e-2 N/mm³.",
        low=0.0, low_open=True),
    "contact.indenter_youngs_MPa": Key(
        "float", math.inf,
        "Young's modulus of the indenting condyle for the Hertz law (contact.law = "
        "'hertz'), MPa; inf = rigid: E* = E / (1 - ν²).", low=0.0, low_open=True,
        allow_inf=True),
    "contact.indenter_poisson": Key(
        "float", 0.3,
        "Poisson's ratio of the indenting condyle for the Hertz law, dimensionless; used "
        "only with a finite contact.indenter_youngs_MPa.", low=0.0, high=0.5,
        high_open=True, unit=DIMENSIONLESS),
    "load.force_N": Key("float", 800.0, "Magnitude of the external load on the tibia, N, "
                        "along load.direction through load.point_mm.", low=0.0),
    "load.point_mm": Key(
        "vec3", [7.9, 12.8, -380.0],
        "Point of application of the external load, tibia frame, mm. x = +7.9 mm "
        "reproduces the thesis's Table 5.1 (with a 2.0 kg tibia at x = 0: F_m + F_l = "
        "780.38 N and -20.4·F_m + 28.3·F_l = 800·7.9); the thesis prints x = -7.9 mm, a "
        "sign error."),
    "load.frame": Key(
        "str", "world",
        "'world': the load stays fixed in space (a ground reaction with a fixed centre of "
        "pressure); 'tibia': load.point_mm and load.direction are in the tibia frame and "
        "turn with it, a follower load whose line of action is fixed in the tibia (e.g. a "
        "compression along the tibial axis in `fecheck flex`). On the baseline both give "
        "the same split to 0.01 N (its tilt is 0.07°). A force fixed in space at a point "
        "turning with the tibia (what 'tibia' did before) is a column under a dead load: "
        "the scanned knee's flexion buckled at 3-4° under 800 N.",
        choices=("world", "tibia")),
    "load.direction": Key("vec3", [0.0, 0.0, 1.0], "Direction of the external load, world "
                          "frame (tibia frame with load.frame = 'tibia'), normalised on use: "
                          "[0, 0, 1] pushes the tibia up against the femur."),
    "tibia.mass_kg": Key("float", 2.0, "Mass of the tibia (shank), kg; its weight acts at "
                         "tibia.com_mm when gravity = true. 2.0 kg at x = 0 reproduces the "
                         "thesis's Table 5.1 (weight 19.62 N).", low=0.0),
    "tibia.com_mm": Key("vec3", [0.0, 12.8, -190.0], "Centre of mass of the tibia, where "
                        "its weight acts, tibia frame, mm."),
    "ligaments.model": Key(
        "str", "none",
        "Ligaments ACL, PCL and MCL between the knee's attachment landmarks: 'none', "
        "'rod' = inextensible rods of constant length (Lagrange multipliers, thesis eq. "
        "1.7) or 'spring' = Blankevoort 1991 springs (their stiffness_N and "
        "reference_strain keys, e.g. ligaments.ACL.stiffness_N; contact models only).",
        choices=("none", "rod", "spring")),
    "ligaments.transition_strain": Key(
        "float", 0.06,
        "Spring ligaments: the strain 2ε_l (ε_l = 0.03) that ends the quadratic toe region, "
        "dimensionless; the spring is linear beyond it.", low=0.0, low_open=True, high=1.0,
        unit=DIMENSIONLESS),
    "ligaments.wrap": Key(
        "bool", False,
        "Ligament bundles whose data has a wrap object (the lenhart2015 knee: MCLs1-6, "
        "MCLd1-5 and MCLp1-5 over two ellipsoids fixed to the tibia, pCAP1-8 over a "
        "cylinder fixed to the femur; with patella.dir the patellar tendon PT1-6 over an "
        "ellipsoid fixed to the patella) take the shortest path over it, as the source "
        "model does, when the straight line would pass through it: its length strains "
        "the spring, and the force acts along the segment from the free end to its "
        "tangent point. false (the default) = straight lines from origin to insertion "
        "(scanned.ligaments = 'bundles' and patella.dir): wrapped, this knee's passive "
        "flexion turns the tibia up to 3.4° further from its source model's at 10-60°, "
        "the flex with the patella takes twice as long and stops at 84° "
        "(validation/flex_passive.py)."),
    **_lig("ACL", 9840.0, -0.0708, "12 × 820 N"),
    **_lig("PCL", 6000.0, -0.057, "5 × 900 N + 5 × 300 N"),
    **_lig("MCL", 8000.0, 0.0289, "16 × 500 N"),
    "dofs.free": Key(
        "strings", ["z", "abduction"],
        "Tibia degrees of freedom solved for, at least one, among x, y, z, abduction (θy) "
        "and internal (θz); the others are driven at their dofs.* values, which also start "
        "the free ones. Flexion (θx) is always driven. On frictionless transverse plateaus "
        "without ligaments x, y and internal carry no load and must be driven.",
        choices=DOF_NAMES),
    "dofs.x_mm": Key("float", 0.0, _dof("x", "translation x (to the subject's right), mm")),
    "dofs.y_mm": Key("float", 0.0, _dof("y", "translation y (anterior), mm")),
    "dofs.z_mm": Key("float", 0.0, _dof("z", "translation z (superior), mm", " 0 = the "
                                         "reference pose, the condyles touching the "
                                         "plateaus.")),
    "dofs.abduction_deg": Key("float", 0.0, _dof(
        "abduction", "angle θy, deg (old name: + moves the distal tibia toward -x, which is "
        "adduction (varus) in a right knee and abduction in a left one; reports give "
        "adduction_deg, + adduction, on either side)"), low=-45.0, high=45.0),
    "dofs.internal_deg": Key("float", 0.0, _dof(
        "internal", "angle θz, deg (+ turns the tibia's anterior toward -x: internal "
        "rotation in a right knee, external in a left one; reports give "
        "internal_rotation_deg, + internal, on either side)"), low=-45.0, high=45.0),
    "dofs.flexion_deg": Key("float", 0.0, "Tibia flexion angle θx, deg; always driven.",
                            low=-45.0, high=45.0),
    "flexion.axis_point_mm": Key(
        "vec3", None,
        "A point of the knee flexion axis `fecheck flex` turns the tibia about, mm, femur "
        "frame (with flexion.axis_dir); unset: the axis through the centres of spheres "
        "fitted to the posterior condyles of the femoral surface.",
        example=[-0.48, 3.14, 26.47]),
    "flexion.axis_dir": Key(
        "vec3", None,
        "Direction of that flexion axis (with flexion.axis_point_mm), normalised and turned "
        "towards +x on use; within 78° of x.", unit=DIMENSIONLESS,
        example=[0.9982, -0.0599, -0.0033]),
    "constraints.equal_forces": Key("bool", False, "Constrain the medial and lateral contact "
                                    "forces to be equal (thesis Fig. 5.12); not available "
                                    "in the scanned models."),
    "solver.start_gap_mm": Key("float", 0.0, "Start the Newton solve with the tibia this far "
                               "below the reference (touching) pose, mm.", low=0.0, high=50.0),
    "solver.max_iterations": Key("int", 60, "Cap on the Newton iterations (the rigid model "
                                 "is solved directly).", low=1, high=1000),
    "solver.tolerance": Key(
        "float", 1e-8,
        "Newton convergence: residual force norm relative to the load scale (the largest "
        "of load.force_N, the tibia's weight and 1 N), dimensionless.", low=0.0,
        low_open=True, high=1e-2, unit=DIMENSIONLESS),
    "geometry.dir": Key(
        "str", "",
        "Folder the [geometry] file paths are relative to: '' = the scene file's folder; a "
        "relative folder is itself relative to the scene file's folder; ~ and $VARIABLES "
        "are expanded; 'fecheck:knee/lenhart2015' = the lenhart2015 scanned knee packaged "
        "with fecheck (its meshes and ligaments.json; docs/data.md)."),
    "geometry.units": Key("str", "mm", "Length unit of every [geometry] mesh file: 'mm' or "
                          "'m' (scaled by 1000). A surface whose extent is not a knee's in "
                          "mm (5-1000 mm across) is refused, naming the likely unit.",
                          choices=("mm", "m")),
    "geometry.femur": Key(
        "str", "",
        "Femoral articular surface (sphere-tibia fits and femur-tibia models): any mesh "
        "file meshio reads (STL, OBJ, PLY, VTK/VTU, MSH) of triangles; an open cartilage "
        "sheet with normals pointing out of the cartilage (down, toward the tibia), or a "
        "closed implant component with outward normals. Fixed (the femur frame is the "
        "world)."),
    "geometry.tibia": Key(
        "str", "",
        "Tibial articular surface (sphere-tibia and femur-tibia models), normals pointing "
        "out of the cartilage (up): both compartments in one file, split by "
        "geometry.tibia_split; or the medial compartment alone when geometry.tibia_lateral "
        "is given."),
    "geometry.tibia_lateral": Key("str", "", "Lateral tibial articular surface, one "
                                  "compartment per file ('' = both compartments are in "
                                  "geometry.tibia)."),
    "geometry.tibia_solid": Key(
        "str", "",
        "Closed triangle surface of the whole tibial cartilage volume or implant insert "
        "(same formats, units and transform as geometry.tibia): one closed piece for both "
        "compartments or two, one per compartment. `fecheck fe` meshes it in tetrahedra "
        "(Gmsh) instead of extruding the sheet (fe.body): its articular face is the part "
        "of its boundary on geometry.tibia (within 0.1 mm), its base is fixed "
        "(fe.solid_base_deg), its walls are free. Without geometry.tibia the EF's sheet is "
        "its up-facing part (normals within 75 deg of +z, seen from above), split by "
        "geometry.tibia_split. '' = no solid."),
    "geometry.tibia_split": Key(
        "str", "components",
        "How one geometry.tibia file is split into compartments: 'components' = its two "
        "connected pieces; 'sagittal' = the two sides of the plane x = "
        "geometry.split_x_mm. Medial is at -x in a right knee, +x in a left one "
        "(knee.side).", choices=("components", "sagittal")),
    "geometry.split_x_mm": Key("float", 0.0, "The sagittal plane x of geometry.tibia_split "
                               "= 'sagittal', mm (after units and transform).",
                               low=-500.0, high=500.0),
    "geometry.femur_bone": Key("str", "", "Femoral bone surface, for scanned.thickness = "
                               "'bone-distance' (the femoral cartilage's thickness is its "
                               "distance to this bone)."),
    "geometry.tibia_bone": Key("str", "", "Tibial bone surface, for scanned.thickness = "
                               "'bone-distance'."),
    "geometry.ligaments": Key(
        "str", "",
        "Ligament bundle file for scanned.ligaments = 'bundles': a JSON list of bundles, "
        "each with name, group, points_mm (two attachments), points_bone (which bone each "
        "is on: 'femur' or another) and parameters linear_stiffness (N per unit strain), "
        "slack_length (m) and transition_strain (the layout of OpenSim's "
        "Blankevoort1991Ligament, as exported in the lenhart2015 data set)."),
    "geometry.rotation_deg": Key(
        "vec3", [0.0, 0.0, 0.0],
        "Rotation of every [geometry] surface into the thesis frame, about the fixed x, y "
        "and z axes in that order, deg (after units, before translation).",
        low=-360.0, high=360.0),
    "geometry.translation_mm": Key("vec3", [0.0, 0.0, 0.0], "Translation of every "
                                   "[geometry] surface after the rotation, mm.",
                                   low=-10000.0, high=10000.0),
    "geometry.smooth_mm": Key(
        "float", 0.0,
        "Smooth the femoral and tibial articular sheets over this length as they are read, "
        "for the EF run and the FE alike: each vertex moves onto the least-squares quadric "
        "fitted to the sheet within this distance (removes segmentation terraces and "
        "slivers narrower than it; a smooth curved sheet barely moves), mm; 0 = the "
        "sheets as read. `fecheck fe` says how far the sheets moved.",
        low=0.0, high=20.0),
    "scanned.thickness": Key(
        "str", "uniform",
        "Foundation thickness of the sphere-tibia and femur-tibia models: 'uniform' = "
        "contact.thickness_mm everywhere; 'bone-distance' = per tibial face the tibial and "
        "femoral cartilage in series, each the distance from the articular surface to its "
        "bone along the inward normal (OpenSim-JAM's way; needs contact.law = 'ef').",
        choices=("uniform", "bone-distance")),
    "scanned.decimate_faces": Key(
        "int", 0,
        "Sphere-tibia and femur-tibia models: 0 = the full meshes (8,602 tibial and 29,782 "
        "femoral cartilage faces); N = about N tibial faces in total, the femoral sheet "
        "decimated in the same proportion.", low=0, unit="faces"),
    "scanned.condyle": Key(
        "str", "sphere",
        "Condyles of the sphere-tibia model: 'sphere' = exact spheres, or 'hemisphere' = "
        "meshed spheres cut by a sagittal plane scanned.hemisphere_cut_mm from the centre "
        "towards the notch, so they cannot reach the intercondylar eminence (thesis Fig. "
        "5.13).", choices=("sphere", "hemisphere")),
    "scanned.hemisphere_cut_mm": Key(
        "float", 10.0,
        "Distance of the hemisphere's sagittal cut plane from the sphere centre towards "
        "the notch, mm (scanned.condyle = 'hemisphere').", low=0.0),
    "scanned.ligaments": Key(
        "str", "none",
        "'bundles' adds the scanned knee's 55 ligament bundles (Lenhart et al. 2015, "
        "Blankevoort 1991 springs) to any contact model; ligaments.model must then be "
        "'none'. 'none' = no bundles.", choices=("none", "bundles")),
    "scanned.thickness_scale": Key(
        "float", 1.0,
        "Factor on the bone-distance cartilage thickness of every face, both layers "
        "(scanned.thickness = 'bone-distance'), dimensionless: a thinner or thicker "
        "cartilage on the same surfaces (`fecheck population`). 1 = as measured.",
        low=0.0, high=5.0, low_open=True, unit=DIMENSIONLESS),
    "scanned.ligament_stiffness_scale": Key(
        "float", 1.0,
        "Factor on the linear-region stiffness of every ligament bundle "
        "(scanned.ligaments = 'bundles'), dimensionless. 1 = the file's stiffnesses.",
        low=0.0, high=10.0, unit=DIMENSIONLESS),
    "scanned.ligament_slack_scale": Key(
        "float", 1.0,
        "Factor on the slack length of every ligament bundle (scanned.ligaments = "
        "'bundles'), dimensionless: below 1 tightens every bundle (a bundle at its rest "
        "length l has strain l / (factor · l0) − 1). 1 = the file's slack lengths.",
        low=0.5, high=2.0, unit=DIMENSIONLESS),
    "patella.dir": Key(
        "str", "",
        "The patellofemoral joint in `fecheck flex`: the folder of the scanned knee's "
        "patella ('fecheck:knee/lenhart2015_patella' = the lenhart2015 patella packaged with "
        "fecheck; a path is relative to the scene file's folder); '' = no patella. The "
        "patella is a rigid body with six free DOFs, in contact with the femoral articular "
        "surface (its cartilage sheet, the scene's law and scanned.thickness, as the "
        "tibia's), held by its 20 bundles (the patellar tendon to the tibia, the lateral "
        "and medial patellofemoral bundles to the femur; the tendon over its wrap "
        "ellipsoid with ligaments.wrap, the others straight; scanned.ligament_*_scale "
        "applied) and pulled by the quadriceps "
        "(patella.quadriceps_N), solved with the tibia at each angle. Read by `fecheck "
        "flex` (with --fe-at, its FE too: the patellar cartilage a layer on the patella) "
        "and `fecheck fe` (the tibia and the patella at the scene's pose); `fecheck run` "
        "leaves it out.",
        example="fecheck:knee/lenhart2015_patella"),
    "patella.quadriceps_N": Key(
        "float", 111.442,
        "Total quadriceps tension with patella.dir, N, split between rectus femoris, vastus "
        "intermedius, lateralis and medialis by their maximum isometric forces (848.8, "
        "1024.2, 2255.4, 1443.7 N), each along its line of action at the patella (the "
        "vasti toward their last femoral path point; the rectus femoris along the "
        "femoral shaft). Default: 2 % of the 5,572.1 N summed, the source model's passive "
        "flexion (muscles at 2 % activation; force-length and passive fibre forces not "
        "modelled). Above 0: without it nothing presses the patella on the trochlea.",
        low=0.0, low_open=True),
    "menisci.dir": Key(
        "str", "",
        "Femur-tibia model with menisci: the folder of the smith2019 menisci of the scanned "
        "knee ('fecheck:knee/smith2019_menisci' = the copy packaged with fecheck; a path is "
        "relative to the scene file's folder); '' = no menisci. Each meniscus is a rigid "
        "body with six free DOFs, in EF contact with the femoral and the tibial cartilage "
        "and held by its horn roots (menisci.roots; ligaments: menisci.coronary, "
        "menisci.transverse); the femur "
        "starts at smith2019's default knee pose (the data set's matrix G) and the scene's "
        "dofs.* start pose is taken relative to it. Needs contact.law = 'ef'.",
        example="fecheck:knee/smith2019_menisci"),
    "menisci.sides": Key(
        "strings", ["medial", "lateral"],
        "The menisci present with menisci.dir: ['lateral'] = a medial meniscectomy, [] = "
        "both removed (the ligaments of a removed meniscus go with it).",
        choices=("medial", "lateral")),
    "menisci.remove": Key(
        "strings", [],
        "Total meniscectomy: the menisci removed, with their root springs and ligaments "
        "(['medial'] = a total medial meniscectomy), in the EF and in fecheck fe.",
        choices=("medial", "lateral")),
    "menisci.torn_roots": Key(
        "strings", [],
        "Root tears: each listed horn's root attachment removed (its root spring, or its "
        "root bundles with menisci.roots = 'bundles'), e.g. ['medial-posterior'] = a "
        "medial posterior root tear.",
        choices=("medial-anterior", "medial-posterior", "lateral-anterior",
                 "lateral-posterior")),
    "menisci.partial": Key(
        "strings", [],
        "Partial meniscectomy: each listed meniscus without the inner third of its width "
        "(at each place along its arc, the third of the way from the inner to the outer "
        "rim, in the tibial plane, cut vertically); the outer two thirds are kept as they "
        "are.", choices=("medial", "lateral")),
    "menisci.roots": Key(
        "str", "springs",
        "Horn root attachments: 'springs' = each horn tied to the tibia by a linear "
        "spring along its root's direction (the line from the root bundles' tibial to "
        "their meniscal points in the data set), menisci.root_N_per_mm each, unstretched "
        "at the start; 'bundles' = the data set's AHORN / PHORN Blankevoort bundles "
        "(smith2019's EF placeholders: 40 N per unit strain over 3-6.6 mm, 6-13 N/mm a "
        "bundle, about a hundred times softer than the roots of FE knee models; a "
        "warning says so).", choices=("springs", "bundles")),
    "menisci.root_N_per_mm": Key(
        "float", 2000.0,
        "Stiffness of each horn's root spring (menisci.roots = 'springs'), N/mm: 2000 "
        "N/mm a horn, the value of Haut Donahue et al. 2003 (J Biomech 36:19) as later FE "
        "knee studies cite it (\"the anterior and posterior meniscal roots for each "
        "meniscus were modeled as linear springs with spring constants of 2000 N/mm\"); "
        "the direction along the root is this model's choice.", low=0.0, low_open=True,
        unit="N/mm"),
    "menisci.coronary": Key(
        "bool", False,
        "Add the data set's coronary (meniscotibial) ligaments, the COR Blankevoort "
        "bundles (25 N per unit strain over 3.5-5.6 mm, slack at the start), EF "
        "placeholders of smith2019."),
    "menisci.transverse": Key(
        "bool", False,
        "Add the data set's transverse ligament between the two anterior horns "
        "(TRANSVLIG1, a Blankevoort bundle, 40 N per unit strain over 26.9 mm), an EF "
        "placeholder of smith2019 (EF only: the FE leaves it out)."),
    "menisci.fit": Key(
        "str", "fitted",
        "The menisci's shape: 'fitted' = each meniscus made to fill the space between "
        "the femoral and the tibial cartilage at the touching pose (the start pose with "
        "the femur moved along the tibia's z and, if the tibia's abduction is free, "
        "turned about its y axis until each compartment's cartilages just touch): every "
        "vertex moved vertically, keeping its relative height in the wedge, so that the "
        "inferior surface lies on the tibial and the superior on the femoral cartilage "
        "(the latter only where the joint space is no taller than the meniscus's tallest "
        "section), tapered to the shipped shape beyond; 'as-shipped' = the data set's "
        "meshes unchanged.", choices=("fitted", "as-shipped")),
    "menisci.free": Key(
        "strings", ["x", "y", "z", "flexion", "abduction", "internal"],
        "Degrees of freedom of each meniscus solved for (translations x, y, z and rotations "
        "flexion θx, abduction θy, internal θz about the tibial origin); the others stay "
        "where the meniscus starts, riding on the tibia's start pose.",
        choices=("x", "y", "z", "flexion", "abduction", "internal")),
    "menisci.youngs_MPa": Key(
        "float", 1.0, "Young's modulus of the meniscus layer of a meniscus EF interface, "
        "MPa (smith2019: 1 MPa); combined with one cartilage layer of the contact "
        "material, contact.thickness_mm / 2 thick, as menisci.layers says.", low=0.0,
        low_open=True),
    "menisci.poisson": Key(
        "float", 0.45, "Poisson's ratio of the meniscus layer (smith2019: 0.45).", low=0.0,
        high=0.5, high_open=True, unit=DIMENSIONLESS),
    "menisci.thickness_mm": Key(
        "float", 3.0, "Thickness of the meniscus layer of a meniscus EF interface, mm "
        "(smith2019: 3 mm, constant).", low=0.0, low_open=True),
    "menisci.layers": Key(
        "str", "lumped",
        "How a meniscus EF interface combines the meniscus layer with one cartilage layer "
        "(contact material, contact.thickness_mm / 2 thick): 'lumped' = smith2019's lumped "
        "model (Bei & Fregly 2003): mean modulus and Poisson's ratio over the summed "
        "thickness; 'series' = the two layers as springs in series (softer).",
        choices=("lumped", "series")),
    "menisci.calibration": Key(
        "str", "",
        "Calibration file of the meniscus interfaces, written by `fecheck calibrate SCENE "
        "-o FILE` on a scene with menisci: per meniscus the law p = C·d·(d + 0.01 mm)^(n−1) "
        "of its femoral and tibial EF interfaces, fitted so that the EF's meniscal share "
        "and the tibial area under the meniscus follow the FE of the same knee; a path "
        "relative to the scene file's folder. '' = the linear EF of menisci.youngs_MPa, "
        "menisci.poisson, menisci.thickness_mm and menisci.layers."),
    "fe.mode": Key("str", "joint", _FE + "'joint' = the tibia's free DOFs are FE unknowns "
                   "under the scene's load, gravity and ligament springs, so the FE finds its "
                   "own medial/lateral split and pose; 'compartment' = each compartment is "
                   "pushed along the EF compartment force's line with its magnitude, from the "
                   "EF pose.", choices=("joint", "compartment")),
    "fe.layers": Key("int", 0, _FE + "levels of quadratic tetrahedra through the cartilage "
                     "thickness (the EF run's tibial surface extruded along its normals); 0 "
                     "= automatic: 2, or 3 where contact.poisson >= 0.45 (2 levels let a "
                     "nearly incompressible layer's pressures zigzag).", low=0, high=32),
    "fe.formulation": Key("str", "auto", _FE + "'displacement' (quadratic tetrahedra), "
                          "'mixed' (plus an element-constant pressure condensed per "
                          "element: accurate as contact.poisson -> 0.5, about the same "
                          "cost) or 'auto' (mixed from contact.poisson 0.45).",
                          choices=("auto", "displacement", "mixed")),
    "fe.grading": Key("float", 1.6, _FE + "each level of elements this many times thicker "
                      "than the one above it (1 = even levels; > 1 thin levels under the "
                      "contact).", low=1.0, high=4.0),
    "fe.refine": Key("int", 0, _FE + "times every surface triangle is split in four before "
                     "extrusion (0 = the EF run's own faces; each split quarters the element "
                     "size on the surface, mesh convergence studies).", low=0, high=4),
    "fe.candidate_gap_mm": Key("float", 0.5, _FE + "surface vertices within this gap of the "
                               "femoral surface (plus the EF depth) at the EF pose may touch; "
                               "widened automatically if a vertex outside penetrates, mm.",
                               low=0.01, high=20.0),
    "fe.solver": Key("str", "cholmod", _FE + "sparse factorization, 'cholmod' "
                     "(scikit-sparse, about 3.5 × faster) or 'superlu' (SciPy).",
                     choices=("cholmod", "superlu")),
    "fe.prepare": Key("str", "auto", _FE + "'on' = the FE meshes prepared articular sheets "
                      "instead of the EF run's faces: rims turning more than 65 deg from the "
                      "sheet's mean normal trimmed, slivers dropped, remeshed as a smoothed "
                      "height field with equilateral triangles of fe.size_mm (the femoral "
                      "surface over each compartment too), FE pressures interpolated back "
                      "onto the EF faces; 'auto' = only when the EF sheet's own extrusion "
                      "inverts (a segmentation's slivers, curled rims, terraces), or when the "
                      "sheets as read would make more than 500,000 FE dofs and preparing "
                      "makes fewer (decided before the EF run); 'off' = never.",
                      choices=("auto", "on", "off")),
    "fe.size_mm": Key("float", 1.0, _FE + "element size (triangle side) of a prepared "
                      "articular sheet (fe.prepare), mm; the femoral surface is remeshed at "
                      "half of it.", low=0.05, high=10.0),
    "fe.smooth_mm": Key("float", 4.0, _FE + "smoothing length of a prepared articular sheet "
                        "(fe.prepare): the height at each element vertex is a quadric fitted "
                        "to the sheet within this radius, so curved shapes are kept and "
                        "terraces and noise shorter than it are averaged out, whatever "
                        "fe.size_mm; 0 = a least-squares fit on the elements, mm.",
                        low=0.0, high=20.0),
    "fe.terraces": Key("str", "off", _FE + "'on' = a prepared sheet cut from voxels (flat "
                       "terraces one step apart) is fitted as a whole: a thin-plate height "
                       "field through the level lines half-way up its risers (the femoral "
                       "surface too, at the tibia's step); 'off' = the local quadric fits of "
                       "fe.smooth_mm on every sheet.",
                       choices=("off", "on")),
    "fe.axisym_size_mm": Key("float", 0.1, _FE + "element size of the axisymmetric FE "
                             "reference under the contact, mm; that reference runs only "
                             "for flat layers (plateau.kind = 'transverse').",
                             low=0.005, high=2.0),
    "fe.body": Key("str", "auto", _FE + "the tibial body: 'solid' = the closed "
                   "geometry.tibia_solid meshed in quadratic tetrahedra, base fixed, walls "
                   "free; 'layer' = the articular sheet extruded into a layer bonded at its "
                   "bottom (with a geometry.tibia_solid: the solid's own thickness map, the "
                   "distance from each sheet vertex along its inward normal to the solid's "
                   "far side); 'auto' = 'solid' when geometry.tibia_solid is given, else "
                   "'layer'.", choices=("auto", "solid", "layer")),
    "fe.cartilage": Key("str", "series", _FE + "the cartilage model: 'series' = one "
                        "deformable layer on the tibia with both cartilages' thickness in "
                        "series under a rigid femoral surface (the EF's own assumption); "
                        "'two-layer' = the femoral cartilage a deformable layer of its own, "
                        "extruded toward the femoral bone (its thickness the distance to "
                        "geometry.femur_bone with scanned.thickness = 'bone-distance', else "
                        "half of contact.thickness_mm, as the tibial one) and bonded there, "
                        "frictionless contact between the two layers, both of the contact "
                        "material (model.kind = 'femur-tibia' sheets that extrude as read).",
                        choices=("series", "two-layer")),
    "fe.solid_base_deg": Key("float", 45.0, _FE + "the fixed base of geometry.tibia_solid: "
                             "the boundary faces whose outward normal is within this angle of "
                             "-z (pointing away from the femur), all their nodes fixed; every "
                             "other non-articular face is free, deg.", low=0.0, high=89.0),
}
"""Every scene key (dotted) → its `Key`; the order is the order of the documents."""


def section_of(key: str) -> str:
    """The section of a dotted key: its first part, or "" for a top-level key."""
    head, dot, _ = key.partition(".")
    return head if dot else ""
