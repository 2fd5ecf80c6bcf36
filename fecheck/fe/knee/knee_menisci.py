"""The FE of the knee with menisci at the EF equilibrium.

From the EF equilibrium of a ``menisci.dir`` scene (`fecheck.model.menisci`, e.g.
``femur_tibia_menisci`` at 800 N), in the tibia frame of that equilibrium:

* **Tibial cartilage**: each compartment's bonded layer as `fecheck fe` builds it
  (`fecheck.fe.solve.press.build_layers` on the scene's bodies, ``fe.*`` keys, the contact
  material): with ``fe.cartilage = "series"`` its thickness holds the femoral cartilage
  too, under the femoral condyle; over the menisci the femoral cartilage is then rigid.
  With ``"two-layer"`` it is the tibial cartilage alone, and the femoral cartilage is a
  layer of its own (`fecheck.fe.knee.femoral.femoral_layer`: the femoral sheet within
  `fecheck.fe.knee.femoral.CROP_MM` of the points where the femur pairs' candidate rays meet
  it, extruded toward the femoral bone by its thickness and bonded there, the femoral
  material), carried by the femur (`fecheck.fe.contact.condense.ElasticBody.carried`): the master of
  the femur-tibia and femur-meniscus pairs, hit where each slave's ray meets it, paired
  afresh where those rays have moved while a vertex still penetrates (`REPAIR_WEIGHT`).
  Where a later candidate's ray meets the femoral sheet outside the layer, the layer is
  rebuilt over those points too before the next condensation (`_grown_femoral`): the
  femur's contact is deformable wherever it reaches. A candidate whose ray meets no
  femoral cartilage at all (`OFF_SHEET`) has an infinite gap, as with the rigid femur,
  and is left out of the femur pairs while that holds.
* **Menisci**: each a deformable solid (`fecheck.fe.bodies.meniscus_solid`, P2 tetrahedra,
  `fecheck.fe.material.anisotropy.MENISCUS`, fibres along the arc) at its EF pose, raised along
  the tibial axis until it just touches the tibial layer (the EF's meniscus layer is
  soft, so the EF pose overlaps the tibial sheet; the rise is reported). Each horn's
  attachment nodes are on isotropic linear springs to the tibia, the horn's stiffness
  spread evenly over its nodes: ``root = "data"`` the sum of its root bundles' k / l0
  (smith2019's AHORN / PHORN, 6-13 N/mm each), ``"donahue"`` `DONAHUE_HORN_N_PER_MM`
  per horn; the springs are unstretched at that placement (the EF ligaments' tension
  there is not carried over). The transverse ligament is left out; the coronary ones
  (smith2019's COR bundles, 5-6 N/mm each) only with ``coronary=True``, each on the node
  nearest its meniscal point. ``lift_mm`` raises the superior surface along its normals
  (the wedge made that much thicker): the sensitivity to the placement.
* **Femur**: the rigid femoral surface, its translation along the tibia's free axis
  (world z) solved under the EF's axial load on the tibia (the load less the tibia's
  weight, along z), and turned about the tibia's origin along each rotation the scene
  leaves free to the tibia (``dofs.free``: abduction for ``femur_tibia_menisci``) under
  the moment the load and the weight put on the tibia there at the EF pose, reversed
  (`femur_turns`): the femur balances in force and moment on the tibia's free DOFs, as the
  EF's tibia does. ``hold_rotation=True`` keeps it at the EF's rotation (for comparison).

Frictionless contact on three interfaces, node to surface with exact complementarity
(`fecheck.fe.solve.multibody`): femur (its surface, or its cartilage layer) ↔ tibial layer
vertices (along their normals), femur ↔ meniscus superior vertices, meniscus inferior
faces ↔ tibial layer vertices (a tibial vertex under a meniscus meets its inferior face,
the others the femur). Small displacements; the rigid gaps are re-evaluated at the femur's
new place and turn until it stops moving (1e-10 mm at its farthest contact vertex), so
they are exact at the answer (the contact moments act at the slave vertices). Per
compartment: axial load into the tibia through the meniscus (its contact and its horn
springs) and through cartilage-cartilage contact, tibial contact area
(`zero_contour_area`) and vertex p_max, beside the EF's and Donahue 2002's; per meniscus
(`MeniscusReport`) where the femur touches it, how much of its superior surface lies near
the femur, how far its body moves radially, and the hoop force along its arc
(`fecheck.fe.knee.meniscus_body.element_stress`, `fecheck.fe.bodies.meniscus_solid.hoop_force`).
The menisci as bodies (placement, stiffness, horn springs) are built by
`fecheck.fe.knee.meniscus_body`. Units: mm, N, MPa.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from enum import Enum

import numpy as np

from fecheck.errors import FecheckError
from fecheck.fe.bodies.indenter import MeshIndenter
from fecheck.fe.bodies.meniscus_solid import (
    DEFAULT_SIZE_MM,
    INFERIOR,
    SUPERIOR,
    HoopResult,
)
from fecheck.fe.bodies.pose import FramePose
from fecheck.fe.bodies.settings import FESettings
from fecheck.fe.contact.candidates import Outcome, Round, widened
from fecheck.fe.contact.condense import ElasticBody, Pair
from fecheck.fe.contact.gap import nodal_displacements, surface_give
from fecheck.fe.knee.femoral import FemoralSheet, femoral_layer, femoral_sheet, refuse_two_layer
from fecheck.fe.knee.meniscus_body import (
    MeniscusBody,
    build_meniscus,
    coronary_springs,
    element_stress,
    horn_matrices,
    inferior_rays,
)
from fecheck.fe.material.anisotropy import MENISCUS, TransIso
from fecheck.fe.solve.joint import FemoralLayer
from fecheck.fe.solve.multibody import Condensed, MultibodySolution
from fecheck.fe.solve.press import FELayer, build_layers
from fecheck.scene import Scene
from geometry.mesh import TriMesh

PENETRATION_TOL_MM = 1e-6
"""Largest overlap accepted at any contact vertex after the solve, mm."""
REACH_MM = 0.5
"""The femoral layer covers the sheet where the rays of the femur pairs' vertices within
this distance beyond the candidate gap meet it (and `fecheck.fe.knee.femoral.CROP_MM` around):
room for the candidates the femur's travel adds, mm (beyond it the layer grows,
`_grown_femoral`)."""
MAX_CONDENSATIONS = 6
"""Most condensations (each widening the candidates or re-pairing them on the femoral
layer, which grows before one where needed) before a penetration is reported."""
REPAIR_WEIGHT = 1e-9
"""While a vertex penetrates, a candidate is paired afresh with the femoral layer when a
barycentric weight of the point its ray hits has moved by more than this since the
pairing in use (measured on the scanned knee: each re-pairing cuts the penetration about
200-fold, 0.21 mm → 1.3e-3 → 7.4e-6 mm; the condensation is reused where it can be)."""
MAX_CANDIDATES = 12000
"""Most contact candidates in all (their dense compliance: 12000² doubles are 1.2 GB)."""


REGION_NAMES = {0: "cartilage", 1: "anterior horn", 2: "body", 3: "posterior horn"}
"""Tibial contact regions: 0 the cartilage-cartilage contact, 1-3 the tibia under the
meniscus's packaged regions (its inferior face's region: anterior horn, body, posterior
horn)."""


@dataclass(frozen=True)
class RegionFE:
    """One tibial contact region: its axial contact load into the tibia (N, +
    compressive), contact area (mm², inside the zero line of its own pressure) and vertex
    p_max (MPa). The horn springs are no region: the regions' loads plus
    `CompartmentFE.springs_N` make the compartment's load."""

    load_N: float
    area_mm2: float
    p_max_MPa: float


