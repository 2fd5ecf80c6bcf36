"""Numerical-stability stress matrix: hard cases through the public entry points.

Each `Case` runs in its own process (forked from a clean forkserver) with a hard timeout,
so that a hang becomes ``timeout`` and a crash becomes ``exception`` instead of stopping
the matrix. Its outcome is one of

* ``converged`` — finite, converged and physically consistent: force balance (re-checked
  independently of the solver, with fresh contact pairs), no tensile pressure, every
  reported number finite, answer within `ACCURACY` of the closed-form reference where
  one exists, depth below the cartilage thickness;
* ``clear-error`` — a `FecheckError` whose message names the cause (a case marked
  ``expect="converged"`` that is refused is ``inconsistent``: wrong cause);

and anything else names the failure: ``diverged`` (not converged), ``nan`` (a non-finite
number reported), ``inconsistent`` (a check above failed, or a case that must be refused
was not), ``exception`` (a traceback, or the process died), ``timeout``.

Case kinds: ``scene`` (``--set`` overrides through `fecheck.scene.load_scene` and
`fecheck.model.run.run_scene`), ``pair`` (a slave mesh, possibly damaged, against a master
through `fecheck.contact.ContactPair` and the EF law, solved under load control) and
``fe`` (the scikit-fem layer solves of `fecheck.fe`). Units mm, N, MPa, s.
"""

from __future__ import annotations

import difflib
import math
import multiprocessing as mp
import os
import time
import traceback
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from fecheck.errors import FecheckError
from fecheck.laws.registry import spec_of
from fecheck.scene.provenance import provenance
from fecheck.statics.load_control import NotConverged
from fecheck.studies.pool import die_with, interrupts_held

OK_OUTCOMES = ("converged", "clear-error")
BALANCE_TOL = 1e-6      # relative to the load scale: the solver's tolerance is 1e-8
ACCURACY = 0.10         # relative error against a closed form above which an answer is wrong
PRESSURE_TOL = 1e-9     # MPa: a face pressure below minus this is tensile


@dataclass(frozen=True)
class Case:
    """One stress case: `kind` ("scene", "pair", "fe"), its parameters, whether it is in
    the quick matrix, and `expect`: "clear-error" for inputs that must be refused,
    "converged" for valid inputs with a known answer that must not be refused."""

    name: str
    kind: str
    params: dict = field(default_factory=dict)
    quick: bool = True
    expect: str | None = None


@dataclass(frozen=True)
class CaseResult:
    """Outcome of one case (see the module docstring); residual in N, time in s;
    `known_issue` explains a failing outcome already traced to its cause (`KNOWN`)."""

    name: str
    outcome: str
    message: str
    iterations: int | None
    residual: float | None
    time_s: float
    known_issue: str | None = None


class Inconsistent(Exception):
    """A result that came back but fails a physical or numerical check."""

    def __init__(self, outcome: str, message: str):
        super().__init__(message)
        self.outcome = outcome


# ------------------------------------------------------------------------ the matrix
COARSE_NOTE = "faces, so its area and pressures are coarse"
"""What `fecheck.model.notes.mesh_resolution_notes` says of a contact spanning few faces: a result
carrying it is flagged to the user, not silently inaccurate."""
KNOWN: dict[str, str] = {}
"""Failing outcomes traced to a cause in another module (case name → explanation)."""


def _scene(name: str, *overrides: str, quick: bool = True, expect: str | None = None) -> Case:
    return Case(name, "scene", {"overrides": list(overrides)}, quick, expect)


def _pair(name: str, quick: bool = True, expect: str | None = None, **params) -> Case:
    return Case(name, "pair", params, quick, expect)


def _fe(name: str, quick: bool = True, expect: str | None = None, **params) -> Case:
    return Case(name, "fe", params, quick, expect)


