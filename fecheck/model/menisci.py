"""The scanned knee with menisci (issue 28): tibia and both menisci as rigid bodies.

``menisci.dir`` (a folder, or ``"fecheck:knee/smith2019_menisci"``) adds the menisci of the
smith2019 model (OpenSim-JAM; Smith, Brandon & Thelen 2019, J. Biomech. 82:124-133) to a
femur-tibia scene. Bodies of the block Newton (`fecheck.statics.newton`): the femur (fixed,
the world frame), the tibia (the scene's free DOFs) and each meniscus (menisci.free: all six
coordinates by default). Contact, each an EF interface (`fecheck.statics.interfaces.Interface`) per
compartment:

* femoral ↔ tibial cartilage: the femur-tibia scene's own pairs and laws;
* femoral cartilage ↔ meniscus, and meniscus ↔ tibial cartilage: the cartilage sheet is the
  slave and the meniscus's closed volume surface the master. The volume's top and bottom
  are the meniscus's superior and inferior articular surfaces (within 0.22 mm, the data
  set's README); a closed master has an inside everywhere, whereas an open articular
  surface as the master, or the cartilage sheet as the master of the meniscus surface,
  gives the depth's side-of-normal sign jumps behind the sheet's rim
  (`fecheck.contact.mesh_master`), which a meniscus reaching past the cartilage's edge
  (43-76 mm² of each) turns into force jumps that stall Newton. Inside or outside the
  volume is its generalised winding number, with the tree's closest face: the side of the
  closest face's normal put femoral cartilage points outside the medial meniscus's
  anterior rim up to 7.3 mm inside it (25 N of spurious force at the 800 N pose), and a
  closest-face walk from the last call can stop at a local closest face of the thin
  rim; either made the contact wrench depend on the calls before, not on the pose alone,
  and stalled the line search (200 and 2000 N and a 120 MPa meniscus did not converge,
  800 N took 24 iterations; now 9-13 iterations from 200 to 2000 N and 1 to 120 MPa).

A meniscus interface uses the linear EF of the law registry (contact.law = "ef") with the
meniscus layer (menisci.youngs_MPa, menisci.poisson, menisci.thickness_mm: smith2019's
1 MPa, 0.45, 3 mm) and one cartilage layer (the contact material over half of
contact.thickness_mm, which holds both layers) combined as menisci.layers says:
"lumped" (smith2019's use_lumped_contact_model, Bei & Fregly 2003, as OpenSim-JAM's
Smith2018ArticularContactForce computes it): one layer of the mean modulus and mean
Poisson's ratio over the summed thickness, k = (1−ν̄)Ē/((1+ν̄)(1−2ν̄)(h_m + h_c)); the
smith2019 meniscus modulus (1 MPa) belongs to this convention. "series": the two layers as
springs in series, 1/k = 1/k_meniscus + 1/k_cartilage (softer: 1.11 against 3.18 N/mm³
with the packaged scene's values).
The 15 meniscal ligaments of ``meniscal_ligaments.json`` (coronary, horn roots, transverse)
are Blankevoort 1991 springs between tibia and meniscus (the transverse one between the two
menisci). The femur sits at smith2019's default knee pose, the matrix G of the data set's
menisci.json: the tibia and the menisci start at G⁻¹ composed with the scene's dofs.* start
pose, where the menisci just touch the femur and the cartilages are 2.3 mm apart. The
menisci carry no weight (about 1 g each).

Result (`MenisciResult`, in `RunResult.menisci`): per compartment the axial load into the
tibia through the meniscus and through cartilage-cartilage contact and the meniscal share of
their sum, each body's pose, and each body's balance on its free coordinates.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from fecheck.contact.pair import ContactPair
from fecheck.errors import FecheckError
from fecheck.laws.fused import linear_law
from fecheck.laws.materials import ef_stiffness
from fecheck.laws.registry import spec_of
from fecheck.model.assembly import applied_load, force_scale, free_indices, start_pose
from fecheck.model.equilibrium import axial_force, compartment_result, not_converged_note
from fecheck.model.knee_surfaces import femoral_master, tibial_slaves
from fecheck.model.plausibility import before_solve
from fecheck.model.results import Pose, RunResult, SolveRecord
from fecheck.scene import Scene
from fecheck.scene.constants import COMPARTMENTS
from fecheck.scene.packaged import PACKAGE_PREFIX, data_dir
from fecheck.scene.surfaces import read_surface
from fecheck.statics.frames import rot_y
from fecheck.statics.interfaces import Interface
from fecheck.statics.ligaments import BodySpring
from fecheck.statics.newton import (
    BODY_DOFS,
    TIBIA_COORDINATES,
    Body,
    Problem,
    body_basis,
    body_pose,
    on_body,
    solve,
    tibia_body,
)
from geometry.mesh import is_closed

FEMUR, TIBIA = 0, 1
"""Body indices: the femur (fixed, the world frame) and the tibia; the menisci follow."""
VOLUME = "smith2019_R_meniscus_{side}.stl"
"""File name of a meniscus's closed volume surface."""


