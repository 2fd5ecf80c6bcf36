"""Plausibility of a run: inputs, meshes and results against the range a knee model lives in.

A run is checked once before its solve (`before_solve`) and once after it (`after_solve`).
A value outside the range of a knee (cartilage E ~0.1-100 MPa, meshes tens of mm across,
loads of 10 N-10 kN, with or without gravity) is most often a unit typed wrong; it gets a
warning (`ImplausibleInput`) naming the likely mistake. Inputs that make the solve
meaningless (a modulus no unit slip explains, a zero load that nothing balances, a contact
surface under a millimetre across, a tibial sheet wound upside down or with mixed winding,
meshes far from their landmarks, medial and lateral sheets on the wrong sides for
knee.side) and results that cannot be physical (NaN, a force without a contact patch,
p_max above `P_MAX_MPA`) are `FecheckError`s.
Units mm, N, MPa.
"""

from __future__ import annotations

import math
import warnings
import weakref
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import wraps
from typing import TypeVar

import numpy as np

from fecheck.contact.analytic import Sphere
from fecheck.contact.pair import ContactPair
from fecheck.errors import FecheckError
from fecheck.model.assembly import Compartment, free_indices, start_pose
from fecheck.model.results import RunResult
from fecheck.scene import Scene
from fecheck.scene.constants import GRAVITY_MPS2
from fecheck.scene.knee import check_side
from fecheck.scene.law_keys import LAWS
from fecheck.statics.newton import pose
from geometry.mesh import TriMesh

CARTILAGE_E_MPA = (0.1, 100.0)
"""Young's modulus of articular cartilage, MPa: ~0.1-1 MPa (equilibrium, soft, OA) to
~10-100 MPa (instantaneous, impact). Below the range: a value in GPa typed as MPa."""

IMPLANT_E_MPA = 5000.0
"""Stiffest plausible bearing material without an implant key in the scene, MPa: UHMWPE
is ~460-1000 MPa, PEEK ~3600 MPa. Above it the modulus is no knee material: a warning,
"kPa typed as MPa?" (an error from `ABSURD_E_MPA`: cartilage's 2e7 Pa typed as MPa)."""

ABSURD_E_MPA = (1e-4, 1e6)
"""Young's moduli no unit slip of a knee material explains, MPa: below 1e-4 MPa (100 Pa)
even cartilage's 0.1 MPa read as GPa, at or above 1e6 MPa (1 TPa, stiffer than diamond)
cartilage's 2e7 Pa typed as MPa. Outside this the solve means nothing: an error."""

INDENTER_E_MPA = 5e5
"""Stiffest plausible indenting condyle (the Hertz law's contact.indenter_youngs_MPa),
MPa: CoCr ~210 GPa, alumina and zirconia ceramics ~200-400 GPa."""

KNEE_LOAD_N = (10.0, 10000.0)
"""External knee loads, N: a limb's own weight (tens of N) to the tibiofemoral peaks of
running and landing (~4-8 body weights, under ~7 kN). Below the range: kN typed as N;
above it: mN typed as N (a warning, whatever the gravity)."""

ABSURD_VOLUMETRIC_N_PER_MM3 = 1e5
"""A volumetric stiffness (N/mm³) at or above this presses 1e5 MPa at 1 mm depth: the
thesis's 1e7 N/m³ typed as N/mm³ (it is 1e-2 N/mm³). An error."""

MESH_EXTENT_MM = (1.0, 1000.0)
"""A knee contact surface is tens of mm across: under 1 mm it is in metres (an error: the
solve cannot mean anything), over a metre in µm or scaled twice (a warning)."""

LANDMARK_GAP_MM = 20.0
"""The condyle sphere or femoral sheet must lie within this of the tibial sheet at the
start pose (start gap and free translations aside): farther, the landmarks (condyle
spheres, fits.json, knee.landmarks) or the meshes' transform do not match the meshes.
A 10 mm start gap (stress matrix) and the scanned scenes (touching) stay well below."""

FOLD_COS = math.cos(math.radians(120.0))
"""Neighbouring faces of a consistently wound sheet whose normals differ by more than
120° fold back over each other (the scanned tibial sheets: ≤ 25°, ≤ 55° decimated to
100 faces); a face turned more than 120° from the sheet's mean normal lies under a fold."""

MIN_CONTACT_FACES = 4
"""A contact spanning fewer faces has no resolved patch: its area and pressure are one
face's average (`fecheck.model.notes` notes contacts under 60 faces as coarse)."""