def cases() -> list[Case]:
    """The full matrix (`Case.quick` marks the CI subset)."""
    plateau = "contact.master=plateau"
    no_g = "gravity=false"
    out = [_scene("baseline")]
    out += [_scene(f"poisson {nu}", f"contact.poisson={nu}", quick=nu in (0.0, 0.4999))
            for nu in (0.0, 0.2, 0.45, 0.49, 0.499, 0.4999)]
    out += [_scene("poisson 0.5", "contact.poisson=0.5", expect="clear-error"),
            _scene("poisson -0.1", "contact.poisson=-0.1", quick=False, expect="clear-error")]
    out += [_scene(f"E {e:g} MPa", f"contact.youngs_MPa={e}", quick=e in (0.1, 1e4),
                   expect="clear-error" if e < 1 else None)     # 15 mm deep: crushed layer
            for e in (0.1, 1.0, 5.0, 100.0, 1000.0, 1e4)]
    out += [_scene(f"h {h:g} mm", f"contact.thickness_mm={h}", quick=h in (0.5, 20.0))
            for h in (0.5, 1.0, 3.0, 12.0, 20.0)]
    out += [_scene(f"load {f:g} N", f"load.force_N={f}", no_g, quick=f in (0.1, 1e4))
            for f in (0.1, 1.0, 10.0, 100.0, 2000.0, 1e4)]
    out += [_scene("load 0.1 N with the tibia's weight (no equilibrium)", "load.force_N=0.1",
                   expect="clear-error"),
            _scene("load 1e4 N, E 0.1 MPa, h 0.5 mm", "load.force_N=10000",
                   "contact.youngs_MPa=0.1", "contact.thickness_mm=0.5", quick=False,
                   expect="clear-error")]
    out += [_scene(f"load point x {x:+g} mm", f"load.point_mm=[{x}, 12.8, -380.0]",
                   quick=abs(x) == 30) for x in (-30.0, -15.0, 15.0, 30.0)]
    out += [_scene("start 10 mm gap", "solver.start_gap_mm=10"),
            _scene("start 10 mm gap, plateau master", "solver.start_gap_mm=10", plateau,
                   quick=False),
            _scene("start 5 mm overlap", "dofs.z_mm=5"),
            _scene("start 5 mm overlap, plateau master", "dofs.z_mm=5", plateau, quick=False),
            _scene("start 5 mm overlap tilted 10 deg", "dofs.z_mm=5", "dofs.abduction_deg=10",
                   quick=False)]
    out += [_scene(f"icosphere level {n} ({20 * 4 ** n} faces)", plateau,
                   f"mesh.sphere_subdivisions={n}", quick=n in (0, 5))
            for n in (0, 1, 2, 3, 5, 6, 7)]
    out += [_scene("whole-face area, level 2", plateau, "contact.area=whole-face",
                   "mesh.sphere_subdivisions=2", quick=False),
            _scene("plateau mesh 0.2 mm", "mesh.plateau_refine_mm=0.2", quick=False),
            _scene("plateau mesh 3 mm", "mesh.plateau_refine_mm=3", "mesh.plateau_size_mm=3",
                   quick=False)]
    out += [_scene(f"inclined {a:g} deg frontal", "plateau.kind=inclined",
                   f"plateau.medial_angles_deg=[0.0, {-a}]",
                   f"plateau.lateral_angles_deg=[0.0, {a}]", quick=a == 30)
            for a in (10.0, 20.0, 30.0)]
    out += [_scene("inclined 30 deg sagittal", "plateau.kind=inclined",
                   "plateau.medial_angles_deg=[30.0, 0.0]",
                   "plateau.lateral_angles_deg=[30.0, 0.0]"),
            _scene("inclined 30 deg, plateau master", "plateau.kind=inclined", plateau,
                   "plateau.medial_angles_deg=[0.0, -30.0]",
                   "plateau.lateral_angles_deg=[0.0, 30.0]", quick=False)]
    out += [_scene("grazing: 1e-6 N", "load.force_N=1e-6", no_g, expect="converged"),
            _scene("grazing: 1e-6 N, plateau master", "load.force_N=1e-6", no_g, plateau,
                   quick=False, expect="converged"),
            _scene("zero load without gravity", "load.force_N=0", no_g, quick=False,
                   expect="clear-error"),
            _scene("zero load with the tibia's weight", "load.force_N=0", quick=False,
                   expect="clear-error")]
    out += [_scene(f"detection {d}, plateau master", plateau, f"contact.detection={d}",
                   *(["contact.area=whole-face"] if d != "bvh" else []), quick=d == "bvh",
                   expect=None if d == "ray-parity" else "converged")
            for d in ("bvh", "fcl", "ray-parity")]
    out += [_scene(f"law {law}", f"contact.law={law}", quick=quick)
            for law, quick in (("hertz", False), ("volumetric", False), ("blankevoort", True))]
    cal = "contact.law=ef-calibrated"
    out += [_scene("law ef-calibrated (built-in table)", cal, expect="converged"),
            _scene("ef-calibrated, nu 0.49", cal, "contact.poisson=0.49", quick=False,
                   expect="converged"),
            _scene("ef-calibrated, soft layer E 1", cal, "contact.youngs_MPa=1", quick=False,
                   expect="converged"),
            _scene("ef-calibrated, h outside the table", cal, "contact.thickness_mm=30",
                   quick=False, expect="clear-error")]
    out += [_scene("blankevoort beyond 0.9 h", "contact.law=blankevoort",
                   "contact.youngs_MPa=1", quick=False),
            _scene("ligament rods", "ligaments.model=rod", "dofs.free=[\"x\", \"y\", \"z\", "
                   "\"abduction\", \"internal\"]", quick=False),
            _scene("ligament springs", "ligaments.model=spring", quick=False),
            _scene("rigid model", "model.kind=rigid")]
    out += [_scene("E nan", "contact.youngs_MPa=nan", expect="clear-error"),
            _scene("load inf", "load.force_N=inf", expect="clear-error"),
            _scene("load point nan", "load.point_mm=[nan, 0.0, 0.0]", expect="clear-error"),
            _scene("mass inf", "tibia.mass_kg=inf", quick=False, expect="clear-error"),
            _scene("E -20", "contact.youngs_MPa=-20", quick=False, expect="clear-error"),
            _scene("E 1e-6 MPa (no unit slip)", "contact.youngs_MPa=1e-6", quick=False,
                   expect="clear-error"),
            _scene("E 2e7 MPa (Pa typed as MPa)", "contact.youngs_MPa=2e7", quick=False,
                   expect="clear-error"),
            _scene("h 0", "contact.thickness_mm=0", quick=False, expect="clear-error"),
            _scene("load direction zero", "load.direction=[0.0, 0.0, 0.0]", quick=False,
                   expect="clear-error")]
    out += [_pair("mesh: clean level 4"),
            _pair("mesh: degenerate faces", defect="degenerate"),
            _pair("mesh: duplicate faces", defect="duplicate"),
            _pair("mesh: open (upper half removed)", defect="open"),
            _pair("mesh: inverted (faces flipped)", defect="inverted"),
            _pair("mesh: nan vertex", defect="nan", expect="clear-error"),
            _pair("mesh: no faces", defect="empty", expect="clear-error"),
            _pair("mesh: 20 faces", level=0, quick=False),
            _pair("mesh: 327,680 faces", level=7, quick=False),
            _pair("mesh master: closed sphere, BVH", master="sphere"),
            _pair("mesh master: open sphere, winding number", master="open-sphere",
                  sign="winding", quick=False),
            _pair("mesh master: open sphere, closest-face side", master="open-sphere",
                  quick=False),
            _pair("mesh master: inverted sphere", master="inverted-sphere"),
            _pair("pose nan", defect="nan-pose", expect="clear-error"),
            _pair("grazing pose: vertex exactly on the plane", defect="grazing")]
    out += [_fe("FE axisym baseline", model="axisym"),
            _fe("FE axisym nu 0.4999", model="axisym", nu=0.4999),
            _fe("FE axisym E 1e4 MPa, 1e4 N", model="axisym", E=1e4, load=1e4, quick=False),
            _fe("FE axisym h 0.5 mm", model="axisym", h=0.5, size=0.05, quick=False),
            _fe("FE axisym load nan", model="axisym", load=math.nan, expect="clear-error"),
            _fe("FE axisym nu 0.5", model="axisym", nu=0.5, expect="clear-error"),
            _fe("FE axisym contact larger than the layer", model="axisym", load=1e4, E=0.1,
                expect="clear-error"),
            _fe("FE 3D 5 mm", model="3d", size=5.0),
            _fe("FE 3D 2 mm, 2000 N", model="3d", load=2000.0, size=2.0, quick=False),
            _fe("FE 3D 5 mm nu 0.4999", model="3d", nu=0.4999, size=5.0, quick=False),
            _fe("FE 3D load nan", model="3d", load=math.nan, expect="clear-error"),
            _fe("FE 3D nu 0.5", model="3d", nu=0.5, expect="clear-error")]
    return out