def menisci_dir(scene: Scene) -> Path:
    """The folder ``menisci.dir`` names (``fecheck:NAME``, or a path relative to the
    scene file's folder)."""
    given = scene["menisci.dir"]
    if given.startswith(PACKAGE_PREFIX):
        return data_dir(given, "menisci.dir")
    folder = Path(os.path.expandvars(given)).expanduser()
    if not folder.is_absolute():
        folder = (Path(scene.source).expanduser().resolve().parent / folder).resolve()
    if not folder.is_dir():
        raise FecheckError(f"{scene.source}: menisci.dir = {given!r}: no folder at {folder}; "
                           "give the smith2019_menisci folder or 'fecheck:knee/"
                           "smith2019_menisci'")
    return folder


def femur_pose(folder: Path) -> tuple[float, np.ndarray]:
    """(θy rad, t (3,) mm) of the matrix G of menisci.json, which moves the femur to
    smith2019's default pose: a rotation about y and a translation."""
    g = np.asarray(json.loads((folder / "menisci.json").read_text(encoding="utf-8"))[
        "transform_femur_lenhart2015_rest_to_smith2019_default"]["matrix"], dtype=float)
    theta = math.atan2(g[0, 2], g[0, 0])
    if np.abs(g[:3, :3] - rot_y(theta)).max() > 1e-9:
        raise FecheckError(f"{folder / 'menisci.json'}: the femur's pose G is not a rotation "
                           "about y; the menisci model composes only such a pose")
    return theta, g[:3, 3].copy()


def start_coordinates(scene: Scene, theta_g: float, t_g: np.ndarray) -> np.ndarray:
    """Body coordinates (6,) of the tibia (and of each meniscus on it) at the start: G⁻¹
    composed with the scene's start pose (the femur at G, the tibia at the scene's pose)."""
    q = start_pose(scene)
    t = rot_y(-theta_g) @ (q[:3] - t_g)
    return np.array([t[0], t[1], t[2], 0.0, q[3] - theta_g, q[4]])


def meniscus_stiffness(scene: Scene) -> float:
    """EF stiffness of a meniscus interface, N/mm³: the meniscus layer and one cartilage
    layer combined as menisci.layers says (module docstring)."""
    men = (scene["menisci.youngs_MPa"], scene["menisci.poisson"], scene["menisci.thickness_mm"])
    cart = (scene["contact.youngs_MPa"], scene["contact.poisson"],
            0.5 * scene["contact.thickness_mm"])
    if scene["menisci.layers"] == "lumped":
        return ef_stiffness(0.5 * (men[0] + cart[0]), 0.5 * (men[1] + cart[1]),
                            men[2] + cart[2])
    return 1.0 / (1.0 / ef_stiffness(*men) + 1.0 / ef_stiffness(*cart))