P_MAX_MPA = 1000.0
"""No knee tissue or bearing carries this: cortical bone fails at ~200 MPa, UHMWPE yields
at ~20-30 MPa, cartilage at ~25 MPa. A larger p_max is a unit mistake, never a result."""

FORCE_RTOL = 1e-9
"""A compartment force below this times the load scale (N) counts as no force."""


class ImplausibleInput(UserWarning):
    """A value outside the range of a knee model: most often a unit typed wrong."""


def _warn(message: str) -> None:
    warnings.warn(message, ImplausibleInput, stacklevel=3)


# ----------------------------------------------------------------------------- inputs
def tibia_weight_N(scene: Scene) -> float:
    """The tibia's weight as the scene applies it, N (0 without gravity)."""
    return scene["tibia.mass_kg"] * GRAVITY_MPS2 * scene["gravity"]


def upward_load_N(scene: Scene) -> float:
    """The external load's component along +z (towards the femur), N."""
    d = np.asarray(scene["load.direction"], dtype=float)
    norm = float(np.linalg.norm(d))
    return scene["load.force_N"] * d[2] / norm if norm > 0 else 0.0


def has_ligaments(scene: Scene) -> bool:
    """Whether ligaments (the three rods or springs, or the scanned knee's bundles) can
    hold the tibia on the femur without an external load."""
    return scene["ligaments.model"] != "none" or scene["scanned.ligaments"] != "none"


def load_hint(scene: Scene) -> str:
    """Why no equilibrium can exist when the load does not lift the tibia's weight
    (kN typed as N?) and neither a ligament nor a driven z holds the tibia; "" when it
    does or nothing weighs."""
    weight, up = tibia_weight_N(scene), upward_load_N(scene)
    if weight <= 0 or up >= weight or has_ligaments(scene) or "z" not in scene.free_dofs:
        return ""
    return (f"the load presses the tibia up with {up:.4g} N, less than the tibia's weight "
            f"{weight:.4g} N (tibia.mass_kg · g): nothing holds the tibia on the femur "
            f"(load.force_N = {scene['load.force_N']:g}: kN typed as N? knee loads are "
            "hundreds of N)")


def no_equilibrium_hint(scene: Scene) -> str:
    """What the load says about a solve that found no equilibrium in contact: `load_hint`,
    or for a scene without load held by ligaments that they may hold the tibia apart."""
    hint = load_hint(scene)
    if hint or scene["load.force_N"] != 0 or not has_ligaments(scene):
        return hint
    weight = " and the tibia's weight" if tibia_weight_N(scene) > 0 else ""
    return (f"with load.force_N = 0 only the ligaments{weight} act on the tibia: they may "
            "hold it apart from the femur, where no contact equilibrium exists; give the "
            "knee load in N (hundreds of N)")


def load_warning(force_N: float) -> str:
    """The warning on a load.force_N `force_N` (N, > 0) outside `KNEE_LOAD_N`, naming the
    unit that would put it inside (kN below, mN above), or ""."""
    low, high = KNEE_LOAD_N
    span = f"({low:g} N-{high / 1000:g} kN)"
    if force_N < low:
        as_kn = force_N * 1000.0
        likely = (f"kN typed as N? ({force_N:g} kN = {as_kn:g} N)" if as_kn >= low else
                  "even read as kN; give the load in N (knee loads are hundreds of N)")
        return f"load.force_N = {force_N:g} N is below any knee load {span}: {likely}"
    if force_N > high:
        as_n = force_N / 1000.0
        likely = (f"mN typed as N? ({force_N:g} mN = {as_n:g} N)" if as_n <= high else
                  "even read as mN; give the load in N (knee loads are hundreds of N)")
        return f"load.force_N = {force_N:g} N is above any knee load {span}: {likely}"
    return ""


def zero_load_error(scene: Scene) -> str:
    """Why a scene without external load cannot be solved, or "": the tibia is free along
    z and neither a load nor a ligament holds it on the femur, so it either falls away
    under its weight or has no contact at all (every pose out of contact balances). A
    ligament-only scene, a driven z and the rigid model (forces of the given pose) are
    solvable without load."""
    if (scene["load.force_N"] != 0 or has_ligaments(scene) or "z" not in scene.free_dofs
            or scene["model.kind"] == "rigid"):
        return ""
    weight = tibia_weight_N(scene)
    fix = "give the knee load in N (hundreds of N, e.g. load.force_N = 800)"
    if weight > 0:
        return (f"load.force_N = 0: nothing holds the tibia on the femur against its weight "
                f"({weight:.4g} N, tibia.mass_kg · g), so no equilibrium exists; {fix}")
    return ("load.force_N = 0 and no weight (gravity = false): nothing presses the tibia on "
            "the femur, so the equilibrium is no contact (zero forces, any pose apart) and "
            f"there is nothing to solve; {fix}")


