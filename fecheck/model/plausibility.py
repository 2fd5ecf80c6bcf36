"""Plausibility of a run: its inputs and meshes before the solve, its results after it.

Before the solve (`before_solve`) the scene's unit hints (`fecheck.scene.unit_hints`: a
material or load a unit slip explains is a warning, `ImplausibleInput`; one no slip
explains is a `FecheckError`) and the contact sheets' checks (`geometry.sheet_checks`:
extent, winding, folds) run on the assembled compartments, with the two that need the
model: the medial and lateral sheets on knee.side's sides, and the femoral surface within
`LANDMARK_GAP_MM` of the tibial sheet at the start pose (meshes far from their landmarks).
After it (`after_solve`), results that cannot be physical (NaN, a force without a contact
patch, p_max above `P_MAX_MPA`) are errors (`FecheckError`).
Units mm, N, MPa.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence

import numpy as np

from fecheck.contact.analytic import Sphere
from fecheck.contact.pair import ContactPair
from fecheck.errors import FecheckError, ImplausibleInput
from fecheck.laws.registry import law_spec, spec_of
from fecheck.model.assembly import Compartment, free_indices, start_pose
from fecheck.model.results import RunResult
from fecheck.scene import Scene
from fecheck.scene.knee import check_side
from fecheck.scene.unit_hints import (
    input_errors,
    input_warnings,
    load_hint,
    moduli,
    modulus_warning,
    tibia_weight_N,
)
from fecheck.statics.newton import pose
from geometry.distance import sphere_gap_mm, vertex_gap_mm
from geometry.mesh import TriMesh
from geometry.sheet_checks import check_extent, check_sheet, mean_x_mm

LANDMARK_GAP_MM = 20.0
"""The condyle sphere or femoral sheet must lie within this of the tibial sheet at the
start pose (start gap and free translations aside): farther, the landmarks (condyle
spheres, fits.json, knee.landmarks) or the meshes' transform do not match the meshes.
A 10 mm start gap (stress matrix) and the scanned scenes (touching) stay well below."""

MIN_CONTACT_FACES = 4
"""A contact spanning fewer faces has no resolved patch: its area and pressure are one
face's average (`fecheck.model.notes` notes contacts under 60 faces as coarse)."""

P_MAX_MPA = 1000.0
"""No knee tissue or bearing carries this: cortical bone fails at ~200 MPa, UHMWPE yields
at ~20-30 MPa, cartilage at ~25 MPa. A larger p_max is a unit mistake, never a result."""

EF_POISSON_MAX = law_spec("ef").poisson_max
"""Largest contact.poisson a `fecheck run` of the linear EF answers. The EF's column
stiffness grows as 1/(1 − 2ν) while a bonded layer's FE hardly stiffens (it bulges):
baseline medial (323.71 N, R 25.5 mm, E 20 MPa, h 6 mm), EF p_max 7.19 / 15.25 / 150.0 MPa
at ν 0.45 / 0.49 / 0.4999 against the converged axisymmetric mixed FE's 4.96 / 5.19 / 5.25
(× 1.45 / 2.94 / 28.6). The built-in FE calibration of the EF stops at 0.49 too."""
FORCE_RTOL = 1e-9
"""A compartment force below this times the load scale (N) counts as no force."""


def _warn(message: str) -> None:
    warnings.warn(message, ImplausibleInput, stacklevel=3)