def meniscus_law(scene: Scene):
    """The registry's linear EF for a meniscus interface (`meniscus_stiffness`)."""
    if not spec_of(scene).linear:
        raise FecheckError(f"menisci.dir: the meniscus interfaces use the linear EF; set "
                           f"contact.law = 'ef' (got {scene['contact.law']!r})")
    return linear_law(meniscus_stiffness(scene))


def _sides(scene: Scene) -> tuple[str, ...]:
    sides = tuple(scene["menisci.sides"])
    unknown = [s for s in sides if s not in COMPARTMENTS]
    if unknown or len(set(sides)) < len(sides):
        raise FecheckError(f"menisci.sides = {list(sides)}: give each of 'medial', 'lateral' "
                           "at most once ([] = no meniscus, the menisci removed)")
    return tuple(s for s in COMPARTMENTS if s in sides)


def _springs(folder: Path, index: dict[str, int]) -> list[tuple[str, BodySpring]]:
    """The meniscal ligaments between bodies present (`index`: meniscus side → body)."""
    data = json.loads((folder / "meniscal_ligaments.json").read_text(encoding="utf-8"))
    bone = {"tibia": TIBIA, **{f"meniscus_{s}": b for s, b in index.items()}}
    out = []
    for item in data["ligaments"]:
        if not all(b in bone for b in item["points_bone"]):
            continue                                # on a removed meniscus
        p = item["parameters"]
        (a, b), (xa, xb) = item["points_bone"], item["points_mm"]
        out.append((item["name"], BodySpring(
            bone[a], np.asarray(xa, dtype=float), bone[b], np.asarray(xb, dtype=float),
            1000.0 * float(p["slack_length"]["value"]), float(p["linear_stiffness"]["value"]),
            float(p["transition_strain"]["value"]))))
    return out


def read_volume(folder: Path, side: str):
    """The closed volume surface of the `side` meniscus in `folder` (mm)."""
    path = folder / VOLUME.format(side=side)
    volume = read_surface(path)
    if not is_closed(volume):
        raise FecheckError(f"{path}: the {side} meniscus volume is not closed; the "
                           "menisci model needs the data set's watertight volume")
    return volume


def _interfaces(scene: Scene, folder: Path, comps, index: dict[str, int]) -> list[Interface]:
    """Cartilage-cartilage interfaces (one per compartment), then per meniscus its
    interfaces with the femoral and with the tibial cartilage: the cartilage sheet is the
    slave, the meniscus's closed volume the master (module docstring)."""

    out = [Interface(c.name, c.pair, c.law, TIBIA, FEMUR) for c in comps]
    law, femur, tibia = meniscus_law(scene), femoral_master(scene), tibial_slaves(scene)
    opts = {"method": scene["contact.detection"], "area": scene["contact.area"],
            "margin_mm": scene["contact.margin_mm"], "mesh_sign": "winding"}
    for side, body in index.items():
        volume = read_volume(folder, side)
        out.append(Interface(f"{side} femur-meniscus", ContactPair(femur, volume, **opts),
                             law, FEMUR, body))
        out.append(Interface(f"{side} meniscus-tibia",
                             ContactPair(tibia[side], volume, **opts), law, TIBIA, body))
    return out


def _check(scene: Scene) -> None:
    if scene["model.kind"] != "femur-tibia":
        raise FecheckError(f"menisci.dir needs model.kind = 'femur-tibia' (got "
                           f"{scene['model.kind']!r})")
    if scene["scanned.ligaments"] != "none" or scene["ligaments.model"] != "none":
        raise FecheckError("menisci.dir: ligaments other than the meniscal ones are not "
                           "modelled with the menisci yet; set scanned.ligaments = 'none' "
                           "and ligaments.model = 'none'")
    if scene["dofs.flexion_deg"] != 0.0 or scene["constraints.equal_forces"]:
        raise FecheckError("menisci.dir: the knee with menisci is modelled at full "
                           "extension without constraints; set dofs.flexion_deg = 0 and "
                           "constraints.equal_forces = false")


