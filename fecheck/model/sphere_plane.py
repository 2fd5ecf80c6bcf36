"""The sphere-plane model (thesis §5.2.1): condyle spheres on transverse, inclined or
polynomial plateaus, per compartment a contact pair and a law.

The Hertz law on plane plateaus with analytic detection uses the closed-form sphere-plane
point contact (`fecheck.contact.convex`, smooth in the pose); on polynomial plateaus,
with mesh detection or the thesis's whole-face counting it takes the deepest slave
vertex, which is not smooth (Newton may stall).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping

import numpy as np

from fecheck.contact.analytic import Sphere
from fecheck.contact.convex import SpherePlanePair
from fecheck.contact.pair import ContactPair
from fecheck.errors import FecheckError
from fecheck.laws.kernel import warm_up
from fecheck.laws.registry import spec_of
from fecheck.model.assembly import (
    Compartment,
    equal_force_constraint,
    law_factory,
    ligament_names,
    plateau_normals,
)
from fecheck.model.equilibrium import compartment_results, not_converged_note, solve_equilibrium
from fecheck.model.meshing import (
    condyle_mesh,
    plateau_box,
    plateau_master,
    plateau_mesh,
)
from fecheck.model.notes import (
    DEEPEST_VERTEX_NOTE,
    WHOLE_FACE_NOTE,
    layer_depth_notes,
    mesh_resolution_notes,
)
from fecheck.model.results import CompartmentResult, LigamentResult, Pose, RunResult, SolveRecord
from fecheck.model.reuse import reusable
from fecheck.reference.closed_forms import ef_sphere_plane
from fecheck.scene import Scene
from fecheck.scene.constants import COMPARTMENTS
from fecheck.scene.relevance import MESH_DETECTION, hertz_point_contact
from fecheck.statics.ligaments import rod_constraint, spring_wrench, transition_strain_check


def _hertz_point_compartments(scene: Scene) -> list[Compartment]:
    """Closed-form sphere (femur) on plane (tibia) pairs: smooth maximum depth. The
    plateau mesh only draws the pressure and is built on first use, never in the solve."""
    knee = scene.knee
    point_law = spec_of(scene).point(scene)
    out = []
    for c, n in plateau_normals(scene).items():
        centre, r = knee.condyle_center[c], knee.radius_mm(c)
        pair = SpherePlanePair(centre, r, centre - r * n, n,
                               mesh=lambda c=c: plateau_mesh(scene, knee, c))
        out.append(Compartment(c, pair, lambda s, r=r: point_law(s, r), True, r))
    return out


@reusable
def build_compartments(scene: Scene) -> list[Compartment]:
    """Contact pairs of the sphere-plane model (meshes built or read from the cache)."""
    if hertz_point_contact(scene):
        return _hertz_point_compartments(scene)
    if scene["contact.detection"] == "ray-parity" and scene["contact.master"] == "plateau":
        raise FecheckError(
            "contact.detection = 'ray-parity' (thesis Algorithm 3) takes the depth as the "
            "distance to the nearest master VERTEX; the plateau master is a box whose "
            "vertices lie ~20 mm from the contact, so that depth is meaningless here. Use "
            "contact.master = 'condyle' (the meshed condyle is then the master), or "
            "contact.detection = 'auto', 'bvh' or 'fcl'")
    knee = scene.knee
    law = law_factory(scene)
    note = "" if spec_of(scene).local else DEEPEST_VERTEX_NOTE
    out = []
    opts = {"method": scene["contact.detection"], "area": scene["contact.area"],
            "margin_mm": scene["contact.margin_mm"]}
    meshed = scene["contact.detection"] in MESH_DETECTION
    for c in COMPARTMENTS:
        centre, r = knee.condyle_center[c], knee.radius_mm(c)
        if scene["contact.master"] == "plateau":
            slave = condyle_mesh(scene, knee, c)
            master = plateau_box(scene, knee, c) if meshed else plateau_master(scene, knee, c)
            pair = ContactPair(slave, master, **opts)
            out.append(Compartment(c, pair, law(r, c), False, r, note=note))
        else:
            slave = plateau_mesh(scene, knee, c)
            master = condyle_mesh(scene, knee, c) if meshed else Sphere(centre, r)
            pair = ContactPair(slave, master, **opts)
            out.append(Compartment(c, pair, law(r, c), True, r, note=note))
    return out


def ligament_parts(scene: Scene) -> tuple[list, list]:
    """The three ligaments as springs (wrench parts) or rods (constraints), as the scene's
    ``ligaments.model`` asks; ([], []) without ligaments."""
    knee = scene.knee
    names = ligament_names(scene)
    if scene["ligaments.model"] == "spring":
        transition_strain_check(scene["ligaments.transition_strain"])
        return [spring_wrench(knee.femur_attachment[n], knee.tibia_attachment[n],
                              knee.ligament_length_mm(n), scene[f"ligaments.{n}.stiffness_N"],
                              scene[f"ligaments.{n}.reference_strain"],
                              scene["ligaments.transition_strain"]) for n in names], []
    if scene["ligaments.model"] == "rod":
        return [], [rod_constraint(knee.femur_attachment[n], knee.tibia_attachment[n],
                                   knee.ligament_length_mm(n)) for n in names]
    return [], []


def run_contact_model(scene: Scene, warm_start: np.ndarray | None = None) -> RunResult:
    """Sphere-plane models: Newton statics with contact laws (thesis §5.2.1)."""
    t_start = time.perf_counter()
    knee = scene.knee
    comps = build_compartments(scene)
    warm_up()                        # the compiled law kernel loads in the build, not the solve
    t_built = time.perf_counter()
    lig_names = ligament_names(scene)
    springs, constraints = ligament_parts(scene)
    if scene["constraints.equal_forces"]:
        constraints.append(equal_force_constraint)
    eq = solve_equilibrium(scene, comps, springs, constraints, warm_start)
    sol, rot, t = eq.solution, eq.rot, eq.t
    compartments = compartment_results(comps, eq)
    ligaments = {}
    for i, n in enumerate(lig_names):
        x = rot @ knee.tibia_attachment[n] + t
        length = float(np.linalg.norm(knee.femur_attachment[n] - x))
        if springs:
            force = springs[i].tension(length)
        else:
            force = float(sol.multipliers[i])
        ligaments[n] = LigamentResult(force, length)
    notes = []
    if scene["contact.area"] == "whole-face":
        notes.append(WHOLE_FACE_NOTE)
    notes += not_converged_note(sol)
    notes += (layer_depth_notes(scene, compartments)
              + mesh_resolution_notes(scene, comps, eq.results))
    spec = spec_of(scene)
    if spec.depth_notes is not None:
        notes += spec.depth_notes(scene, {c: r.max_depth_mm for c, r in compartments.items()})
    contact = eq.contact
    record = SolveRecord(contact.evaluations, {c.name: c.pair.slave.n_faces for c in comps},
                         {c.name: c.describe() for c in comps}, tuple(sol.history),
                         float(sol.multipliers[-1]) if scene["constraints.equal_forces"]
                         else None)
    timing = {"total": time.perf_counter() - t_start, "build": t_built - t_start,
              "solve": eq.seconds, "contact": contact.contact_seconds,
              "per_evaluation": contact.contact_seconds / max(contact.evaluations, 1),
              "per_evaluation_s": contact.contact_seconds / max(contact.evaluations, 1)}
    return RunResult(scene.label, scene["model.kind"], scene["contact.law"],
                     sol.converged, sol.iterations, sol.residual_norm,
                     Pose.of(eq.q, math.radians(scene["dofs.flexion_deg"]), side=scene.side),
                     compartments, ligaments, timing, exact_reference(scene, compartments),
                     tuple(notes), record)


def exact_reference(scene: Scene, compartments: Mapping[str, CompartmentResult]) -> dict:
    """Closed-form EF values at the solved compartment forces, with deviations (%)."""
    spec = spec_of(scene)
    if (scene["model.kind"] != "sphere-plane" or scene["plateau.kind"] == "polynomial"
            or not spec.linear):
        return {}
    k = spec.stiffness(scene)
    out = {}
    knee = scene.knee
    for c, res in compartments.items():
        if res.force_N <= 0:
            continue
        ref = ef_sphere_plane(res.force_N, knee.radius_mm(c), k)
        got = {"max_depth_mm": res.max_depth_mm, "area_mm2": res.area_mm2,
               "max_pressure_MPa": res.max_pressure_MPa,
               "mean_pressure_MPa": res.mean_pressure_MPa}
        ref["deviation_percent"] = {key: 100.0 * (got[key] - v) / v for key, v in ref.items()}
        out[c] = ref
    return out