@dataclass(frozen=True)
class CompartmentFE:
    """One compartment: axial loads into the tibia (N, + compressive) through the
    meniscus (contact + horn springs), its horn springs alone and cartilage-cartilage;
    the femur's axial load on the meniscus; the meniscal share; tibial contact area (mm²)
    and vertex p_max (MPa); the meniscus's force balance (N, norm of the residual); how
    far the meniscus slides in the tibial plane (mm, its vertices' mean displacement); the
    deepest compression of the tibial layer under the femur (mm, along the normals): how
    far the femur comes down onto what lies around its contact; per tibial region
    (`REGION_NAMES`) its `RegionFE`."""

    meniscus_N: float
    springs_N: float
    cartilage_N: float
    femur_on_meniscus_N: float
    share: float
    area_mm2: float
    p_max_MPa: float
    meniscus_balance_N: float
    meniscus_slide_mm: float = 0.0
    compression_mm: float = 0.0
    regions: dict[str, RegionFE] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class MeniscusReport:
    """One meniscus at the answer: the area of its superior surface (mm², vertex
    tributary areas) the femur presses and within 0.1 / 0.5 / 1 mm of the femur
    (`near_mm2`, keyed by the distance), the mean outward radial displacement of its body
    (arc 0.25-0.75, volume-weighted, mm; + extruded), the hoop stress and force along
    its arc (`fecheck.fe.bodies.meniscus_solid.HoopResult`), and per horn its root's tension
    along the root's direction (N, + pulling the horn toward the tibia: the force on the
    tibia along the root)."""

    contact_mm2: float
    near_mm2: dict[float, float]
    radial_mm: float
    hoop: HoopResult
    roots_N: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class PairRecord:
    """One contact pair at the answer (tibia frame): slave `nodes` (the layer's surface
    vertices, or the meniscus's mesh points), contact forces (N, ≥ 0), gaps (mm) and the
    unit normals (from the slave toward the master) the forces act along."""

    nodes: np.ndarray
    force_N: np.ndarray
    gap_mm: np.ndarray
    normals: np.ndarray


@dataclass(frozen=True, eq=False)
class KneeMenisciFE:
    """The answer: load (N), per compartment the FE (`CompartmentFE`) and the EF (a dict
    of the same names), femur travel from the EF pose (mm) along `axis` (the tibia frame's
    unit vector along which the femur is pushed), the femur's balance along it (N), the
    worst penetration over every pair's vertices (mm), dofs, outer iterations, times (s),
    each pair's `PairRecord`, and per meniscus the horn springs' force on it (3,) N and
    its `MeniscusReport`; per compartment the pressure on the tibial layer's surface
    vertices (MPa: femur and meniscus contact) and the outline of the meniscus's
    footprint (its inferior surface's boundary edges, (k, 2, 3) mm, tibia frame); per
    compartment the tibial region (`REGION_NAMES` key) of each layer surface vertex; the
    femur's turn from the EF pose about each rotation the tibia is free in (deg, `turns`)
    and its moment balance about each (N·mm: contact moment plus the load's); the
    cartilage model (``fe.cartilage``: "series" or "two-layer"); per compartment the FE of
    the same knee without menisci (empty unless asked for, `knee_menisci_fe`); per
    compartment the tibial layer's surface (tibia frame, mm: `pressure_MPa` is on its
    vertices) and per meniscus its superior surface (tibia frame, at the placement) with
    the femur's pressure on its vertices (MPa: contact force over vertex tributary area)."""

    load_N: float
    fe: dict[str, CompartmentFE]
    ef: dict[str, dict[str, float]]
    approach_mm: float
    axis: np.ndarray
    balance_N: float
    max_penetration_mm: float
    n_dofs: int
    outer_iterations: int
    seconds: dict[str, float]
    pairs: dict[str, PairRecord] = field(default_factory=dict)
    spring_force_N: dict[str, np.ndarray] = field(default_factory=dict)
    menisci: dict[str, MeniscusReport] = field(default_factory=dict)
    pressure_MPa: dict[str, np.ndarray] = field(default_factory=dict)
    outlines: dict[str, np.ndarray] = field(default_factory=dict)
    tibial_region: dict[str, np.ndarray] = field(default_factory=dict)
    turn_deg: np.ndarray = field(default_factory=lambda: np.zeros(0))
    moment_balance_Nmm: np.ndarray = field(default_factory=lambda: np.zeros(0))
    cartilage: str = "series"
    without_menisci: dict[str, CompartmentFE] = field(default_factory=dict)
    surfaces: dict[str, TriMesh] = field(default_factory=dict)
    meniscus_surfaces: dict[str, tuple[TriMesh, np.ndarray]] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class FemoralCrop:
    """What a compartment's femoral layer is built over (`fecheck.fe.knee.femoral.femoral_layer`):
    the femoral sheet (tibia frame at the EF pose) and its `MeshIndenter`, the FE settings,
    and the points (k, 3) mm where the femur pairs' rays meet the sheet, with the faces
    (k,) they meet."""

    sheet: FemoralSheet
    indenter: MeshIndenter
    settings: FESettings
    points: np.ndarray
    faces: np.ndarray