def balance(problem: Problem, q: Sequence[np.ndarray]) -> dict[str, float]:
    """{body: largest |generalised force| on its free coordinates (N; moments over
    `Problem.length_scale_mm`)} at coordinates `q`: zero at an equilibrium."""
    poses = [body_pose(qb) for qb in q]
    w = [np.zeros(6) for _ in q]
    for bodies, wp, _ in problem.wrench(poses):
        for i, b in enumerate(bodies):
            w[b] += wp[6 * i:6 * i + 6]
    out = {}
    for b, body in enumerate(problem.bodies):
        if body.free:
            gen = body_basis(q[b]).T @ w[b]
            scale = np.where(np.arange(6) >= 3, 1.0 / problem.length_scale_mm, 1.0)
            out[body.name] = float(np.abs((gen * scale)[list(body.free)]).max())
    return out


def build_problem(scene: Scene):
    """(problem, interfaces, springs {name: spring}, compartments, sides): the knee with
    the scene's menisci as a `Problem`."""
    from fecheck.model.scanned import build_compartments

    _check(scene)
    folder = menisci_dir(scene)
    sides = _sides(scene)
    theta_g, t_g = femur_pose(folder)
    comps = build_compartments(scene)
    before_solve(scene, comps)
    q0 = start_coordinates(scene, theta_g, t_g)
    index = {s: 2 + i for i, s in enumerate(sides)}
    free = tuple(i for i, d in enumerate(BODY_DOFS) if d in scene["menisci.free"])
    bodies = (Body("femur", np.zeros(6), ()),
              Body("tibia", q0, tibia_body(q0[list(TIBIA_COORDINATES)],
                                           free_indices(scene)).free),
              *(Body(f"{s} meniscus", q0.copy(), free, "menisci.free", "the tibia's start")
                for s in sides))
    interfaces = _interfaces(scene, folder, comps, index)
    springs = dict(_springs(folder, index))
    load = on_body(lambda r, t: [applied_load(scene)(r, t)], TIBIA)

    def wrench(poses):
        return ([i(poses) for i in interfaces] + [s(poses) for s in springs.values()]
                + load(poses))

    problem = Problem(bodies, wrench, (), force_scale(scene),
                      tolerance=scene["solver.tolerance"],
                      max_iterations=scene["solver.max_iterations"],
                      touching=lambda: any(i.max_depth_mm > 0 for i in interfaces))
    return problem, interfaces, springs, comps, sides