# -------------------------------------------------------------------------- checks
def _finite(label: str, *values) -> None:
    for v in values:
        a = np.asarray(v, dtype=float)
        if not np.all(np.isfinite(a)):
            raise Inconsistent("nan", f"{label} is not finite: {a.ravel()[:4]}")


def check_run(scene, result) -> tuple[int, float, str]:
    """Checks of a `RunResult`; returns (iterations, residual N, message)."""
    if not result.converged:
        raise Inconsistent("diverged", f"not converged after {result.iterations} iterations, "
                           f"residual {result.residual_norm:.3g} N")
    _finite("residual", result.residual_norm)
    _finite("pose", list(result.pose.values()))
    rigid = result.model == "rigid"
    for name, c in result.compartments.items():
        _finite(f"{name} force/torque", c.force_N, c.torque_Nmm, c.torque_vector_Nmm)
        if rigid:
            continue
        _finite(f"{name} pressure/area/depth", c.max_pressure_MPa, c.mean_pressure_MPa,
                c.area_mm2, c.max_depth_mm, c.face_pressure_MPa)
        if c.face_pressure_MPa.min(initial=0.0) < -PRESSURE_TOL or c.max_pressure_MPa < 0:
            raise Inconsistent("inconsistent", f"{name}: tensile pressure "
                               f"{c.face_pressure_MPa.min():.3g} MPa")
        noted = any("thickness" in note for note in result.notes)
        if (spec_of(scene).beyond_thickness != "ignore" and not noted
                and c.max_depth_mm >= scene["contact.thickness_mm"]):
            raise Inconsistent("inconsistent", f"{name}: depth {c.max_depth_mm:.3g} mm exceeds "
                               f"the cartilage thickness {scene['contact.thickness_mm']:g} mm "
                               "(the foundation law does not hold) without an error or note")
    for lig in result.ligaments.values():
        _finite("ligament", lig.force_N, lig.length_mm)
    notes = []
    if not rigid:
        notes.append(_balance(scene, result))
        for name, ref in result.exact.items():
            dev = ref["deviation_percent"]
            worst = max(abs(dev["area_mm2"]), abs(dev["max_pressure_MPa"])) / 100.0
            coarse = any(n.startswith(f"{name}:") and COARSE_NOTE in n for n in result.notes)
            if scene["contact.area"] == "clipped" and worst > ACCURACY and not coarse:
                raise Inconsistent("inconsistent", f"{name}: area/p_max {100 * worst:.1f}% "
                                   "off the exact EF answer, without a warning")
            notes.append(f"{name} {100 * worst:.2g}% from exact")
    notes += [f"note: {n}" for n in result.notes if "thickness" in n or COARSE_NOTE in n]
    return result.iterations, float(result.residual_norm), "; ".join(notes)