def _out_of(e: float, low: float, high: float) -> str:
    return (f"softer than any cartilage ({low:g}-{high:g} MPa)" if e < low else
            f"stiffer than cartilage ({low:g}-{high:g} MPa)")


def modulus_warning(e: float, key: str = "contact.youngs_MPa",
                    stiffest_MPa: float = IMPLANT_E_MPA) -> str:
    """The message on a Young's modulus `e` (MPa) of scene key `key` outside the range of
    knee materials (`CARTILAGE_E_MPA` up to `stiffest_MPa`), naming the likely unit, or
    "". Beyond `ABSURD_E_MPA` no unit slip of cartilage explains it (`modulus_error`)."""
    low, high = CARTILAGE_E_MPA
    if e < ABSURD_E_MPA[0]:
        return (f"{key} = {e:g} MPa ({e * 1e6:.3g} Pa) is {_out_of(e, low, high)} even read "
                "as GPa: a value converted the wrong way? (fecheck takes MPa: cartilage "
                "~20 MPa = 0.02 GPa = 2e7 Pa)")
    if e < low:
        return (f"{key} = {e:g} MPa is {_out_of(e, low, high)}: GPa typed as MPa? "
                "(20 MPa = 0.02 GPa)")
    if e <= stiffest_MPa:
        return ""
    what = (f"{_out_of(e, low, high)} and than any bearing implant (UHMWPE ~460-1000 MPa)"
            if stiffest_MPa <= IMPLANT_E_MPA else
            f"{_out_of(e, low, high)} and than any implant metal or ceramic (up to "
            f"{stiffest_MPa:g} MPa)")
    if e >= ABSURD_E_MPA[1]:
        likely = "Pa typed as MPa? (20 MPa = 2e7 Pa)"
    elif e < 1e5:                          # in kPa: 5-100 MPa; in Pa: under 0.1 MPa
        likely = f"kPa typed as MPa? ({e:g} kPa = {e / 1000:g} MPa)"
    else:
        likely = f"Pa or kPa typed as MPa? ({e:g} Pa = {e * 1e-6:g} MPa)"
    return f"{key} = {e:g} MPa is {what}: {likely}"


def modulus_error(e: float) -> bool:
    """Whether a modulus `e` (MPa) is absurd (outside `ABSURD_E_MPA`): an error."""
    return not ABSURD_E_MPA[0] <= e < ABSURD_E_MPA[1]


def _moduli(scene: Scene) -> list[tuple[str, float, float]]:
    """(key, E MPa, stiffest plausible MPa) of each modulus the scene's solve reads."""
    out = []
    if scene["model.kind"] != "rigid":
        out.append(("contact.youngs_MPa", scene["contact.youngs_MPa"], IMPLANT_E_MPA))
        indenter = scene["contact.indenter_youngs_MPa"]
        if "contact.indenter_youngs_MPa" in LAWS[scene["contact.law"]].keys \
                and math.isfinite(indenter):
            out.append(("contact.indenter_youngs_MPa", indenter, INDENTER_E_MPA))
    return out


def volumetric_error(scene: Scene) -> str:
    """The error on a volumetric stiffness typed in N/m³ (the thesis's unit), or ""."""
    key = "contact.volumetric_stiffness_N_per_mm3"
    k = scene[key]
    if (scene["model.kind"] == "rigid" or key not in LAWS[scene["contact.law"]].keys
            or k < ABSURD_VOLUMETRIC_N_PER_MM3):
        return ""
    return (f"{key} = {k:g} N/mm³ would press {k:g} MPa at 1 mm depth, no knee's contact: "
            f"N/m³ typed as N/mm³? ({k:g} N/m³ = {k * 1e-9:g} N/mm³; the thesis gives k_V "
            "in N/m³)")


def input_errors(scene: Scene) -> list[str]:
    """Errors on inputs no unit slip of a knee explains (a zero load nothing balances, an
    absurd modulus or volumetric stiffness): the solve would mean nothing."""
    out = [zero_load_error(scene), volumetric_error(scene)]
    out += [modulus_warning(e, key, top) for key, e, top in _moduli(scene) if modulus_error(e)]
    return [m for m in out if m]


