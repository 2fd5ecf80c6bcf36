"""Contact evaluation time of fecheck against Drake and OpenSim, measured in one process.

The problem: an icosphere slave (R = 25.5 mm, levels 3-6: 1,280 … 81,920 faces; quick:
levels 3 and 4) pressed d = 1 mm into the plane z = 0 (centre at z = R - d), the
foundation stiffness the same for all (k = `ef_stiffness` (5 MPa, ν 0.3, h 6 mm)
= 1.12 N/mm³), so that the contact forces (≈ kπd²(R - d/3) = 88.7 N) can be compared.
One evaluation at a pose, per method and mode:

* ``fecheck reused``: `fecheck_evaluator` — contact surface, force, moment and 6x6
  tangent of the EF law, the pose alternating between two poses 1e-4 mm apart (the
  surface is recomputed, the broad-phase candidate set reused).
* ``fecheck scratch``: the same with the candidate set rebuilt every call.
* ``drake query``: pydrake's SceneGraph, the icosphere a rigid hydroelastic mesh against
  a compliant hydroelastic half space (slab 10 mm, modulus k·slab so that p = k·d):
  the pose set through the source's FramePoseVector, then
  ``QueryObject.ComputeContactSurfaces(kTriangle)`` (surface and pressure field, no
  force integration). Drake works in SI: the mesh is written in metres.
* ``opensim ef``: an OpenSim Model, the icosphere a ContactMesh on a free body against a
  ContactHalfSpace on ground, an ElasticFoundationForce (stiffness k in N/m³, no
  dissipation or friction): the free joint's z set, then ``Model.realizeDynamics``.

Peers alternate between poses 1e-7 m apart, so their caches are invalidated too.
Every method is built and checked (non-empty contact, plausible area) before timing,
then warmed up; the methods then take turns, three runs of one block each (~0.2 s of
consecutive calls; quick ~0.05 s). Time per call is CPU time (`time.process_time_ns`)
of a block over its calls, in µs; a row is the median of the runs and their spread.
Peers are optional (``pip install -e '.[peers]'``): a peer that is not installed or
fails to set up is reported in ``skipped`` with the reason, and its rows are left out.
"""

from __future__ import annotations

import importlib.util
import itertools
import logging
import math
import statistics
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fecheck.laws import ef_stiffness
from fecheck.studies.bench import machine

RADIUS_MM = 25.5
DEPTH_MM = 1.0
LEVELS_FULL = (3, 4, 5, 6)               # 1,280 … 81,920 faces
LEVELS_QUICK = (3, 4)
STEP_MM = 1e-4                           # fecheck's two poses: within the candidate reuse
STEP_M = 1e-7                            # the peers' two poses
RUNS = 3
BLOCK_S, BLOCK_QUICK_S = 0.2, 0.05       # CPU time of one timed block
WARMUP_CALLS = 3
MM = 1e-3                                # m per mm
SLAB_M = 0.01                            # Drake's compliant half-space slab thickness
INSTALL = "pip install -e '.[peers]'"
PEER_MODULES = {"drake": "pydrake", "opensim": "opensim"}
RATIOS = {"reused_vs_drake_query": (("fecheck", "reused"), ("drake", "query")),
          "scratch_vs_drake_query": (("fecheck", "scratch"), ("drake", "query")),
          "reused_vs_opensim": (("fecheck", "reused"), ("opensim", "ef")),
          "scratch_vs_opensim": (("fecheck", "scratch"), ("opensim", "ef"))}
"""Ratio name → (fecheck method, mode), (peer method, mode): fecheck time / peer time."""


class PeerError(RuntimeError):
    """A peer library set up a contact that cannot be benchmarked (e.g. empty)."""


@dataclass(frozen=True)
class Case:
    """One method and mode at one face count.

    call : one evaluation, at the next of its two poses
    check : (normal force N, contact area mm² or None) at the first pose
    """

    method: str
    mode: str
    call: Callable[[], object]
    check: Callable[[], tuple[float, float | None]]