def _balance(scene, result) -> str:
    """Re-evaluate contact and loads at the solved pose with FRESH pairs (no reused broad
    phase) and check the generalised forces of the free DOFs and the reported forces."""
    from fecheck.model.assembly import ContactModel, applied_load, force_scale, free_indices
    from fecheck.model.sphere_plane import build_compartments
    from fecheck.statics.newton import Problem, pose, twist_basis

    q = np.asarray(result.pose.q, dtype=float)
    theta_x = math.radians(scene["dofs.flexion_deg"])
    rot, t = pose(q, theta_x)
    contact = ContactModel(build_compartments(scene))
    walls = contact.wrenches(rot, t)
    wl, _ = applied_load(scene)(rot, t)
    w = sum(walls.values()) + wl
    knee = scene.knee
    for name, lig in result.ligaments.items():       # rods and springs: reported tension
        x = rot @ knee.tibia_attachment[name] + t
        u = knee.femur_attachment[name] - x
        f = lig.force_N * u / np.linalg.norm(u)
        w = w + np.concatenate([f, np.cross(x, f)])
    if scene["constraints.equal_forces"]:
        return "balance not re-checked (equal-force constraint multiplier)"
    free = list(free_indices(scene))
    gen = (twist_basis(q, theta_x).T @ w)[free]
    gen = gen / np.where(np.array(free) >= 3, Problem.length_scale_mm, 1.0)   # N·mm → N
    residual = float(np.linalg.norm(gen))
    scale = force_scale(scene)
    _finite("re-evaluated residual", residual)
    if residual > BALANCE_TOL * scale:
        raise Inconsistent("inconsistent", f"force balance fails when re-evaluated with "
                           f"fresh contact pairs: residual {residual:.3g} N "
                           f"(load scale {scale:.3g} N)")
    for name, c in result.compartments.items():
        f = walls[name][:3]
        if f[2] > PRESSURE_TOL * max(1.0, abs(f).max()):
            raise Inconsistent("inconsistent", f"{name}: contact pulls the tibia up "
                               f"(F_z = {f[2]:.3g} N)")
        if abs(np.linalg.norm(f) - c.force_N) > BALANCE_TOL * max(1.0, c.force_N):
            raise Inconsistent("inconsistent", f"{name}: reported force {c.force_N:.6g} N but "
                               f"{np.linalg.norm(f):.6g} N when re-evaluated")
    return f"re-evaluated balance {residual:.2g} N"