def footprint_outline(volume, rot: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(k, 2, 3) world segments (mm) of the edge of a closed meniscus volume's footprint
    at pose x = R p + t: the edges that bound its downward-facing faces (world n_z < 0),
    whose x-y projection covers the footprint; loops shorter than a tenth of the longest
    (small folds where a wall's faces turn over) are left out."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    pts = volume.points @ np.asarray(rot).T + t
    tri = pts[volume.faces]
    down = volume.faces[np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])[:, 2] < 0.0]
    edges = np.sort(np.concatenate([down[:, [0, 1]], down[:, [1, 2]], down[:, [2, 0]]]),
                    axis=1)
    unique, count = np.unique(edges, axis=0, return_counts=True)
    edge = unique[count == 1]
    n = len(pts)
    graph = coo_matrix((np.ones(len(edge)), (edge[:, 0], edge[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    length = np.linalg.norm(pts[edge[:, 0], :2] - pts[edge[:, 1], :2], axis=1)
    loop = np.bincount(label[edge[:, 0]], weights=length, minlength=n)
    return pts[edge[loop[label[edge[:, 0]]] >= 0.1 * loop.max()]]


def _maps(interfaces: Sequence[Interface], poses, volumes: dict) -> dict[str, dict]:
    """Per meniscus side (`volumes`: side → its closed volume): its pressure on the tibial
    faces, the edge of its footprint, and its contact area and peak pressure on the tibia
    (`RunResult.meniscus_maps`)."""
    by_name = {i.name: i for i in interfaces}
    out = {}
    for side, volume in volumes.items():
        down = by_name[f"{side} meniscus-tibia"]
        res = down.law(down.pair.evaluate(poses[down.slave], poses[down.master]))
        out[side] = {"pressure_MPa": res.face_pressure(), "area_mm2": float(res.area),
                     "max_pressure_MPa": float(res.max_pressure),
                     "outline": footprint_outline(volume, *poses[down.master])}
    return out


def _shares(interfaces: Sequence[Interface], poses, sides) -> dict[str, dict[str, float]]:
    """Per compartment: axial load into the tibia through cartilage and meniscus (N, +
    compressive), the meniscal share, the femur's load on the meniscus, the depths."""
    rot = poses[TIBIA][0]
    by_name = {i.name: i for i in interfaces}
    out = {}
    for c in COMPARTMENTS:
        cart = by_name[c]
        row = {"cartilage_N": axial_force(cart.wrench_on_slave(poses)[:3], rot),
               "cartilage_max_depth_mm": cart.max_depth_mm, "meniscus_N": 0.0,
               "femur_on_meniscus_N": 0.0}
        if c in sides:
            down, up = by_name[f"{c} meniscus-tibia"], by_name[f"{c} femur-meniscus"]
            row["meniscus_N"] = axial_force(down.wrench_on_slave(poses)[:3], rot)
            row["meniscus_tibia_max_depth_mm"] = down.max_depth_mm
            row["femur_on_meniscus_N"] = -axial_force(up.wrench_on_slave(poses)[:3], rot)
            row["femur_meniscus_max_depth_mm"] = up.max_depth_mm
        total = row["cartilage_N"] + row["meniscus_N"]
        row["meniscal_share"] = row["meniscus_N"] / total if total > 0 else math.nan
        out[c] = row
    return out


def run_menisci(scene: Scene, warm_start: np.ndarray | None = None) -> RunResult:
    """Solve a femur-tibia scene with its menisci (module docstring). `warm_start` is not
    taken (the menisci have their own coordinates)."""
    t_start = time.perf_counter()
    problem, interfaces, springs, comps, sides = build_problem(scene)
    t_built = time.perf_counter()
    sol = solve(problem)
    seconds = time.perf_counter() - t_built
    poses = [body_pose(q) for q in sol.q]
    rot, t = poses[TIBIA]
    compartments = {}
    for comp in comps:
        res, w, _ = comp.evaluate(rot, t)
        compartments[comp.name] = compartment_result(comp, res, w, rot, t)
    folder = menisci_dir(scene)
    maps = _maps(interfaces, poses, {s: read_volume(folder, s) for s in sides})
    shares = _shares(interfaces, poses, sides)
    for side, m in maps.items():
        shares[side]["meniscus_tibia_area_mm2"] = m["area_mm2"]
        shares[side]["meniscus_tibia_max_pressure_MPa"] = m["max_pressure_MPa"]
    menisci = {"compartments": shares,
               "balance_N": balance(problem, sol.q),
               "poses": {b.name: {"q": [float(v) for v in q]}
                         for b, q in zip(problem.bodies, sol.q, strict=True) if b.free},
               "ligaments_N": {n: s.tension(poses) for n, s in springs.items()}}
    q_tibia = sol.q[TIBIA][list(TIBIA_COORDINATES)]
    record = SolveRecord(0, {i.name: i.pair.slave.n_faces for i in interfaces},
                         {i.name: i.pair.describe() for i in interfaces}, tuple(sol.history))
    timing = {"total": time.perf_counter() - t_start, "build": t_built - t_start,
              "solve": seconds}
    return RunResult(scene["name"] or scene.source, scene["model.kind"], scene["contact.law"],
                     sol.converged, sol.iterations, sol.residual_norm, Pose.of(q_tibia),
                     compartments, {}, timing, {}, tuple(not_converged_note(sol)), record,
                     menisci, {s: {k: m[k] for k in ("pressure_MPa", "outline")}
                               for s, m in maps.items()})