def stiffness() -> float:
    """The foundation stiffness of every method, N/mm³."""
    return ef_stiffness(5.0, 0.3, 6.0)


def _alternating(evaluate: Callable, poses: list) -> Callable[[], object]:
    """A call that evaluates `evaluate` at the next of `poses`, round and round."""
    cycle = itertools.cycle(poses)
    return lambda: evaluate(next(cycle))


def fecheck_evaluator(level: int, scratch: bool = False
                      ) -> Callable[[tuple], tuple[np.ndarray, np.ndarray]]:
    """fecheck's evaluation of the icosphere (level `level`, R 25.5 mm) on the plane z = 0,
    as the statics loop makes it (a compartment's `fecheck.laws.fused.HotPath`).

    The callable takes the slave pose (R (3, 3), t (3,) mm) and returns the wrench
    [force N, moment N·mm] (6,) and tangent (6, 6) of the EF law; `scratch` rebuilds the
    broad phase before every evaluation.
    """
    from fecheck.contact import ContactPair, Plane
    from fecheck.laws.fused import HotPath, linear_law
    from geometry.icosphere import icosphere

    pair = ContactPair(icosphere(RADIUS_MM, level), Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]))
    hot, master = HotPath(pair, linear_law(stiffness())), (np.eye(3), np.zeros(3))

    def evaluate(slave_pose: tuple) -> tuple[np.ndarray, np.ndarray]:
        if scratch:
            pair.cache.reset()
        w = hot.evaluate(slave_pose, master)
        return w.wrench, w.tangent

    return evaluate


def _fecheck_case(level: int, scratch: bool) -> Case:
    """fecheck (`fecheck_evaluator`) at poses 1e-4 mm apart; check: its z force, N."""
    evaluate = fecheck_evaluator(level, scratch)
    poses = [(np.eye(3), np.array([0.0, 0.0, RADIUS_MM - DEPTH_MM + dz]))
             for dz in (0.0, STEP_MM)]
    return Case("fecheck", "scratch" if scratch else "reused", _alternating(evaluate, poses),
                lambda: (float(evaluate(poses[0])[0][2]), None))


def _write_obj(mesh, path: Path, scale: float) -> str:
    """Write `mesh` (points × `scale`) as a Wavefront .obj; its path."""
    from geometry.io import save_mesh
    from geometry.mesh import TriMesh

    return str(save_mesh(TriMesh(mesh.points * scale, mesh.faces), path))


@contextmanager
def _drake_quiet() -> Iterator[None]:
    """Silence Drake's warning (on the first context) that half spaces take no part in
    deformable contact."""
    log = logging.getLogger("drake")
    level = log.level
    log.setLevel(logging.ERROR)
    try:
        yield
    finally:
        log.setLevel(level)


def _drake_contact(surfaces: list) -> tuple[float, float]:
    """|z force| (N, ∫ p |n_z| dA, pressure at the triangle centroids) and area (mm²)."""
    force = area = 0.0
    for s in surfaces:
        mesh, field = s.tri_mesh_W(), s.tri_e_MN()
        for f in range(mesh.num_triangles()):
            a = mesh.area(f)
            force += field.EvaluateCartesian(f, mesh.element_centroid(f)) * a * abs(
                mesh.face_normal(f)[2])
            area += a
    return force, area / MM**2


def _zone_area_mm2() -> float:
    """Sphere surface within DEPTH_MM of the plane, 2πRd (mm²)."""
    return 2 * math.pi * RADIUS_MM * DEPTH_MM


def _checked(case: Case) -> Case:
    """`case` after checking its contact: a force, and an area near 2πRd if it has one."""
    force, area = case.check()
    if not force > 0:
        raise PeerError(f"no contact force at d = {DEPTH_MM:g} mm")
    if area is not None and not 0.5 < area / _zone_area_mm2() < 1.5:
        raise PeerError(f"contact area {area:.1f} mm², expected ≈ {_zone_area_mm2():.0f}")
    return case


