"""A rigid sphere pressed on a flat bonded layer through the general FE path: the
reference problem of the studies, the benchmark ladder and the stress matrix.

The same path as `fecheck fe` (extruded P2 layer, exact frictionless contact, one
factorization condensed onto the contact candidates) on a flat disc meshed by Gmsh:
`refine_size_mm` under the contact, ``size_mm`` away from it, the disc wide enough for
the contact. The mesh and the contact candidates are sized by the Hertz contact radius,
an upper bound for a layer bonded to rigid bone (the bone only stiffens it). Units: mm,
N, MPa.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

from fecheck.fe.bodies.indenter import SphereIndenter
from fecheck.fe.bodies.pose import FramePose
from fecheck.fe.bodies.scene_bodies import FEBody
from fecheck.fe.bodies.settings import FESettings
from fecheck.fe.pressure.recovery import contact_metrics, zero_contour_area
from fecheck.fe.pressure.results import FEContactResult
from fecheck.fe.solve.press import FELayer, build_layers, push_drive, rigid_gaps, solve_pressed
from fecheck.reference.closed_forms import hertz_sphere_on_plane

UP = np.array([0.0, 0.0, 1.0])
CANDIDATE_RADII = 1.3
"""Contact candidates: the top vertices within this many Hertz contact radii of the axis
(the solve widens them if a vertex outside penetrates)."""


def contact_radius_estimate(load_N: float, radius_mm: float, youngs_MPa: float,
                            poisson: float) -> float:
    """The Hertz contact radius at the load, mm: an upper bound for a bonded layer (it
    sizes the mesh and the candidates)."""
    return math.sqrt(hertz_sphere_on_plane(load_N, radius_mm, youngs_MPa, poisson).area_mm2
                     / math.pi)


def flat_layer(load_N: float, radius_mm: float, youngs_MPa: float, poisson: float,
               thickness_mm: float, *, refine_size_mm: float = 0.8, size_mm: float = 2.0,
               disc_radius_mm: float | None = None, layers: int = 2, grading: float = 1.6,
               solver: str = "cholmod", log: Callable[[str], None] | None = None,
               formulation: str = "auto") -> tuple[FELayer, FESettings]:
    """The assembled layer of `sphere_on_flat_layer` (same arguments) and its settings."""
    from geometry.plateau import plane_patch

    a = contact_radius_estimate(load_N, radius_mm, youngs_MPa, poisson)
    disc = disc_radius_mm or max(14.0, 3.0 * a + thickness_mm)
    surface = plane_patch((0.0, 0.0, 0.0), UP, radius=disc, size=max(size_mm, refine_size_mm),
                          refine_point=(0.0, 0.0, 0.0), refine_size=refine_size_mm,
                          refine_radius=min(disc, CANDIDATE_RADII * a + 2.0 * refine_size_mm))
    indenter = SphereIndenter(np.array([0.0, 0.0, radius_mm]), radius_mm)
    body = FEBody("layer", surface, np.full(surface.n_points, float(thickness_mm)), indenter,
                  "plane", indenter.describe(), "uniform")
    settings = FESettings(mode="compartment", layers=layers, grading=grading, solver=solver,
                          formulation=formulation)
    settings.check()
    layer = build_layers([body], youngs_MPa, poisson, settings, log or (lambda m: None))[0]
    return layer, settings


def candidate_margin(load_N: float, radius_mm: float, youngs_MPa: float,
                     poisson: float) -> float:
    """Rigid gap (mm) at `CANDIDATE_RADII` Hertz radii from the touch point."""
    rho = min(CANDIDATE_RADII * contact_radius_estimate(load_N, radius_mm, youngs_MPa,
                                                        poisson), radius_mm)
    return radius_mm - math.sqrt(radius_mm ** 2 - rho ** 2)


def sphere_on_flat_layer(load_N: float, radius_mm: float, youngs_MPa: float, poisson: float,
                         thickness_mm: float, *, refine_size_mm: float = 0.8,
                         size_mm: float = 2.0, disc_radius_mm: float | None = None,
                         layers: int = 2, grading: float = 1.6, solver: str = "cholmod",
                         log: Callable[[str], None] | None = None,
                         formulation: str = "auto") -> FEContactResult:
    """The sphere (radius_mm) pressed on the layer with `load_N`, touching it at the origin.

    `refine_size_mm` is the element size within `CANDIDATE_RADII` Hertz contact radii of
    the axis, plus two elements (and `size_mm` beyond); the disc radius defaults to 3
    contact radii plus the thickness (at least 14 mm); `layers` levels of elements
    through the thickness, each `grading` times thicker than the one above; `formulation`
    of the layer's elasticity as ``fe.formulation``. Returns the
    FE answer with its metrics (p_max, mean = load / area, zero-contour area,
    indentation depth, summed contact force).
    """
    say = log or (lambda message: None)
    t0 = time.perf_counter()
    layer, settings = flat_layer(load_N, radius_mm, youngs_MPa, poisson, thickness_mm,
                                 refine_size_mm=refine_size_mm, size_mm=size_mm,
                                 disc_radius_mm=disc_radius_mm, layers=layers,
                                 grading=grading, solver=solver, log=say,
                                 formulation=formulation)
    surface = layer.surface
    t1 = time.perf_counter()
    drive = push_drive(FramePose.identity("W", "T"), -load_N * UP)
    margin = candidate_margin(load_N, radius_mm, youngs_MPa, poisson)
    sol, condense, gaps, worst = solve_pressed([layer], drive, margin, settings, say)
    t2 = time.perf_counter()
    contact = sol.layers[0]
    pressure = contact.force_N / layer.solid.tributary_mm2
    area = zero_contour_area(surface.points, surface.faces, pressure, contact.active)
    rigid = rigid_gaps(layer, drive.pose(sol.q))
    metrics = contact_metrics(pressure, contact.force_N, area, float(sol.q[0]))
    inside = contact.active[surface.faces].all(axis=1)
    edges = np.linalg.norm(surface.points[surface.faces[inside][:, [1, 2, 0]]]
                           - surface.points[surface.faces[inside]], axis=2)
    return FEContactResult(
        metrics=metrics, points=surface.points, pressure_MPa=pressure, gap0_mm=rigid + sol.q[0],
        nodal_force_N=contact.force_N, gap_mm=gaps[0], active=contact.active,
        faces=surface.faces, n_dofs=layer.solid.n_dofs, n_elements=len(layer.solid.mesh.tets),
        element="tet P2 (extruded)",
        size_under_contact_mm=float(np.median(edges)) if edges.size else math.nan,
        iterations=sol.active_set_iterations,
        timing_s={"build": t1 - t0, "condense": condense, "contact": t2 - t1 - condense},
        max_penetration_mm=worst, node_area_mm2=float(layer.solid.tributary_mm2[contact.active]
                                                      .sum()))