# ---------------------------------------------------------------------- case kinds
def run_scene_case(params: dict) -> tuple[int, float, str]:
    from fecheck.model.run import run_scene
    from fecheck.scene import load_scene

    scene = load_scene(overrides=params["overrides"])
    return check_run(scene, run_scene(scene))


def _damaged(mesh, defect: str | None):
    from geometry.mesh import TriMesh

    p, f = mesh.points, mesh.faces
    if defect == "degenerate":
        zero = np.column_stack([f[:, 0], f[:, 0], f[:, 1]])          # repeated vertex
        mid = np.vstack([p, 0.5 * (p[f[:, 0]] + p[f[:, 1]])])         # collinear triple
        line = np.column_stack([f[:, 0], f[:, 1], len(p) + np.arange(len(f))])
        return TriMesh(mid, np.vstack([f, zero, line]))
    if defect == "duplicate":
        return TriMesh(p, np.vstack([f, f]))
    if defect == "open":
        keep = p[f].mean(axis=1)[:, 2] < p[:, 2].mean()
        return TriMesh(p, f[keep])
    if defect == "inverted":
        return TriMesh(p, f[:, ::-1])
    if defect == "nan":
        bad = p.copy()
        bad[0, 0] = np.nan
        return TriMesh(bad, f)
    if defect == "empty":
        return TriMesh(p, np.zeros((0, 3), dtype=int))
    return mesh