def _drake_case(mesh, folder: Path) -> Case:
    """Drake: rigid hydroelastic icosphere against a compliant hydroelastic half space."""
    from pydrake.geometry import (
        AddCompliantHydroelasticPropertiesForHalfSpace,
        AddRigidHydroelasticProperties,
        FramePoseVector,
        GeometryFrame,
        GeometryInstance,
        HalfSpace,
        HydroelasticContactRepresentation,
        Mesh,
        ProximityProperties,
        SceneGraph,
    )
    from pydrake.math import RigidTransform

    obj = _write_obj(mesh, folder / f"icosphere-{mesh.n_faces}-m.obj", MM)
    scene = SceneGraph()
    source = scene.RegisterSource("bench_peers")
    frame = scene.RegisterFrame(source, GeometryFrame("icosphere"))
    rigid, compliant = ProximityProperties(), ProximityProperties()
    AddRigidHydroelasticProperties(rigid)
    AddCompliantHydroelasticPropertiesForHalfSpace(SLAB_M, stiffness() * 1e9 * SLAB_M,
                                                   compliant)
    with _drake_quiet():
        sphere = scene.RegisterGeometry(source, frame, GeometryInstance(
            RigidTransform(), Mesh(obj), "icosphere"))
        scene.AssignRole(source, sphere, rigid)
        plane = scene.RegisterAnchoredGeometry(source, GeometryInstance(
            HalfSpace.MakePose([0.0, 0.0, 1.0], [0.0, 0.0, 0.0]), HalfSpace(), "plane"))
        scene.AssignRole(source, plane, compliant)
        context = scene.CreateDefaultContext()
    pose_port, query_port = scene.get_source_pose_port(source), scene.get_query_output_port()
    poses = []
    for dz in (0.0, STEP_M):
        pose = FramePoseVector()
        pose.set_value(frame, RigidTransform([0.0, 0.0, (RADIUS_MM - DEPTH_MM) * MM + dz]))
        poses.append(pose)

    def surfaces(pose) -> list:
        pose_port.FixValue(context, pose)
        return query_port.Eval(context).ComputeContactSurfaces(
            HydroelasticContactRepresentation.kTriangle)

    return _checked(Case("drake", "query", _alternating(surfaces, poses),
                         lambda: _drake_contact(surfaces(poses[0]))))


def _opensim_case(mesh, folder: Path) -> Case:
    """OpenSim: ElasticFoundationForce between a ContactMesh on a free body and ground's
    ContactHalfSpace (outward normal: its frame's -x, turned onto +z)."""
    import opensim as osim

    obj = _write_obj(mesh, folder / f"icosphere-{mesh.n_faces}-m.obj", MM)
    model = osim.Model()
    model.setGravity(osim.Vec3(0.0))
    body = osim.Body("icosphere", 1.0, osim.Vec3(0.0), osim.Inertia(1e-3, 1e-3, 1e-3))
    joint = osim.FreeJoint("free", model.getGround(), body)
    model.addBody(body)
    model.addJoint(joint)
    model.addContactGeometry(osim.ContactMesh(obj, osim.Vec3(0.0), osim.Vec3(0.0), body,
                                              "icosphere"))
    model.addContactGeometry(osim.ContactHalfSpace(
        osim.Vec3(0.0), osim.Vec3(0.0, math.pi / 2, 0.0), model.getGround(), "plane"))
    force = osim.ElasticFoundationForce()
    force.setName("ef")
    force.addGeometry("icosphere")
    force.addGeometry("plane")
    force.setStiffness(stiffness() * 1e9)          # N/mm³ → N/m³
    for setter in (force.setDissipation, force.setStaticFriction, force.setDynamicFriction,
                   force.setViscousFriction):
        setter(0.0)
    model.addForce(force)
    state = model.initSystem()
    z = joint.get_coordinates(5)                    # FreeJoint: rx, ry, rz, tx, ty, tz
    labels = force.getRecordLabels()
    fz = [labels.get(i) for i in range(labels.size())].index("ef.icosphere.force.Z")
    zs = [(RADIUS_MM - DEPTH_MM) * MM + dz for dz in (0.0, STEP_M)]

    def realize(z_m: float) -> None:
        z.setValue(state, z_m, False)
        model.realizeDynamics(state)

    def check() -> tuple[float, None]:
        realize(zs[0])
        return model.getForceSet().get("ef").getRecordValues(state).get(fz), None

    return _checked(Case("opensim", "ef", _alternating(realize, zs), check))