@dataclass(eq=False)
class _Side:
    """One compartment in the tibia frame: its layer and `ElasticBody`, the femoral surface
    (world), its meniscus or None, and per layer vertex the meniscus inferior face its
    ray meets (-1: none), the barycentric weights and the gap (mm); `under` the vertices
    paired with the meniscus rather than the femur; `lift` (mm) taken off every
    femur-meniscus gap; with two deformable layers the femoral layer (tibia frame,
    `fecheck.fe.solve.joint.FemoralLayer`), its `ElasticBody` (carried by the femur), its
    surface as a `fecheck.fe.bodies.indenter.MeshIndenter` (what the rays hit), `hits`: per
    femur pair (its `PairKind`) the femoral layer's MeshIndenter hits (face (k,),
    weights (k, 3)) of every vertex it may pair, at the pairing in use, and the
    `FemoralCrop` the layer was built over."""

    name: str
    layer: FELayer
    body: ElasticBody
    indenter: MeshIndenter
    meniscus: MeniscusBody | None
    face: np.ndarray
    weights: np.ndarray
    gap: np.ndarray
    under: np.ndarray
    lift: float = 0.0
    femoral: FemoralLayer | None = None
    femoral_body: ElasticBody | None = None
    femoral_surface: MeshIndenter | None = None
    hits: dict[PairKind, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    femoral_crop: FemoralCrop | None = None


def _disp(body: ElasticBody, u: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """(k, 3) displacements (mm) of `nodes` of `body` from its kept-dof `u` (0: fixed)."""
    return nodal_displacements(body.node_dofs, u, nodes)


def knee_menisci_fe(scene: Scene, *, meniscus_size_mm: float = DEFAULT_SIZE_MM,
                    root: str | None = None, ef=None, layers=None, lift_mm: float = 0.0,
                    coronary: bool | None = None,
                    log: Callable[[str], None] | None = None,
                    material: TransIso = MENISCUS,
                    hold_rotation: bool = False, without: bool = False) -> KneeMenisciFE:
    """The FE of `scene`'s knee with menisci at its EF equilibrium (module docstring).

    `ef`: the scene's EF run (`fecheck.model.menisci.run_menisci`; run here when None);
    `layers`: its tibial layers (`fecheck.fe.solve.press.FELayer`, built here when None);
    `meniscus_size_mm`: the meniscus tetrahedra (`fecheck.fe.bodies.meniscus_solid`); `root`:
    the horn roots (None: menisci.roots, "springs" along the root at
    menisci.root_N_per_mm or "bundles"; or one of `fecheck.fe.knee.meniscus_body.ROOTS`,
    the same in x, y and z; the horns of menisci.torn_roots left out); `lift_mm`: the
    superior surface raised along its normals, mm; `coronary`: the coronary ligaments as
    springs too (None: menisci.coronary); `material`: the menisci's transversely isotropic
    constants; `hold_rotation`: the femur kept at the
    EF's rotation (else it turns free in the tibia's free rotations, `femur_turns`);
    `without`: the same FE of the knee without its menisci too (``menisci.sides = []``, at
    that scene's own EF equilibrium, on the same tibial layers), in
    `KneeMenisciFE.without_menisci`. `FecheckError` on a scene without ``menisci.dir``,
    a two-layer cartilage on remeshed sheets, a load that does not press the joint, or a
    contact that leaves a penetration over `PENETRATION_TOL_MM`."""
    from fecheck.fe.bodies.meniscus_solid import meniscus_solid
    from fecheck.model.assembly import applied_load
    from fecheck.model.menisci import menisci_dir, run_menisci
    from fecheck.scene import with_values
    from fecheck.statics.newton import body_pose

    say = log or (lambda message: None)
    root = scene["menisci.roots"] if root is None else root
    coronary = scene["menisci.coronary"] if coronary is None else coronary
    if not scene["menisci.dir"]:
        raise FecheckError("the FE with menisci needs a scene with menisci.dir (e.g. "
                           "femur_tibia_menisci)")
    plain = with_values(scene, menisci__dir="")
    settings = FESettings.from_scene(plain)
    refuse_two_layer(plain, settings)
    seconds: dict[str, float] = {}
    t0 = time.perf_counter()
    run = ef if ef is not None else run_menisci(scene)
    if not run.converged:
        raise FecheckError("the EF equilibrium with menisci did not converge: no pose for "
                           "the FE")
    poses = ef_coordinates(run)
    q_tibia = poses["tibia"]
    X_WT = FramePose(*body_pose(q_tibia), "W", "T")
    load = float(applied_load(scene)(*X_WT.pair())[0][2])
    if not load > 0:
        raise FecheckError(f"the load less the tibia's weight along z is {load:.1f} N: the "
                           "FE with menisci needs a load that presses the joint")
    seconds["ef"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    if layers is None:
        from fecheck.fe.bodies.scene_bodies import scene_bodies

        layers = build_layers(scene_bodies(plain), scene["contact.youngs_MPa"],
                              scene["contact.poisson"], settings, say)
    sides = []
    for lay in layers:
        pts, nrm = lay.surface.points, lay.solid.normals
        body = ElasticBody(f"{lay.body.name} tibia", lay.solid.K, lay.solid.vertex_dofs)
        men = None
        if f"{lay.body.name} meniscus" in poses:
            solid = meniscus_solid(scene, lay.body.name, meniscus_size_mm)
            extra = coronary_springs(solid, menisci_dir(scene)) if coronary else None
            torn = tuple(h.split("-")[1] for h in scene["menisci.torn_roots"]
                         if h.startswith(f"{lay.body.name}-"))
            horns = horn_matrices(solid, root, scene["menisci.root_N_per_mm"], torn)
            men = build_meniscus(solid, poses[f"{lay.body.name} meniscus"], q_tibia, pts, nrm,
                            horns, extra, material)
            say(f"{men.side} meniscus: {len(men.solid.mesh.tets)} tetrahedra, "
                f"{men.body.K.shape[0]} dofs, raised {men.rise_mm:.3f} mm onto the layer")
        sides.append(replace(_side(lay, body, men, X_WT), lift=float(lift_mm)))
    if settings.cartilage == "two-layer":
        sides = _with_femoral_layers(plain, sides, X_WT, settings, say)
    seconds["build"] = time.perf_counter() - t0
    turns = femur_turns(scene, q_tibia) if not hold_rotation else (np.zeros((0, 3)),
                                                                    np.zeros(0))
    result = _solve(sides, X_WT, load, settings.candidate_gap_mm, run, seconds, say, turns)
    if not without:
        return result
    say("the same knee without its menisci")
    bare = with_values(scene, menisci__sides=[], menisci__remove=[],
                       menisci__calibration="")
    alone = knee_menisci_fe(bare, layers=layers, log=log, hold_rotation=hold_rotation)
    return replace(result, without_menisci=alone.fe)


def ef_coordinates(run) -> dict[str, np.ndarray]:
    """{body: its generalised coordinates q (6,) (mm, rad)} of the EF run with menisci
    (`fecheck.model.menisci.run_menisci`): the tibia's and each meniscus's ("<compartment>
    meniscus")."""
    return {name: np.asarray(q, dtype=float) for name, q in run.coordinates.items()}


def _with_femoral_layers(scene: Scene, sides: list[_Side], X_WT: FramePose, settings,
                         say: Callable[[str], None]) -> list[_Side]:
    """`sides` each with the femoral cartilage as a layer of its own (tibia frame, bonded
    to the femur and carried by it: `fecheck.fe.knee.femoral.femoral_layer`) over the points
    where the normals of its femur pairs' vertices within `REACH_MM` of the candidate gap
    (the meniscus's less its lift) meet the femoral sheet (`FemoralCrop`)."""
    world = sides[0].indenter.mesh
    sheet = femoral_sheet(scene, world)
    sheet = replace(sheet, mesh=TriMesh(X_WT.inverse().points(world.points), world.faces))
    indenter = MeshIndenter(sheet.mesh)
    out = []
    for s in sides:
        points, faces = [], []
        for kind in _femur_kinds(s):
            pts, nrm = _pair_points(s, kind)
            gap, face, _ = indenter.hits(pts, nrm)
            lift = s.lift if kind is PairKind.FEMUR_MENISCUS else 0.0
            near = (face >= 0) & (gap.gap_mm - lift < settings.candidate_gap_mm + REACH_MM)
            if kind is PairKind.FEMUR_TIBIA:
                near &= ~s.under
            points.append(pts[near] + gap.gap_mm[near, None] * nrm[near])
            faces.append(face[near])
        crop = FemoralCrop(sheet, indenter, settings, np.concatenate(points),
                           np.concatenate(faces))
        side = _with_femoral(s, crop, say)
        side.hits = _femoral_hits(side, X_WT, 0.0, None)
        out.append(side)
    return out


def _with_femoral(s: _Side, crop: FemoralCrop, say: Callable[[str], None]) -> _Side:
    """`s` with its femoral layer built over `crop` (its hits left to the caller)."""
    layer = femoral_layer(crop.sheet, s.name, crop.points, crop.faces, crop.settings, say)
    return replace(s, femoral=layer, femoral_body=ElasticBody(
        f"{s.name} femoral", layer.solid.K, layer.solid.vertex_dofs, carried=True),
        femoral_surface=MeshIndenter(layer.solid.surface), femoral_crop=crop, hits={})


def _grown_femoral(s: _Side, cands: dict[PairKey, np.ndarray], X_WT: FramePose,
                   travel: float, turn: np.ndarray | None, say: Callable[[str], None]
                   ) -> _Side | None:
    """`s` with its femoral layer rebuilt over its `FemoralCrop`'s points and the points
    where the normals of the candidates `cands` whose rays miss the layer but meet the
    femoral sheet (`_Side.hits`, the femur at `travel` turned by `turn`) meet the sheet,
    and its hits there; None where there is no such candidate."""
    if s.femoral is None:
        return None
    crop = s.femoral_crop
    points, faces = [crop.points], [crop.faces]
    for kind in _femur_kinds(s):
        rows = cands[s.name, kind]
        miss = rows[s.hits[kind][0][rows] == -1]
        pts, nrm = _in_femur(*(a[miss] for a in _pair_points(s, kind)), X_WT, travel, turn)
        gap, face, _ = crop.indenter.hits(pts, nrm)
        points.append(pts + gap.gap_mm[:, None] * nrm)
        faces.append(face)
    added = sum(len(f) for f in faces[1:])
    if not added:
        return None
    say(f"{s.name} femoral layer: the normals of {added} contact candidates miss it: "
        "grown over the sheet they meet")
    side = _with_femoral(s, replace(crop, points=np.concatenate(points),
                                    faces=np.concatenate(faces)), say)
    side.hits = _femoral_hits(side, X_WT, travel, turn)
    return side


TURN_DOFS = {"flexion": 0, "abduction": 1, "internal": 2}
"""The tibia's rotational coordinates and their axis in the chain Rx·Ry·Rz of its pose."""


def femur_turns(scene: Scene, q_tibia: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(unit axes (r, 3) in the frame of the tibia at `q_tibia`, moments (r,) N·mm): the
    femur turns about the tibia's origin along each rotation the scene leaves free to the
    tibia (``dofs.free``), under the moment about it that the load and the tibia's weight
    put on the tibia, reversed (the EF balances the tibia's moment about its origin along
    those axes; the FE the femur's)."""
    from fecheck.model.assembly import applied_load
    from fecheck.statics.frames import rot_x, rot_y
    from fecheck.statics.newton import body_pose

    q = np.asarray(q_tibia, dtype=float)
    X_WT = FramePose(*body_pose(q), "W", "T")
    rx = rot_x(q[3])
    axes = (np.array([1.0, 0.0, 0.0]), rx[:, 1], (rx @ rot_y(q[4]))[:, 2])
    free = [TURN_DOFS[d] for d in scene.free_dofs if d in TURN_DOFS]
    world = np.array([axes[i] for i in free]).reshape(-1, 3)
    wrench = applied_load(scene)(*X_WT.pair())[0]
    about_origin = wrench[3:] - np.cross(X_WT.translation, wrench[:3])
    return world @ X_WT.rotation, -(world @ about_origin)


def _side(lay, body: ElasticBody, men: MeniscusBody | None, X_WT: FramePose) -> _Side:
    """The compartment's pairing: a layer vertex meets the meniscus where its ray meets
    the meniscus's inferior face before the femur."""
    pts, nrm = lay.surface.points, lay.solid.normals
    n = len(pts)
    if men is None:
        return _Side(lay.body.name, lay, body, lay.indenter, None, np.full(n, -1),
                     np.zeros((n, 3)), np.full(n, np.inf), np.zeros(n, dtype=bool))
    face, weights, gap = inferior_rays(men.points, men.inferior_faces, pts, nrm)
    femur = _femur_gap(lay.indenter, pts, nrm, X_WT, 0.0)
    return _Side(lay.body.name, lay, body, lay.indenter, men, face, weights, gap,
                 (face >= 0) & (gap < femur))


def _femur_gap(indenter, points: np.ndarray, normals: np.ndarray, X_WT: FramePose,
               travel_mm: float, turn: np.ndarray | None = None) -> np.ndarray:
    """Rigid gaps (mm) along `normals` from tibia-frame `points` to the femoral surface,
    the tibia at pose X_WT, the femur turned by the rotation vector `turn` (tibia frame,
    rad, about the tibia's origin; None: not turned) and lowered by `travel_mm` along
    world z."""
    lowered, normals = _in_femur(points, normals, X_WT, travel_mm, turn)
    return indenter.gap(X_WT.points(lowered), X_WT.vectors(normals)).gap_mm


def _in_femur(points: np.ndarray, normals: np.ndarray, X_WT: FramePose, travel_mm: float,
              turn: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Tibia-frame `points` and `normals` carried into the femur's frame at the EF pose:
    the femur lowered by `travel_mm` along world z and turned by `turn` (`_femur_gap`)."""
    lowered = points + travel_mm * (X_WT.rotation.T @ [0.0, 0.0, 1.0])
    if turn is None:
        return lowered, normals
    from scipy.spatial.transform import Rotation

    back = Rotation.from_rotvec(-np.asarray(turn, dtype=float)).as_matrix()
    return lowered @ back.T, normals @ back.T


class PairKind(Enum):
    """The contact pairs of a compartment with a meniscus; the value names them in the
    output (``"<compartment> <value>"``)."""

    FEMUR_TIBIA = "femur-tibia"
    FEMUR_MENISCUS = "femur-meniscus"
    MENISCUS_TIBIA = "meniscus-tibia"

    @property
    def femur(self) -> bool:
        """The femur presses the pair (rigid, or through its cartilage layer)."""
        return self is not PairKind.MENISCUS_TIBIA


FEMUR_PAIRS = (PairKind.FEMUR_TIBIA, PairKind.FEMUR_MENISCUS)
"""The pairs the femur presses (rigid, or through its cartilage layer)."""

PairKey = tuple[str, PairKind]
"""A pair of the knee: its compartment's name and its kind."""


def pair_name(key: PairKey) -> str:
    """The pair's name in the output, e.g. ``"medial femur-tibia"``."""
    return f"{key[0]} {key[1].value}"


def _pair_points(s: _Side, kind: PairKind) -> tuple[np.ndarray, np.ndarray]:
    """(points, unit normals) in the tibia frame of every vertex the femur pair `kind`
    may pair: the tibial layer's surface vertices or the meniscus's femur-facing superior
    vertices."""
    if kind is PairKind.FEMUR_TIBIA:
        return s.layer.surface.points, s.layer.solid.normals
    m = s.meniscus
    return m.points[m.superior], m.superior_normals


def _femur_kinds(s: _Side) -> tuple[PairKind, ...]:
    """The femur pairs of compartment `s`: femur-tibia, and femur-meniscus with a
    meniscus."""
    return FEMUR_PAIRS if s.meniscus is not None else FEMUR_PAIRS[:1]


OFF_SHEET = -2
"""The face `_femoral_hits` gives a vertex whose normal ray meets neither the femoral layer
nor the femoral sheet: no femoral cartilage lies along it (its gap is infinite, as with
the rigid femur), so it is left out of the femur pairs while that holds."""


def _femoral_hits(s: _Side, X_WT: FramePose, travel: float, turn: np.ndarray | None
                  ) -> dict[PairKind, tuple[np.ndarray, np.ndarray]]:
    """Per femur pair of `s` the femoral layer's face (-1: a miss that meets the femoral
    sheet, `OFF_SHEET`: one that does not) and barycentric weights where each of its
    vertices' normal rays meets it (either way along the ray), the femur at `travel`
    turned by `turn`."""
    out = {}
    for kind in _femur_kinds(s):
        pts, nrm = _in_femur(*_pair_points(s, kind), X_WT, travel, turn)
        _, face, weights = s.femoral_surface.hits(pts, nrm)
        miss = np.flatnonzero(face < 0)
        off = s.femoral_crop.indenter.hits(pts[miss], nrm[miss])[1] < 0
        face[miss[off]] = OFF_SHEET
        out[kind] = (face, weights)
    return out


def _reachable(s: _Side, kind: PairKind, rows: np.ndarray) -> np.ndarray:
    """The candidates `rows` of femur pair `kind` that femoral cartilage lies along: all
    with a rigid femur, those not `OFF_SHEET` with a femoral layer."""
    return rows if s.femoral is None else rows[s.hits[kind][0][rows] != OFF_SHEET]


def _pairs(sides: list[_Side], cands: dict[PairKey, np.ndarray]) -> list[Pair]:
    """The contact pairs on the candidate vertices `cands` (pair → indices; those of a
    femur pair that no femoral cartilage lies along left out, `_reachable`)."""
    out = []
    for s in sides:
        key = (s.name, PairKind.FEMUR_TIBIA)
        ft = _reachable(s, PairKind.FEMUR_TIBIA, cands[key])
        out.append(Pair(pair_name(key), s.body.name, ft, s.layer.solid.normals[ft],
                        np.zeros(len(ft)), points=s.layer.surface.points[ft], key=key,
                        **_femoral_master(s, PairKind.FEMUR_TIBIA, ft)))
        if s.meniscus is None:
            continue
        m = s.meniscus
        key = (s.name, PairKind.FEMUR_MENISCUS)
        fm = _reachable(s, PairKind.FEMUR_MENISCUS, cands[key])
        out.append(Pair(pair_name(key), m.body.name, m.superior[fm],
                        m.superior_normals[fm], np.zeros(len(fm)),
                        points=m.points[m.superior[fm]], key=key,
                        **_femoral_master(s, PairKind.FEMUR_MENISCUS, fm)))
        key = (s.name, PairKind.MENISCUS_TIBIA)
        mt = cands[key]
        out.append(Pair(pair_name(key), s.body.name, mt, s.layer.solid.normals[mt],
                        s.gap[mt], m.body.name, m.inferior_faces[s.face[mt]], s.weights[mt],
                        key=key))
    return out


def _femoral_master(s: _Side, kind: PairKind, rows: np.ndarray) -> dict:
    """The master of femur pair `kind` on its vertices `rows`: none (the rigid femur), or
    the femoral layer's faces and weights its rays hit (`_Side.hits`; `FecheckError` on a
    ray that meets the femoral sheet but misses the layer even after `_grown_femoral`)."""
    if s.femoral is None:
        return {}
    face, weights = s.hits[kind]
    if (face[rows] < 0).any():
        k = rows[np.argmax(face[rows] < 0)]
        x = _pair_points(s, kind)[0][k]
        raise FecheckError(f"the normal of a {s.name} {kind.value} contact candidate at "
                           f"({', '.join(f'{v:.1f}' for v in x)}) mm (tibia frame) meets "
                           "the femoral sheet where the femoral layer, grown over it, does "
                           "not reach (its extrusion stops short): use fe.cartilage = "
                           "'series'")
    return {"master": s.femoral_body.name,
            "master_nodes": s.femoral.solid.surface.faces[face[rows]],
            "weights": weights[rows]}


def _femoral_give(s: _Side, kind: PairKind, u: dict[str, np.ndarray] | None
                  ) -> np.ndarray:
    """How far the femoral layer's displacement (u, its kept dofs; None: undeformed)
    moves its surface along the normals of femur pair `kind` where they hit it, mm (0
    with a rigid femur or a miss)."""
    n = len(_pair_points(s, kind)[0])
    if s.femoral is None or not u:
        return np.zeros(n)
    face, weights = s.hits[kind]
    hit = face >= 0
    nodes = s.femoral.solid.surface.faces[face[hit]]
    out = np.zeros(n)
    out[hit] = surface_give(
        _disp(s.femoral_body, u[s.femoral_body.name], nodes.ravel()).reshape(-1, 3, 3),
        weights[hit], _pair_points(s, kind)[1][hit])
    return out


def _all_gaps(sides: list[_Side], X_WT: FramePose, travel: float,
              u: dict[str, np.ndarray] | None, turn: np.ndarray | None = None
              ) -> dict[PairKey, np.ndarray]:
    """Every pair's gaps (mm) over all its possible vertices (inf where none) with the
    femur at `travel` turned by `turn` (`_femur_gap`) and the bodies displaced by `u`
    (None: undeformed)."""
    out = {}
    for s in sides:
        pts, nrm = s.layer.surface.points, s.layer.solid.normals
        every = np.arange(len(pts))
        u_t = _disp(s.body, u[s.body.name], every) if u else np.zeros_like(pts)
        g = (_femur_gap(s.indenter, pts, nrm, X_WT, travel, turn)
             - np.einsum("ij,ij->i", u_t, nrm) + _femoral_give(s, PairKind.FEMUR_TIBIA, u))
        out[s.name, PairKind.FEMUR_TIBIA] = np.where(s.under, np.inf, g)
        if s.meniscus is None:
            continue
        m = s.meniscus
        u_m = (u[m.body.name] if u else np.zeros(m.body.K.shape[0]))
        sup = _disp(m.body, u_m, m.superior)
        out[s.name, PairKind.FEMUR_MENISCUS] = (
            _femur_gap(s.indenter, m.points[m.superior], m.superior_normals, X_WT, travel,
                       turn)
            - np.einsum("ij,ij->i", sup, m.superior_normals) - s.lift
            + _femoral_give(s, PairKind.FEMUR_MENISCUS, u))
        faces = m.inferior_faces[np.maximum(s.face, 0)]
        at = np.einsum("mk,mkc->mc", s.weights, _disp(m.body, u_m, faces.ravel()).reshape(
            -1, 3, 3))
        out[s.name, PairKind.MENISCUS_TIBIA] = np.where(
            s.under, s.gap + np.einsum("ij,ij->i", at - u_t, nrm), np.inf)
    return out


@dataclass(eq=False)
class _Femur:
    """The femur's place while the candidates' rounds solve: its travel along its axis
    (mm) and turns (rad), the last condensation (reused by the next), the pose updates
    and the seconds spent condensing and solving."""

    travel: float
    angles: np.ndarray
    condensed: Condensed | None = None
    outer: int = 0
    condense_s: float = 0.0
    solve_s: float = 0.0


@dataclass(frozen=True, eq=False)
class _Settled:
    """One round's contact: its pairs, the solution, every pair's gaps after it (mm) and
    where the deepest penetration is."""

    pairs: list[Pair]
    sol: MultibodySolution
    gaps: dict[PairKey, np.ndarray]
    where: str


def _solve(sides: list[_Side], X_WT: FramePose, load: float,
           margin: float, run, seconds: dict, say,
           turns: tuple[np.ndarray, np.ndarray] = (np.zeros((0, 3)), np.zeros(0))
           ) -> KneeMenisciFE:
    """Condense on the candidates (gaps under `margin` mm), move the femur until it stops,
    widen the candidates while a vertex outside them penetrates; the answer. A femoral
    layer that a candidate's ray misses is grown over it first (`_grown_femoral`).
    `turns`: (unit axes (r, 3) in the tibia frame about the tibia's origin, the moment
    (r,) N·mm on the femur about each) along which the femur turns free under that
    moment."""
    axis = -X_WT.rotation.T @ np.array([0.0, 0.0, 1.0])
    turn_axes, moments = turns
    sides = list(sides)
    gaps = _all_gaps(sides, X_WT, 0.0, None)
    state = _Femur(travel=0.0, angles=np.zeros(len(turn_axes)))

    def solve(cands: dict[PairKey, np.ndarray]) -> Round[_Settled]:
        t0 = time.perf_counter()
        for i, s in enumerate(sides):
            grown = _grown_femoral(s, cands, X_WT, state.travel, state.angles @ turn_axes, say)
            sides[i] = s if grown is None else grown
        seconds["build"] += time.perf_counter() - t0
        off = sum(len(cands[s.name, k]) - len(_reachable(s, k, cands[s.name, k]))
                  for s in sides for k in _femur_kinds(s))
        if off:
            say(f"{off} contact candidates meet no femoral cartilage along their normals: "
                "left out of the femur pairs")
        pairs = [p for p in _pairs(sides, cands) if len(p.nodes)]
        count = sum(len(p.nodes) for p in pairs)
        if count > MAX_CANDIDATES:
            raise FecheckError(f"{count} contact candidates (gaps under {margin:.2f} mm), more "
                               f"than the {MAX_CANDIDATES} the dense contact solve takes: "
                               "lower fe.candidate_gap_mm or coarsen the sheets (fe.prepare "
                               "= 'on', fe.size_mm)")
        t0 = time.perf_counter()
        state.condensed = Condensed(_bodies(sides), pairs, axis,
                                    turns=[(a, np.zeros(3)) for a in turn_axes],
                                    reuse=state.condensed)
        state.condense_s += time.perf_counter() - t0
        say(f"condensed {sum(len(p.nodes) for p in pairs)} contact candidates in "
            f"{state.condensed.seconds:.1f} s")
        t0 = time.perf_counter()
        arm = max(float(np.linalg.norm(p.points, axis=1).max()) for p in pairs if p.key[1].femur)
        sol = state.condensed.solve(
            lambda x: np.concatenate([_pair_gaps(p, sides, X_WT, x[0], x[1:] @ turn_axes)
                                      for p in pairs]),
            load, moments_Nmm=moments, start=np.r_[state.travel, state.angles], arm_mm=arm)
        state.outer += sol.updates
        state.travel, state.angles = sol.approach_mm, sol.turns_rad
        state.solve_s += time.perf_counter() - t0
        paired = {s.name: s.hits for s in sides}
        for s in sides:
            if s.femoral is not None:
                s.hits = _femoral_hits(s, X_WT, state.travel, state.angles @ turn_axes)
        gaps = _all_gaps(sides, X_WT, state.travel, sol.u, state.angles @ turn_axes)
        worst, where = _worst(gaps, sides)
        moved = _moved_hits(paired, sides, cands) if worst > PENETRATION_TOL_MM else 0
        return Round(_Settled(pairs, sol, gaps, where), gaps, worst, moved)

    def widening(result: Round[_Settled]) -> None:
        say(f"a vertex penetrates by {result.worst:.2e} mm ({result.solution.where}): "
            + (f"re-pairing the {result.repaired} contact candidates whose ray has moved on "
               "the femoral layer" if result.repaired else "widening the candidates"))

    result, outcome, _ = widened(solve, {name: np.flatnonzero(g < margin)
                                         for name, g in gaps.items()},
                                 margin, MAX_CONDENSATIONS, PENETRATION_TOL_MM, widening)
    pairs, sol, gaps, worst = (result.solution.pairs, result.solution.sol,
                               result.solution.gaps, result.worst)
    if outcome is not Outcome.SETTLED:
        fix = ("raise fe.candidate_gap_mm" if outcome is Outcome.STUCK else
               f"the contact did not settle in {MAX_CONDENSATIONS} condensations; refine "
               "the sheets at the contact, or use fe.cartilage = 'series'")
        raise FecheckError(f"the FE with menisci leaves a penetration of {worst:.2e} mm "
                           f"({result.solution.where}); {fix}")
    travel, angles, outer = state.travel, state.angles, state.outer
    t_condense, t_solve = state.condense_s, state.solve_s
    seconds |= {"condense": t_condense, "solve": t_solve}
    fe, balance, pressure, region = _report(sides, pairs, sol, axis, load)
    ef = _ef_rows(run, [s.name for s in sides])
    on_femur = sum(np.cross(p.points, p.normals).T @ sol.pairs[p.name].force_N
                   for p in pairs if p.key[1].femur)
    records = {p.name: PairRecord(p.nodes, sol.pairs[p.name].force_N, sol.pairs[p.name].gap_mm,
                                  p.normals) for p in pairs}
    springs = {s.name: -np.einsum("nij,nj->i", s.meniscus.spring_N_per_mm, _disp(
        s.meniscus.body, sol.u[s.meniscus.body.name], s.meniscus.spring_nodes))
        for s in sides if s.meniscus}
    reports = {s.name: meniscus_report(s.meniscus, sol.u[s.meniscus.body.name],
                                       gaps[s.name, PairKind.FEMUR_MENISCUS],
                                       records[pair_name((s.name, PairKind.FEMUR_MENISCUS))])
               for s in sides if s.meniscus}
    return KneeMenisciFE(load, fe, ef, travel, axis, balance, worst,
                         sum(b.K.shape[0] for b in _bodies(sides)), outer, seconds, records,
                         springs, reports, pressure,
                         {s.name: outline(s.meniscus.points, s.meniscus.inferior_faces)
                          for s in sides if s.meniscus}, region,
                         np.degrees(angles), turn_axes @ on_femur + moments,
                         "two-layer" if any(s.femoral is not None for s in sides) else "series",
                         {}, {s.name: s.layer.surface for s in sides},
                         {s.name: superior_pressure(s.meniscus, records.get(
                             pair_name((s.name, PairKind.FEMUR_MENISCUS))))
                          for s in sides if s.meniscus})


def _bodies(sides: list[_Side]) -> list[ElasticBody]:
    """Every body of the knee: the tibial layers, the menisci and the femoral layers."""
    return ([s.body for s in sides] + [s.meniscus.body for s in sides if s.meniscus]
            + [s.femoral_body for s in sides if s.femoral_body is not None])


def superior_pressure(m: MeniscusBody, record: PairRecord | None
                      ) -> tuple[TriMesh, np.ndarray]:
    """(the superior surface of meniscus `m` (its own vertices, tibia frame), the femur's
    pressure on each vertex, MPa): contact force over the vertex's tributary area."""
    faces = m.solid.faces(SUPERIOR)
    used = np.unique(faces)
    index = np.full(len(m.points), -1)
    index[used] = np.arange(len(used))
    surface = TriMesh(m.points[used], index[faces])
    area = np.bincount(surface.faces.ravel(), np.repeat(surface.face_areas / 3.0, 3),
                       minlength=len(used))
    force = np.zeros(len(m.points))
    if record is not None:
        force[record.nodes] = record.force_N
    return surface, np.divide(force[used], area, out=np.zeros(len(used)), where=area > 0)


def _moved_hits(paired: dict[str, dict], sides: list[_Side],
                cands: dict[PairKey, np.ndarray]) -> int:
    """How many femur-pair candidates' rays hit the femoral layer elsewhere (another face,
    or weights moved by over `REPAIR_WEIGHT`) than at the pairing `paired` (per side,
    `_Side.hits`) the solve used."""
    count = 0
    for s in sides:
        for kind, (face, weights) in s.hits.items():
            rows = cands[s.name, kind]
            old_face, old_weights = paired[s.name][kind]
            count += int(((face[rows] != old_face[rows])
                          | (np.abs(weights[rows] - old_weights[rows]).max(axis=1)
                             > REPAIR_WEIGHT)).sum())
    return count


def outline(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(k, 2, 3) the boundary edges of the triangles `faces` on `points` (mm): the edges
    that belong to one face only."""
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    unique, count = np.unique(edges, axis=0, return_counts=True)
    return points[unique[count == 1]]


NEAR_MM = (0.1, 0.5, 1.0)
"""Distances from the femur (mm) at which `MeniscusReport` measures the superior area."""
HOOP_ARCS = (0.1, 0.25, 0.5, 0.75, 0.9)
"""Arc coordinates (0 anterior tip, 1 posterior) of the hoop force sections."""


def meniscus_report(m: MeniscusBody, u: np.ndarray, gaps: np.ndarray,
                    record: PairRecord | None) -> MeniscusReport:
    """The `MeniscusReport` of meniscus `m` at its kept-dof displacement `u` (mm), the
    gaps (mm) of its femur-facing superior vertices `m.superior` at the answer and the
    femur-meniscus pair's record."""
    from fecheck.fe.bodies.meniscus_solid import hoop_force

    faces = m.solid.faces(SUPERIOR)
    tri = m.points[faces]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    vertex = np.bincount(faces.ravel(), np.repeat(area / 3.0, 3), minlength=len(m.points))
    pressed = np.zeros(len(m.points), dtype=bool)
    if record is not None:
        pressed[record.nodes[record.force_N > 0]] = True
    near = {d: float(vertex[m.superior[gaps <= d]].sum()) for d in NEAR_MM}
    full = m.tie @ u
    sigma = element_stress(m.basis, full, m.solid.fibre @ m.rotation.T, m.material)
    sigma = np.einsum("ai,nab,bj->nij", m.rotation, sigma, m.rotation)    # the data frame
    return MeniscusReport(float(vertex[pressed].sum()), near,
                          radial_displacement(m, full),
                          hoop_force(m.solid, sigma, HOOP_ARCS), root_tensions(m, u))


def root_tensions(m: MeniscusBody, u: np.ndarray) -> dict[str, float]:
    """{horn: tension (N) along its root's direction} of meniscus `m` at its kept-dof
    displacement `u`: −(Σ over the horn's nodes of the springs' force on the meniscus)·e,
    e the root's unit direction (`fecheck.fe.bodies.meniscus_solid.Horn.direction`)."""
    out, start = {}, 0
    for horn in m.horn_N_per_mm:
        nodes = m.solid.horns[horn].nodes
        rows = slice(start, start + len(nodes))
        start += len(nodes)
        force = -np.einsum("nij,nj->i", m.spring_N_per_mm[rows],
                           _disp(m.body, u, m.spring_nodes[rows]))
        out[horn] = float(-force @ m.solid.horns[horn].direction) if \
            m.solid.horns[horn].ligaments else float("nan")
    return out


def radial_displacement(m: MeniscusBody, full: np.ndarray) -> float:
    """Mean outward radial displacement (mm) of the elements of `m` between arc 0.25 and
    0.75 (volume-weighted): each element's mean vertex displacement (from the P2 field
    `full`) along the horizontal normal to its fibre, pointing away from the meniscus's
    mean point."""
    vertex = full[m.basis.nodal_dofs].T                              # (n, 3)
    tets = m.solid.mesh.tets
    disp = vertex[tets].mean(axis=1)
    fibre = m.solid.fibre @ m.rotation.T
    out = np.cross(fibre, [0.0, 0.0, 1.0])
    centroid = m.points[tets].mean(axis=1)
    out *= np.sign(np.einsum("ij,ij->i", out, centroid - m.points.mean(axis=0)))[:, None]
    out /= np.linalg.norm(out, axis=1, keepdims=True)
    body = (m.solid.arc >= 0.25) & (m.solid.arc <= 0.75)
    vol = np.abs(m.solid.mesh.tet_volumes)[body]
    return float(vol @ np.einsum("ij,ij->i", disp[body], out[body]) / vol.sum())


def _worst(gaps: dict[PairKey, np.ndarray], sides: list[_Side]) -> tuple[float, str]:
    """(the deepest penetration over every pair's vertices (mm, ≥ 0), the pair and the
    vertex's place in the tibia frame)."""
    key = min(gaps, key=lambda k: float(gaps[k].min()))
    k = int(np.argmin(gaps[key]))
    side = next(s for s in sides if s.name == key[0])
    point = (side.meniscus.points[side.meniscus.superior[k]]
             if key[1] is PairKind.FEMUR_MENISCUS else side.layer.surface.points[k])
    return (max(0.0, -float(gaps[key][k])),
            f"{pair_name(key)} at ({', '.join(f'{v:.1f}' for v in point)}) mm, tibia frame")


def _pair_gaps(p: Pair, sides: list[_Side], X_WT: FramePose, travel: float,
               turn: np.ndarray | None = None) -> np.ndarray:
    """The reference gaps (mm) of pair `p` with the femur at `travel` turned by `turn`
    (`_femur_gap`; undeformed)."""
    side = next(s for s in sides if s.name == p.key[0])
    if not p.key[1].femur:
        return p.gap0_mm
    if p.slave == side.body.name:
        return _femur_gap(side.indenter, side.layer.surface.points[p.nodes], p.normals,
                          X_WT, travel, turn)
    return _femur_gap(side.indenter, side.meniscus.points[p.nodes], p.normals, X_WT,
                      travel, turn) - side.lift


def _report(sides: list[_Side], pairs: list[Pair], sol, axis: np.ndarray, load: float
            ) -> tuple[dict[str, CompartmentFE], float, dict[str, np.ndarray],
                       dict[str, np.ndarray]]:
    """Per compartment the loads, area and p_max (`CompartmentFE`), the femur's
    balance along its axis (N): Σ λ n·(−a) − F, the tibial vertex pressures (MPa) and
    regions (`REGION_NAMES` keys)."""
    from fecheck.fe.pressure.recovery import zero_contour_area

    by_key = {p.key: p for p in pairs}
    femur_total = 0.0
    out, pressures, regions_at = {}, {}, {}
    for s in sides:
        n_pts = len(s.layer.surface.points)
        force = np.zeros(n_pts)
        axial_at = np.zeros(n_pts)
        region = np.zeros(n_pts, dtype=np.int64)
        axial = {}
        for kind in (PairKind.FEMUR_TIBIA, PairKind.MENISCUS_TIBIA, PairKind.FEMUR_MENISCUS):
            p = by_key.get((s.name, kind))
            lam = sol.pairs[p.name].force_N if p else np.zeros(0)
            normals = p.normals if p else np.zeros((0, 3))
            axial[kind] = float(lam @ normals[:, 2])
            if p and kind.femur:
                femur_total -= float(lam @ (normals @ axis))
            if p and p.slave == s.body.name:
                force[p.nodes] += lam
                axial_at[p.nodes] += lam * normals[:, 2]
            if p and kind is PairKind.MENISCUS_TIBIA:
                inferior = s.meniscus.solid.face_region[s.meniscus.solid.face_label == INFERIOR]
                region[p.nodes] = inferior[s.face[p.nodes]]
        springs, balance, slide = 0.0, 0.0, 0.0
        if s.meniscus is not None:
            m = s.meniscus
            every = _disp(m.body, sol.u[m.body.name], np.arange(len(m.points)))
            slide = float(np.linalg.norm(every.mean(axis=0)[:2]))
            spring = np.einsum("nij,nj->ni", m.spring_N_per_mm,
                               _disp(m.body, sol.u[m.body.name], m.spring_nodes))
            springs = -float(spring[:, 2].sum())
            on_men = -spring.sum(axis=0)
            for kind, sign in ((PairKind.FEMUR_MENISCUS, -1.0), (PairKind.MENISCUS_TIBIA, 1.0)):
                p = by_key.get((s.name, kind))
                if p:
                    on_men += sign * sol.pairs[p.name].force_N @ p.normals
            balance = float(np.linalg.norm(on_men))
        pressure = force / s.layer.solid.tributary_mm2
        pressures[s.name] = pressure
        regions_at[s.name] = region
        ft = by_key[s.name, PairKind.FEMUR_TIBIA]
        sink = -np.einsum("ij,ij->i", _disp(s.body, sol.u[s.body.name], ft.nodes), ft.normals)
        pressed = sol.pairs[ft.name].force_N > 0
        area = zero_contour_area(s.layer.surface.points, s.layer.surface.faces, pressure,
                                 force > 0)
        through = axial[PairKind.MENISCUS_TIBIA] + springs
        total = through + axial[PairKind.FEMUR_TIBIA]
        regions = {name: _region(s.layer.surface, np.where(region == k, pressure, 0.0),
                                 float(axial_at[region == k].sum()))
                   for k, name in REGION_NAMES.items() if k == 0 or s.meniscus is not None}
        out[s.name] = CompartmentFE(through, springs, axial[PairKind.FEMUR_TIBIA],
                                    axial[PairKind.FEMUR_MENISCUS], through / total, float(area),
                                    float(pressure.max()), balance, slide,
                                    float(sink[pressed].max(initial=0.0)), regions)
    return out, femur_total - load, pressures, regions_at


def _region(surface, pressure: np.ndarray, load: float) -> RegionFE:
    """The `RegionFE` of the tibial vertex pressures `pressure` (MPa, zero off the
    region) on `surface`, its axial load `load` (N)."""
    from fecheck.fe.pressure.recovery import zero_contour_area

    active = pressure > 0
    area = zero_contour_area(surface.points, surface.faces, pressure, active) if active.any() \
        else 0.0
    return RegionFE(load, float(area), float(pressure.max(initial=0.0)))


def _ef_rows(run, names: list[str]) -> dict[str, dict[str, float]]:
    """Per compartment the EF's loads, share, tibial contact area (cartilage-cartilage
    plus meniscus-tibia, mm²) and p_max (MPa)."""
    out = {}
    for c in names:
        row = run.menisci["compartments"][c]
        comp = run.compartments[c]
        out[c] = {"meniscus_N": row["meniscus_N"], "cartilage_N": row["cartilage_N"],
                  "share": row["meniscal_share"],
                  "area_mm2": comp.area_mm2 + row.get("meniscus_tibia_area_mm2", 0.0),
                  "p_max_MPa": max(comp.max_pressure_MPa,
                                   row.get("meniscus_tibia_max_pressure_MPa", 0.0))}
    return out