def run_pair_case(params: dict) -> tuple[int, float, str]:
    """EF solve under load control of a (damaged) icosphere or plateau against a master."""
    from fecheck.contact import ContactPair, Plane
    from fecheck.laws import elastic_foundation
    from fecheck.reference.closed_forms import ef_sphere_plane
    from fecheck.statics.load_control import load_controlled
    from fecheck.studies.bench import BASELINE_COMPARTMENTS, baseline_ef_stiffness, ef_start_depth
    from geometry.icosphere import icosphere
    from geometry.plateau import plane_patch

    radius, force = BASELINE_COMPARTMENTS["medial"]
    k = baseline_ef_stiffness()
    defect, master = params.get("defect"), params.get("master")
    eye, zero = np.eye(3), np.zeros(3)
    if master is not None:
        sphere = icosphere(radius, params.get("level", 5), (0.0, 0.0, radius))
        keep = np.ones(sphere.n_faces, dtype=bool)
        if master == "open-sphere":
            keep = sphere.points[sphere.faces].mean(axis=1)[:, 2] < radius
        faces = sphere.faces[keep]
        if master == "inverted-sphere":
            faces = faces[:, ::-1]
        from geometry.mesh import TriMesh

        slave = plane_patch((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), radius=12.0, size=2.0,
                            refine_point=(0.0, 0.0, 0.0), refine_size=0.5, refine_radius=9.0)
        pair = ContactPair(slave, TriMesh(sphere.points, faces), method="bvh",
                           mesh_sign=params.get("sign", "normal"))
        direction = np.array([0.0, 0.0, 1.0])
    else:
        slave = _damaged(icosphere(radius, params.get("level", 4), (0.0, 0.0, radius)), defect)
        pair = ContactPair(slave, Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]))
        direction = np.array([0.0, 0.0, -1.0])
    if defect == "nan-pose":
        pair.evaluate((eye, np.array([np.nan, 0.0, 0.0])), (eye, zero))
    if defect == "grazing":
        for shift in (0.0, 1e-12, -1e-12):
            res = elastic_foundation(pair.evaluate((eye, shift * direction), (eye, zero)), k)
            _finite("grazing force/tangent", res.force, res.tangent, res.area)
            if np.linalg.norm(res.force) > 1e-6:
                raise Inconsistent("inconsistent", f"force {res.force} N at zero depth")
    res, _, it = load_controlled(pair, lambda s: elastic_foundation(s, k), direction,
                                     force, ef_start_depth(radius, force))
    _finite("force/tangent/pressure", res.force, res.tangent, res.pressure, res.max_pressure,
            res.area)
    if res.pressure.min(initial=0.0) < -PRESSURE_TOL:
        raise Inconsistent("inconsistent", f"tensile pressure {res.pressure.min():.3g} MPa")
    balance = abs(-float(res.force @ direction) - force)
    lateral = float(np.linalg.norm(res.force - (res.force @ direction) * direction))
    if balance > BALANCE_TOL * force or lateral > 1e-3 * force:
        raise Inconsistent("inconsistent", f"force {res.force} N does not balance {force} N "
                           "along the approach")
    ref = ef_sphere_plane(force, radius, k)
    err = max(abs(res.area / ref["area_mm2"] - 1),
              abs(res.max_pressure / ref["max_pressure_MPa"] - 1))
    if err > ACCURACY:
        raise Inconsistent("inconsistent", f"p_max {res.max_pressure:.3g} MPa, area "
                           f"{res.area:.4g} mm²: {100 * err:.0f}% off the exact EF answer "
                           f"({ref['max_pressure_MPa']:.3g} MPa, {ref['area_mm2']:.4g} mm²), "
                           "accepted without an error")
    return it, balance, f"{slave.n_faces} faces, {100 * err:.2g}% from exact EF"


def run_fe_case(params: dict) -> tuple[int, float, str]:
    """FE layer solve; checks Σλ = F, λ ≥ 0, finite pressure and no penetration."""
    load = params.get("load", 800.0)
    args = (load, 25.5, params.get("E", 20.0), params.get("nu", 0.3), params.get("h", 6.0))
    if params["model"] == "axisym":
        from fecheck.fe.reference.axisym import axisym_sphere_on_layer

        res = axisym_sphere_on_layer(*args, size_mm=params.get("size", 0.2))
    else:
        from fecheck.fe.reference.sphere_layer import sphere_on_flat_layer

        res = sphere_on_flat_layer(*args, refine_size_mm=params.get("size", 2.0))
    m = res.metrics
    _finite("FE metrics", m.max_pressure_MPa, m.area_mm2, m.depth_mm, m.force_N,
            res.pressure_MPa, res.nodal_force_N)
    balance = abs(res.nodal_force_N.sum() - load)
    if balance > BALANCE_TOL * load:
        raise Inconsistent("inconsistent", f"nodal contact forces sum to "
                           f"{res.nodal_force_N.sum():.6g} N, load {load:g} N")
    if res.nodal_force_N.min() < -BALANCE_TOL * load:
        raise Inconsistent("inconsistent", f"tensile nodal force {res.nodal_force_N.min():.3g} N")
    if res.max_penetration_mm > 1e-6 * max(1.0, m.depth_mm):
        raise Inconsistent("inconsistent", f"penetration {res.max_penetration_mm:.3g} mm")
    return res.iterations, balance, (f"p_max {m.max_pressure_MPa:.3g} MPa, area "
                                     f"{m.area_mm2:.4g} mm², {res.n_dofs} dofs")