PEERS: dict[str, Callable[..., Case]] = {"drake": _drake_case, "opensim": _opensim_case}


def _missing(peer: str) -> str | None:
    """Why `peer` cannot run (not installed), or None."""
    if importlib.util.find_spec(PEER_MODULES[peer]) is None:
        return f"{peer} not installed: {INSTALL}"
    return None


def _cases(level: int, folder: Path, skipped: dict, progress: Callable[[str], None]
           ) -> list[Case]:
    """Every method at one level, built and checked; a peer that fails goes to `skipped`."""
    from geometry.icosphere import icosphere

    mesh = icosphere(RADIUS_MM, level)
    progress(f"{mesh.n_faces:,} faces: building fecheck")
    cases = [_fecheck_case(level, scratch) for scratch in (False, True)]
    for peer, build in PEERS.items():
        if peer in skipped:
            continue
        progress(f"{mesh.n_faces:,} faces: building {peer}")
        try:
            cases.append(build(mesh, folder))
        except Exception as err:            # a peer's failure is a result, not a crash
            skipped[peer] = (f"{peer} failed at {mesh.n_faces:,} faces: "
                             f"{type(err).__name__}: {err}")
    return cases


def _calls_per_block(call: Callable[[], object], block_s: float) -> int:
    """Warm `call` up (WARMUP_CALLS calls), then time it for a quarter block: the number
    of calls that last one block."""
    for _ in range(WARMUP_CALLS):
        call()
    calls, start = 0, time.process_time_ns()
    while calls == 0 or time.process_time_ns() - start < 0.25e9 * block_s:
        call()
        calls += 1
    per_call_ns = (time.process_time_ns() - start) / calls
    return max(1, round(1e9 * block_s / per_call_ns))


def _block_us(call: Callable[[], object], calls: int) -> float:
    """CPU time per call of `calls` consecutive calls, µs."""
    start = time.process_time_ns()
    for _ in range(calls):
        call()
    return (time.process_time_ns() - start) / calls / 1e3


def _timed(cases: list[Case], faces: int, block_s: float) -> tuple[list[dict], list[dict]]:
    """Rows (median and spread of RUNS interleaved blocks) and contact checks of `cases`."""
    calls = [_calls_per_block(c.call, block_s) for c in cases]
    runs: list[list[float]] = [[] for _ in cases]
    for _ in range(RUNS):
        for case, n, times in zip(cases, calls, runs, strict=True):
            times.append(_block_us(case.call, n))
    rows, checks = [], []
    for case, times in zip(cases, runs, strict=True):
        key = {"method": case.method, "faces": faces, "mode": case.mode}
        rows.append(key | {"us": statistics.median(times), "us_min": min(times),
                           "us_max": max(times)})
        force, area = case.check()
        checks.append(key | {"force_N": float(force),
                             "area_mm2": None if area is None else float(area)})
    return rows, checks