def input_warnings(scene: Scene) -> list[str]:
    """Warnings on the scene's material and load (none for values a knee can have): a
    load outside `KNEE_LOAD_N` whatever the gravity, and one that does not lift the
    tibia's weight (`load_hint`) where that says more."""
    out = [modulus_warning(e, key, top) for key, e, top in _moduli(scene)]
    force = scene["load.force_N"]
    load = load_warning(force) if force > 0 else ""
    out.append(load or load_hint(scene))
    return [w for w in out if w]


# ----------------------------------------------------------------------------- meshes
T = TypeVar("T")


def once_per_mesh(fn: Callable[[TriMesh], T]) -> Callable[[TriMesh], T]:
    """`fn(mesh)` computed once per `TriMesh` (frozen: its arrays never change) and kept
    while the mesh lives: a sweep checks the same sheets at every point. Arrays come back
    read-only, shared by every caller."""
    memo: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()

    @wraps(fn)
    def cached(mesh: TriMesh) -> T:
        if mesh not in memo:
            memo[mesh] = fn(mesh)
        return memo[mesh]
    return cached


def _read_only(*arrays: np.ndarray) -> None:
    for a in arrays:
        a.setflags(write=False)


@once_per_mesh
def extent_mm(mesh: TriMesh) -> float:
    """Largest bounding-box side of the mesh's used vertices, mm."""
    used = np.zeros(mesh.n_points, dtype=bool)
    used[mesh.faces.ravel()] = True
    return float(np.ptp(mesh.points[used], axis=0).max()) if used.any() else 0.0


def check_extent(mesh: TriMesh, what: str) -> None:
    """`FecheckError` for a contact surface under a millimetre across (in metres?), a
    warning over a metre."""
    size = extent_mm(mesh)
    low, high = MESH_EXTENT_MM
    if size < low:
        raise FecheckError(f"the {what} is {size:.3g} mm across, where a knee's is tens of "
                           f"mm: mesh in metres? (scale it by 1000: fecheck works in mm)")
    if size > high:
        _warn(f"the {what} is {size:,.0f} mm across, where a knee's is tens of mm: mesh in "
              "µm, or scaled to mm twice? (fecheck works in mm)")


@dataclass(frozen=True)
class EdgeNeighbours:
    """The faces on the two sides of every shared edge of a triangle mesh.

    a, b : (k,) faces sharing an edge; consistent : (k,) the edge is traversed in
    opposite directions by a and b (their winding agrees); edge : (k, 2) its vertices;
    non_manifold : edges shared by more than two faces; crowded : (m, 2) their vertices,
    once per extra face
    """

    a: np.ndarray
    b: np.ndarray
    consistent: np.ndarray
    edge: np.ndarray
    non_manifold: int
    crowded: np.ndarray

    @property
    def winding_consistent(self) -> bool:
        """`geometry.checks.mesh_report`'s definition: every edge shared by two faces is
        traversed in opposite directions by them, and no edge by more than two."""
        return bool(self.consistent.all()) and self.non_manifold == 0


@once_per_mesh
def edge_neighbours(mesh: TriMesh) -> EdgeNeighbours:
    """Face pairs across the shared edges of `mesh`, from its `geometry.mesh.EdgeTable`
    (`geometry.checks.mesh_report` answers the same winding question with every other
    check, ~10x the time, too slow for every run)."""
    table = mesh.edge_table
    directed, order = table.directed, table.order
    equal = table.sorted_edge[1:] == table.sorted_edge[:-1]
    same = np.flatnonzero(equal)
    a, b = order[same], order[same + 1]
    third = np.flatnonzero(equal[1:] & equal[:-1])
    out = EdgeNeighbours(a // 3, b // 3, directed[a, 0] == directed[b, 1], directed[a],
                         int(np.count_nonzero(equal[1:] & equal[:-1])), directed[order[third]])
    _read_only(out.a, out.b, out.consistent, out.edge, out.crowded)
    return out


def _where(points_xy: np.ndarray) -> str:
    x, y = points_xy.mean(axis=0)
    return f"around (x, y) = ({x:.1f}, {y:.1f}) mm"


@once_per_mesh
def area_mean_normal(mesh: TriMesh) -> np.ndarray:
    """(3,) the faces' normals averaged by area: |·| 1 for a flat sheet, less as it
    curves; its z says which way the sheet faces."""
    cross = mesh.face_cross
    out = cross.sum(axis=0) / max(float(np.linalg.norm(cross, axis=1).sum()), 1e-300)
    _read_only(out)
    return out