RUNNERS = {"scene": run_scene_case, "pair": run_pair_case, "fe": run_fe_case}


# -------------------------------------------------------------------------- runner
def _where(err: BaseException) -> str:
    """file:line of the innermost frame of the traceback."""
    tb = traceback.extract_tb(err.__traceback__)
    return f"{tb[-1].filename}:{tb[-1].lineno}" if tb else "?"


def execute(case: Case, runner=None) -> dict:
    """Run one case in this process; never raises. Returns a dict without ``time_s``.
    `runner` (a function of the case's params) replaces ``RUNNERS[case.kind]``."""
    out = {"name": case.name, "iterations": None, "residual": None}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            with np.errstate(all="ignore"):
                run = RUNNERS[case.kind] if runner is None else runner
                it, residual, message = run(case.params)
            out.update(outcome="converged", message=message, iterations=it,
                       residual=residual)
        except NotConverged as err:
            out.update(outcome="diverged", message=str(err))
        except FecheckError as err:
            out.update(outcome="clear-error", message=str(err))
        except Inconsistent as err:
            out.update(outcome=err.outcome, message=str(err))
        except Exception as err:   # noqa: BLE001 - every other exception is the finding
            out.update(outcome="exception",
                       message=f"{type(err).__name__}: {err} at {_where(err)}")
    if case.expect == "clear-error" and out["outcome"] == "converged":
        out.update(outcome="inconsistent",
                   message="accepted an input that must be refused: " + out["message"])
    if case.expect == "converged" and out["outcome"] == "clear-error":
        out.update(outcome="inconsistent",
                   message="refused a valid input with a wrong cause: " + out["message"])
    notes = sorted({str(w.message) for w in caught})
    if notes:
        out["message"] += " [warning: " + "; ".join(notes) + "]"
    return out


def _child(case: Case, conn, runner, run: int) -> None:
    die_with(run)           # `run` started the fork server: the case ends with it (kill -9)
    conn.send(execute(case, runner))
    conn.close()


def _context():
    """Processes forked from a fresh server that has imported the light core modules: as
    cheap as a fork, but never a copy of a parent holding threads or locks (BLAS, OpenMP,
    Gmsh), which can deadlock a plain fork (seen under pytest)."""
    ctx = mp.get_context("forkserver")
    ctx.set_forkserver_preload(["fecheck.studies.stress", "fecheck.model.run", "fecheck.scene",
                                "fecheck.contact.pair", "scipy.sparse", "scipy.spatial"])
    return ctx


def run_case(case: Case, timeout_s: float, runner=None) -> CaseResult:
    """Run `case` in its own process, killed after `timeout_s` seconds. `runner` (a
    module-level function of the params) replaces ``RUNNERS[case.kind]``."""
    ctx = _context()
    recv, send = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child, args=(case, send, runner, os.getpid()), daemon=True)
    t0 = time.perf_counter()
    out = None
    try:
        with interrupts_held():        # a signal in the middle of a spawn waits until it ends
            proc.start()
            send.close()
        if recv.poll(timeout_s):
            try:
                out = recv.recv()
            except EOFError:
                out = None
    except KeyboardInterrupt:                   # Ctrl-C or SIGTERM: no case left running
        proc.kill()
        proc.join()
        recv.close()
        time.sleep(0.1)          # the fork server reaps the case before `stop_servers` ends it
        raise
    elapsed = time.perf_counter() - t0
    if out is None:
        if proc.is_alive():
            proc.kill()
            proc.join()
            out = {"name": case.name, "outcome": "timeout", "iterations": None,
                   "residual": None, "message": f"no result after {timeout_s:g} s; killed"}
        else:
            proc.join()
            out = {"name": case.name, "outcome": "exception", "iterations": None,
                   "residual": None,
                   "message": f"the process died (exit code {proc.exitcode})"}
    else:
        proc.join()
    recv.close()
    known = KNOWN.get(case.name) if out["outcome"] not in OK_OUTCOMES else None
    return CaseResult(time_s=elapsed, known_issue=known, **out)