def ratios(rows: list[dict]) -> dict:
    """fecheck time / peer time per face count (keys: faces as text) for every RATIOS entry."""
    us = {(r["method"], r["mode"], r["faces"]): r["us"] for r in rows}
    out = {}
    for name, ((ours, our_mode), (peer, peer_mode)) in RATIOS.items():
        out[name] = {str(faces): t / us[(peer, peer_mode, faces)]
                     for (m, mode, faces), t in us.items() if (m, mode) == (ours, our_mode)
                     and (peer, peer_mode, faces) in us}
    return out


def run(quick: bool = False, progress: Callable[[str], None] = lambda message: None) -> dict:
    """The benchmark: {"rows", "ratios", "skipped", "checks", "machine"} (JSON-ready).

    rows : method, faces, mode, us (median µs per evaluation), us_min, us_max
    ratios : see `ratios`;  skipped : peer → reason
    checks : method, faces, mode, force_N (normal force at d = 1 mm), area_mm2 (contact
        area where the method reports one, else None)
    """
    block_s = BLOCK_QUICK_S if quick else BLOCK_S
    skipped = {peer: why for peer in PEERS if (why := _missing(peer))}
    rows, checks = [], []
    with tempfile.TemporaryDirectory(prefix="fecheck-peers-") as folder:
        for level in LEVELS_QUICK if quick else LEVELS_FULL:
            cases = _cases(level, Path(folder), skipped, progress)
            faces = 20 * 4**level
            progress(f"{faces:,} faces: timing {', '.join(f'{c.method} {c.mode}' for c in cases)}")
            level_rows, level_checks = _timed(cases, faces, block_s)
            rows += level_rows
            checks += level_checks
    rows = [r for r in rows if r["method"] not in skipped]   # a peer failing late: all out
    checks = [c for c in checks if c["method"] not in skipped]
    return {"rows": rows, "ratios": ratios(rows), "skipped": skipped, "checks": checks,
            "machine": machine()}


def _cell(row: dict) -> str:
    def us(x: float) -> str:
        return f"{x:.0f}" if x >= 100 else f"{x:.1f}"

    return f"{us(row['us'])} [{us(row['us_min'])}-{us(row['us_max'])}]"


def table(result: dict) -> str:
    """Rows as a method × faces table (µs), then ratios, contact checks and skipped peers."""
    faces = sorted({r["faces"] for r in result["rows"]})
    width = 20
    lines = [f"{'method':9s}{'mode':8s}" + "".join(f"{n:>{width},d}" for n in faces)
             + "   (µs per evaluation, median over 3 runs [min-max])"]
    cells = {(r["method"], r["mode"], r["faces"]): _cell(r) for r in result["rows"]}
    for method, mode in dict.fromkeys((r["method"], r["mode"]) for r in result["rows"]):
        lines.append(f"{method:9s}{mode:8s}" + "".join(
            f"{cells.get((method, mode, n), '-'):>{width}s}" for n in faces))
    lines.append("ratios, fecheck time / peer time (< 1: fecheck faster):")
    for name, by_faces in result["ratios"].items():
        text = "  ".join(f"{int(n):,} {v:.3g}" for n, v in by_faces.items()) or "-"
        lines.append(f"  {name:24s} {text}")
    k = stiffness()
    exact = k * math.pi * DEPTH_MM**2 * (RADIUS_MM - DEPTH_MM / 3)
    lines.append(f"contact at d = {DEPTH_MM:g} mm: force N (exact EF {exact:.1f}), "
                 f"area mm² (Drake's zone, 2πRd = {_zone_area_mm2():.1f}):")
    for c in result["checks"]:
        area = "" if c["area_mm2"] is None else f"  area {c['area_mm2']:.1f}"
        lines.append(f"  {c['method']:9s}{c['mode']:8s}{c['faces']:>8,d}  "
                     f"force {c['force_N']:.2f}{area}")
    lines += [f"skipped {peer}: {why}" for peer, why in result["skipped"].items()]
    m = result["machine"]
    lines.append(f"machine: {m['platform']}, {m['cpus']} cpus, python {m['python']}")
    return "\n".join(lines)