def check_winding(mesh: TriMesh, what: str) -> None:
    """`FecheckError` for a tibial sheet with mixed winding (edges traversed the same
    way by both faces) or wound upside down (its area-weighted mean normal points down,
    -z, where contact expects it up, towards the femur)."""
    edges = edge_neighbours(mesh)
    if edges.non_manifold:
        count = len(np.unique(np.sort(edges.crowded, axis=1), axis=0))
        raise FecheckError(f"the {what} has {count} edges shared by three or more faces "
                           f"(non-manifold), "
                           f"{_where(mesh.points[edges.crowded.ravel()][:, :2])}, where a "
                           "contact sheet is one layer of faces: remove the extra faces there")
    if not edges.winding_consistent:
        down = mesh.face_cross[:, 2] < 0
        bad = int(np.count_nonzero(~edges.consistent)) + edges.non_manifold
        minority = down if np.count_nonzero(down) <= mesh.n_faces / 2 else ~down
        where = (_where(mesh.face_centroids[minority][:, :2]) if minority.any() else
                 _where(mesh.points[edges.edge[~edges.consistent].ravel()][:, :2]))
        raise FecheckError(f"the {what} has mixed winding: {bad} edges are traversed the "
                           f"same way by both their faces and {int(down.sum())} of "
                           f"{mesh.n_faces} faces face down (-z), {where}; orient every "
                           "face counter-clockwise seen from above (normals up, towards "
                           "the femur), e.g. trimesh.repair.fix_normals or MeshLab")
    mean = area_mean_normal(mesh)
    if mean[2] < 0:
        raise FecheckError(f"the {what}'s normals point down (area-weighted mean normal "
                           f"n_z = {mean[2]:.2f}), where contact expects them up, towards the "
                           "femur: its winding is inverted; reverse the vertex order of "
                           "every face (flip the normals) in the mesh file")


@once_per_mesh
def fold_faces(mesh: TriMesh) -> np.ndarray:
    """(n_faces,) True for faces of a consistently wound sheet that fold back: across an
    edge their normal turns more than 120° from the neighbour's, or they face more than
    120° away from the sheet's mean normal (under a fold)."""
    edges = edge_neighbours(mesh)
    n = mesh.face_normals
    a, b = edges.a, edges.b
    sharp = edges.consistent & (np.einsum("ij,ij->i", n[a], n[b]) < FOLD_COS)
    out = np.zeros(mesh.n_faces, dtype=bool)
    out[a[sharp]] = True
    out[b[sharp]] = True
    mean = area_mean_normal(mesh)
    norm = float(np.linalg.norm(mean))
    if norm > 0:
        out |= n @ (mean / norm) < FOLD_COS
    _read_only(out)
    return out


def check_folds(mesh: TriMesh, what: str) -> None:
    """Warn when the sheet folds back over itself: the contact would meet the fold's
    upper layer (wrong depth, area and pressure)."""
    folded = fold_faces(mesh)
    if folded.any():
        _warn(f"the {what} folds back over itself: {int(folded.sum())} of {mesh.n_faces} "
              f"faces turn more than 120° against their neighbours or the sheet, "
              f"{_where(mesh.face_centroids[folded][:, :2])}; the contact meets the folded "
              "layer (depth, area and pressure are wrong there): repair the mesh")


def check_sheet(mesh: TriMesh, what: str) -> None:
    """A tibial contact sheet's winding (errors) and folds (a warning)."""
    check_winding(mesh, what)
    check_folds(mesh, what)


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
        d = np.linalg.norm(points - master.center, axis=1) - master.radius
        return max(float(d.min()), 0.0)
    if hasattr(master, "distance_mm"):                  # a mesh master: its own tree
        return float(master.distance_mm(points).min())
    mesh = getattr(master, "mesh", master)
    if not isinstance(mesh, TriMesh):
        return None
    from scipy.spatial import cKDTree

    # every k-th vertex first: an upper bound that settles the usual, touching case fast
    k = max(1, len(mesh.points) // 2000, len(points) // 2000)
    near = float(cKDTree(mesh.points[::k]).query(points[::k], k=1)[0].min())
    if near <= LANDMARK_GAP_MM:
        return near
    return float(cKDTree(mesh.points).query(points, k=1)[0].min())


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


@once_per_mesh
def mean_x_mm(mesh: TriMesh) -> float:
    """Area-weighted mean x of the mesh's faces, mm (0 for a mesh without area)."""
    area = mesh.face_areas
    return float(area @ mesh.face_centroids[:, 0]) / max(float(area.sum()), 1e-300)


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


# ---------------------------------------------------------------------------- results
def _unit_cause(scene: Scene) -> str:
    found = [modulus_warning(e, key, top) for key, e, top in _moduli(scene)]
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
