"""Plausibility of a run: inputs, meshes and results against the range a knee model lives in.

A run is checked once before its solve (`before_solve`) and once after it (`after_solve`).
A value outside the range of a knee (cartilage E ~0.1-100 MPa, meshes tens of mm across,
loads of hundreds of N) is most often a unit typed wrong; it gets a warning
(`ImplausibleInput`) naming the likely mistake. Inputs that make the solve meaningless
(a contact surface under a millimetre across, a tibial sheet wound upside down or with
mixed winding, meshes far from their landmarks) and results that cannot be physical
(NaN, a force without a contact patch, p_max above `P_MAX_MPA`) are `FecheckError`s.
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
from fecheck.statics.newton import pose
from geometry.mesh import TriMesh

CARTILAGE_E_MPA = (0.1, 100.0)
"""Young's modulus of articular cartilage, MPa: ~0.1-1 MPa (equilibrium, soft, OA) to
~10-100 MPa (instantaneous, impact). Below the range: a value in GPa typed as MPa."""

IMPLANT_E_MPA = 5000.0
"""Stiffest plausible bearing material without an implant key in the scene, MPa: UHMWPE
is ~460-1000 MPa, PEEK ~3600 MPa. Above it (cartilage's 2e7 Pa typed as 2e7 MPa) the
modulus is no knee material: a warning, "Pa typed as MPa?"."""

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


def load_hint(scene: Scene) -> str:
    """Why no equilibrium can exist when the load does not lift the tibia's weight
    (kN typed as N?); "" when it does or nothing weighs."""
    weight, up = tibia_weight_N(scene), upward_load_N(scene)
    if weight <= 0 or up >= weight:
        return ""
    return (f"the load presses the tibia up with {up:.4g} N, less than the tibia's weight "
            f"{weight:.4g} N (tibia.mass_kg · g): nothing holds the tibia on the femur "
            f"(load.force_N = {scene['load.force_N']:g}: kN typed as N? knee loads are "
            "hundreds of N)")


def modulus_warning(e: float) -> str:
    """The warning on a contact.youngs_MPa `e` (MPa) outside the range of knee materials,
    or ""."""
    low, high = CARTILAGE_E_MPA
    if e < low:
        return (f"contact.youngs_MPa = {e:g} MPa is softer than any cartilage "
                f"({low:g}-{high:g} MPa): GPa typed as MPa? (20 MPa = 0.02 GPa)")
    if e > IMPLANT_E_MPA:
        return (f"contact.youngs_MPa = {e:g} MPa is stiffer than cartilage ({low:g}-{high:g} "
                f"MPa) and than any bearing implant (UHMWPE ~460-1000 MPa): Pa typed as "
                f"MPa? (20 MPa = 2e7 Pa)")
    return ""


def input_warnings(scene: Scene) -> list[str]:
    """Warnings on the scene's material and load (none for values a knee can have)."""
    out = []
    if scene["model.kind"] != "rigid":
        out.append(modulus_warning(scene["contact.youngs_MPa"]))
    out.append(load_hint(scene))
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
    """Face pairs across the shared edges of `mesh` (one sort of the 3·n_faces
    half-edges; `geometry.checks.mesh_report` answers the same winding question with
    every other check, ~10x the time, too slow for every run)."""
    directed = mesh.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    lo, hi = directed.min(axis=1), directed.max(axis=1)
    key = lo.astype(np.int64) * mesh.n_points + hi
    order = np.argsort(key)
    equal = key[order][1:] == key[order][:-1]
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


def check_meshes(scene: Scene, comps: Sequence[Compartment]) -> None:
    """Checks of every meshed contact pair before the solve: extents, the tibial sheets'
    winding and folds, and the femoral surface's distance to them."""
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
    for message in input_warnings(scene):
        _warn(message)
    check_meshes(scene, comps)


# ---------------------------------------------------------------------------- results
def _unit_cause(scene: Scene) -> str:
    warning = modulus_warning(scene["contact.youngs_MPa"])
    if warning:
        return f"; {warning}"
    return ""


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