# ----------------------------------------------------------------------------- meshes
def check_pose(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """The tibia's pose (R, t) where the landmarks are checked: the start pose without
    the start gap, free translations at 0 (the solve moves them)."""
    q = start_pose(scene)
    q[2] += scene["solver.start_gap_mm"]
    free = [i for i in free_indices(scene) if i < 3]
    q[free] = 0.0
    return pose(q, math.radians(scene["dofs.flexion_deg"]))


def master_distance_mm(points: np.ndarray, master) -> float | None:
    """Smallest distance (mm, ≥ 0) from slave points (world) to a sphere or a mesh master
    (its vertices: within an edge length of the surface); None for other masters."""
    if isinstance(master, Sphere):
        return sphere_gap_mm(points, master.center, master.radius)
    if hasattr(master, "distance_mm"):                  # a mesh master: its own tree
        return float(master.distance_mm(points).min())
    mesh = getattr(master, "mesh", master)
    if not isinstance(mesh, TriMesh):
        return None
    return vertex_gap_mm(points, mesh, LANDMARK_GAP_MM)


def check_landmarks(scene: Scene, comp: Compartment) -> None:
    """`FecheckError` when the femoral surface (condyle sphere or femoral sheet) lies
    farther than `LANDMARK_GAP_MM` from the tibial sheet at the start pose."""
    pair = comp.pair
    master = getattr(pair, "master", None)
    rot, t = check_pose(scene)
    gap = master_distance_mm(pair.slave.points @ rot.T + t, master)
    if gap is None or gap <= LANDMARK_GAP_MM:
        return
    what = ("condyle sphere" if isinstance(master, Sphere) else "femoral surface mesh")
    raise FecheckError(f"{comp.name}: the {what} is {gap:.1f} mm from the tibial sheet at "
                       f"the start pose (more than {LANDMARK_GAP_MM:g} mm): the landmarks "
                       "or transform do not match the meshes; check that the meshes, the "
                       "condyle spheres (fits.json, knee.landmarks) and the knee frame "
                       "share one frame and unit (mm)")


def check_sides(scene: Scene, comps: Sequence[Compartment]) -> None:
    """`FecheckError` when the medial and lateral tibial sheets lie on the sides opposite
    to knee.side's (one file per compartment: the side names no piece, so a wrong side
    would pass silently)."""
    x = {comp.name: mean_x_mm(comp.pair.slave) for comp in comps
         if comp.slave_is_tibia and isinstance(comp.pair, ContactPair)}
    if set(x) == {"medial", "lateral"}:
        check_side(scene.side, x["medial"], x["lateral"], "the medial tibial sheet is "
                   "centred", "swap the files geometry.tibia and geometry.tibia_lateral")


def check_meshes(scene: Scene, comps: Sequence[Compartment]) -> None:
    """Checks of every meshed contact pair before the solve: the tibial sheets' sides,
    extents, winding and folds, and the femoral surface's distance to them."""
    check_sides(scene, comps)
    seen: set[int] = set()                          # a shared femoral master: once
    for comp in comps:
        pair = comp.pair
        if not isinstance(pair, ContactPair):       # closed-form point contact, no mesh
            continue
        what = (f"{comp.name} tibial contact sheet" if comp.slave_is_tibia
                else f"{comp.name} femoral slave mesh")
        check_extent(pair.slave, what)
        master = getattr(pair.master, "mesh", pair.master)
        if isinstance(master, TriMesh) and id(master) not in seen:
            seen.add(id(master))
            check_extent(master, f"{comp.name} master mesh")
        if comp.slave_is_tibia:
            check_sheet(pair.slave, what)
            check_landmarks(scene, comp)


def before_solve(scene: Scene, comps: Sequence[Compartment] = ()) -> None:
    """Warn on implausible inputs; raise `FecheckError` on meshes that make the solve
    meaningless (see the module docstring)."""
    errors = input_errors(scene)
    if errors:
        raise FecheckError(errors[0])
    for message in input_warnings(scene):
        _warn(message)
    check_meshes(scene, comps)


def check_ef_poisson(scene: Scene) -> None:
    """`FecheckError` for a law above its `LawSpec.poisson_max` (the linear EF's 0.49,
    `EF_POISSON_MAX`): its pressures there are several times the FE's, growing without
    bound as ν → 0.5."""
    nu, limit = scene["contact.poisson"], spec_of(scene).poisson_max
    if limit is None or nu <= limit:
        return
    raise FecheckError(f"contact.poisson = {nu:g} with contact.law = '{spec_of(scene).name}': "
                       "its column stiffness grows as 1/(1 - 2ν) while a bonded layer hardly "
                       f"stiffens (it bulges), so past ν {limit:g} its p_max is more than 3 "
                       "times the FE's (baseline: 15 MPa at 0.49 and 150 MPa at 0.4999, FE 5.2 "
                       f"and 5.3): use contact.poisson <= {limit:g}, contact.law = "
                       "'ef-calibrated' (fitted to the FE up to ν 0.49), or `fecheck fe` for a "
                       "near-incompressible layer")


def _unit_cause(scene: Scene) -> str:
    found = [modulus_warning(e, key, top) for key, e, top in moduli(scene)]
    return "".join(f"; {w}" for w in found if w)


def check_compartment(scene: Scene, name: str, comp, force_floor_N: float) -> None:
    """`FecheckError` for a compartment result that cannot be physical; a warning for a
    contact spanning fewer than `MIN_CONTACT_FACES` faces."""
    values = {"force": comp.force_N, "max pressure": comp.max_pressure_MPa,
              "mean pressure": comp.mean_pressure_MPa, "contact area": comp.area_mm2,
              "max depth": comp.max_depth_mm, "torque": comp.torque_Nmm}
    bad = [k for k, v in values.items() if not math.isfinite(v)]
    if bad:
        raise FecheckError(f"{name}: the {', '.join(bad)} came out NaN or infinite, which "
                           "is not a physical result; check the meshes (degenerate faces, "
                           "`fecheck mesh info`) and the material" + _unit_cause(scene))
    if comp.force_N <= force_floor_N:
        return
    if comp.area_mm2 <= 0 or comp.max_pressure_MPa <= 0:
        raise FecheckError(f"{name}: {comp.force_N:.4g} N carried on a contact area of "
                           f"{comp.area_mm2:g} mm² at a max pressure of "
                           f"{comp.max_pressure_MPa:g} MPa: a force without a contact patch "
                           "is not physical; the contact is smaller than one face (refine "
                           "the mesh) or the material far too stiff" + _unit_cause(scene))
    if comp.max_pressure_MPa > P_MAX_MPA:
        raise FecheckError(f"{name}: max pressure {comp.max_pressure_MPa:.4g} MPa on "
                           f"{comp.area_mm2:.3g} mm², above the {P_MAX_MPA:g} MPa no knee "
                           "tissue or bearing carries (bone fails at ~200 MPa): not a "
                           "physical result" + (_unit_cause(scene) or "; check the units "
                                                "of load.force_N, contact.youngs_MPa and "
                                                "the meshes (mm)"))
    if 0 < comp.n_contact_faces < MIN_CONTACT_FACES:
        _warn(f"{name}: the contact spans only {comp.n_contact_faces} face(s) "
              f"({comp.area_mm2:.3g} mm²): its area and pressures are one face's average, "
              "not a resolved patch; refine the mesh, and check contact.youngs_MPa (Pa "
              "typed as MPa?) and the mesh units (metres?)")


def check_rigid(scene: Scene, result: RunResult) -> None:
    """The rigid model's ball forces: NaN is an error; a tensile (negative) force means
    the ball pulls on its plane, which is an error when the load does not lift the
    tibia's weight (`load_hint`) and a warning otherwise (the condyle lifts off, which
    linear rigid statics cannot represent)."""
    for name, comp in result.compartments.items():
        if not (math.isfinite(comp.force_N) and math.isfinite(comp.torque_Nmm)):
            raise FecheckError(f"{name}: the contact force came out NaN or infinite")
    pulling = {n: c.force_N for n, c in result.compartments.items() if c.force_N < 0}
    if not pulling:
        return
    where = ", ".join(f"{n} {f:.4g} N" for n, f in pulling.items())
    hint = load_hint(scene)
    if hint:
        raise FecheckError(f"tensile contact force ({where}): the balls would pull on the "
                           f"plateaus; {hint}")
    _warn(f"tensile contact force ({where}): the condyle lifts off its plateau, which "
          "rigid statics cannot represent; move the load point (load.point_mm) between "
          "the condyles")


def after_solve(scene: Scene, result: RunResult) -> None:
    """Check a solved run: non-physical compartment values raise `FecheckError` (never
    table entries); the rigid model has no pressures, areas or depths (NaN by design)."""
    if result.model == "rigid":
        check_rigid(scene, result)
        return
    floor = FORCE_RTOL * max(1.0, scene["load.force_N"], tibia_weight_N(scene))
    for name, comp in result.compartments.items():
        check_compartment(scene, name, comp, floor)