class StressInterrupted(KeyboardInterrupt):
    """The matrix stopped by Ctrl-C (or SIGTERM turned into one): the finished cases.

    results : the cases that finished, in order;  total : how many cases were chosen
    """

    def __init__(self, results: list[CaseResult], total: int):
        super().__init__(f"stress matrix interrupted: {len(results)} of {total} cases run")
        self.results = results
        self.total = total


def stop_servers() -> None:
    """Stop the fork server of the case processes and multiprocessing's resource tracker,
    if they run, and wait for them to exit, so that no process of the matrix outlives the
    command (not even as a zombie where nothing reaps orphans)."""
    from multiprocessing import forkserver, resource_tracker

    for server in (forkserver._forkserver, resource_tracker._resource_tracker):
        stop = getattr(server, "_stop", None)            # CPython ≥ 3.8
        if stop is not None:
            stop()


def choose(quick: bool = False, select: str | None = None) -> list[Case]:
    """The cases of the (quick) matrix whose name contains `select` (all for None);
    `FecheckError` naming the cases when none does."""
    every = cases()
    chosen = [c for c in every if (c.quick or not quick)
              and (select is None or select in c.name)]
    if chosen:
        return chosen
    names = [c.name for c in every]
    full = [n for n in names if select in n]
    if full:
        raise FecheckError(f"no quick stress case matches {select!r}, but the full matrix "
                           f"has {len(full)} (e.g. {full[0]!r}): drop --quick")
    close = ([n for n in names if select.lower() in n.lower()]
             or difflib.get_close_matches(select, names, n=3, cutoff=0.6))
    hint = f"did you mean {close[0]!r}? " if close else ""
    starts = ", ".join(dict.fromkeys(n.split()[0].rstrip(":,") for n in names))
    raise FecheckError(f"no stress case matches {select!r} (--only TEXT runs the cases whose "
                       f"name contains TEXT, case-sensitive); {hint}case names begin with: "
                       f"{starts}")


def run_matrix(quick: bool = False, timeout_s: float = 120.0, select: str | None = None,
               log=lambda r: None) -> list[CaseResult]:
    """Run the (quick) matrix, or the cases whose name contains `select` (`choose`). An
    interrupt kills the running case and raises `StressInterrupted` with the finished
    ones."""
    chosen = choose(quick, select)
    results = []
    try:
        for case in chosen:
            result = run_case(case, timeout_s)
            results.append(result)
            log(result)
    except KeyboardInterrupt:
        raise StressInterrupted(results, len(chosen)) from None
    finally:
        stop_servers()
    return results


def row(r: CaseResult) -> str:
    """One table line of a case result."""
    it = "-" if r.iterations is None else str(r.iterations)
    res = "-" if r.residual is None else f"{r.residual:.2g}"
    known = f" [known issue: {r.known_issue}]" if r.known_issue else ""
    return (f"{r.name[:48]:48s} {r.outcome:13s} {it:>5s} {res:>9s} {r.time_s:7.2f}  "
            f"{r.message}{known}")


HEADER = f"{'case':48s} {'outcome':13s} {'iter':>5s} {'residual':>9s} {'time s':>7s}  message"


def summary(results: list[CaseResult]) -> dict[str, int]:
    """Counts per outcome, and ``unexplained``: failing outcomes without a known issue."""
    counts: dict[str, int] = {}
    for r in results:
        counts[r.outcome] = counts.get(r.outcome, 0) + 1
    counts["unexplained"] = len(unexplained(results))
    return counts


def unexplained(results: list[CaseResult]) -> list[CaseResult]:
    """Cases that neither converged nor stopped with a clear error, and are not known."""
    return [r for r in results if r.outcome not in OK_OUTCOMES and r.known_issue is None]


def write_json(results: list[CaseResult], path: str | Path) -> None:
    """{"cases": [...], "summary": {outcome: count}} (NaN residuals written as null),
    written atomically (``-``: standard output)."""
    import json

    from fecheck.io.outputs import write_text

    def clean(d: dict) -> dict:
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                for k, v in d.items()}

    doc = {"cases": [clean(asdict(r)) for r in results], "summary": summary(results),
           "provenance": provenance()}
    write_text(path, json.dumps(doc, indent=2) + "\n")
