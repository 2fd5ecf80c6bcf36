"""Cartilage layers pressed by rigid femoral surfaces: the layers of a scene's bodies, the
rigid-body unknowns that drive them, and the load-controlled solve.

`build_layers` extrudes each body's tibial surface into a bonded layer, along normals
smoothed just enough that no prism inverts (a sheet that no smoothing extrudes, e.g. a
segmentation's, is prepared first with ``fe.prepare``: `prepared_body`); with
`fe.refine` the surface is split and the coarse layer's bottom interpolated onto it, so
the refined layer is the coarse one subdivided (same geometry, never inverted). A `Drive` is
the tibia's motion: the scene's free DOFs under its load, gravity and ligament springs
(`joint_drive`), or one compartment pushed along a given force (`push_drive`).
`solve_pressed` condenses the layers onto the surface vertices near the femoral surface,
solves, and widens that set while any vertex outside it penetrates.

Units: mm, N, MPa; surfaces in the tibia frame, femoral surfaces in the world.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from fecheck.errors import FecheckError
from fecheck.fe.bodies.budget import MAX_DOFS, guard_layers, prepared_for_size
from fecheck.fe.bodies.indenter import MeshIndenter, barycentric
from fecheck.fe.bodies.pose import FramePose
from fecheck.fe.bodies.scene_bodies import FEBody
from fecheck.fe.bodies.settings import FESettings
from fecheck.fe.bodies.solid import LayerSolid, layer_solid, release_freed_heap
from fecheck.fe.bodies.volume import SolidMesh, mesh_solid, parent_faces, solid_layers
from fecheck.fe.contact.candidates import Outcome, Round, widened
from fecheck.fe.solve.joint import (
    ContactLayer,
    JointContact,
    JointSolution,
    femoral_shift,
    rigid_bodies,
)
from fecheck.model.assembly import applied_load, free_indices
from fecheck.scene import Scene
from fecheck.statics.newton import geometric_tangent, pose, twist_basis
from geometry.extrude import ExtrusionError, densest, extrusion_directions, extrusion_offsets
from geometry.mesh import TriMesh
from geometry.planar import plane_interpolation
from geometry.prepare import PreparedSheet, prepare_sheet
from geometry.subdivide import subdivide
from geometry.terraces import TerraceFit

PENETRATION_TOL_MM = 1e-6
"""Largest overlap accepted at any surface vertex after the solve, mm."""
MAX_CANDIDATES = 6000
"""Most contact candidates per layer (the condensed compliance is dense: 6000² doubles
are 0.3 GB)."""
MAX_CANDIDATE_ROUNDS = 3
"""Times the contact candidates are widened when a vertex outside them penetrates."""
FEMUR_MARGIN_MM = 5.0
"""A prepared femoral surface covers its tibial sheet's outline plus this margin, mm."""
FEMUR_SMOOTH = 2.0
"""A prepared femoral surface is smoothed over this many times fe.smooth_mm: a condyle is
close to a quadric over a wider radius than a plateau (its bumps), and a voxelized
condyle keeps a flat terrace about 2·sqrt(2 R v) wide at its bottom (10 mm for a radius R
of 22 mm and voxels v of 0.6 mm). Measured on the 0.6 mm voxel knee at 1 mm elements,
face p_max against the smooth knee's own FE: +12 / +22 % at 1 (medial / lateral),
-3 / +6 % at 2; the smooth knee prepared moves by 0.2 % between the two."""
FEMUR_TERRACES = TerraceFit(terrace_weight=0.0)
"""The femoral surface's staircase fit (fe.terraces): a condyle's bottom is a cap ringed by
a riser every step, and those rings fix it (the 0.5 mm voxel knee's bottoms within 0.01
mm); pulled toward its flat bottom terrace it stays up to half a step off (+0.19 mm at a
terrace weight of 0.05)."""


@dataclass(frozen=True, eq=False)
class FELayer:
    """One compartment's FE layer: its body, the FE surface (the body's surface split
    `refine` times; `parent` maps each FE face to its EF face) and the assembled solid.
    With a prepared sheet (``fe.prepare``) the FE surface is the prepared sheet split
    `refine` times, `parent` maps to the prepared faces, `to_ef` (n_ef_faces, n_fe)
    interpolates FE vertex values onto the EF faces' centroids and `prepared_indenter`
    (a prepared femoral surface, or None) presses the layer instead of the body's."""

    body: FEBody
    surface: TriMesh
    parent: np.ndarray
    solid: LayerSolid
    smoothing_rounds: int
    to_ef: sp.csr_matrix | None = None
    prepared_indenter: MeshIndenter | None = None

    @property
    def indenter(self):
        """The femoral surface that presses the layer (world frame)."""
        return self.body.indenter if self.prepared_indenter is None else self.prepared_indenter


def _refined(coarse: TriMesh, thickness: np.ndarray, times: int, offsets: np.ndarray
             ) -> tuple[TriMesh, np.ndarray, np.ndarray, np.ndarray]:
    """The `coarse` surface split `times` times, its parent faces, and the thickness and
    extrusion offsets interpolated linearly onto the new vertices (so the refined layer
    is the coarse layer subdivided: it cannot invert where the coarse one does not)."""
    surface, parent = subdivide(coarse, times)
    values = np.column_stack([thickness, offsets])                        # (n, 4)
    out = np.empty((surface.n_points, 4))
    out[:coarse.n_points] = values
    if times:
        corners = coarse.points[coarse.faces[parent]]                     # (m, 3, 3)
        bary = barycentric(corners, surface.points[surface.faces])       # (m, 3, 3)
        inner = np.einsum("mkj,mjc->mkc", bary, values[coarse.faces[parent]])
        out[surface.faces.ravel()] = inner.reshape(-1, 4)
        out[:coarse.n_points] = values
    return surface, parent, out[:, 0], out[:, 1:]


def _mesh_solids(bodies: Sequence[FEBody], refine: int) -> dict[int, SolidMesh]:
    """Each distinct closed tibial solid of `bodies` meshed (`mesh_solid`), by identity."""
    solids = {id(b.solid): b.solid for b in bodies if b.solid is not None}
    return {key: mesh_solid(solid, refine) for key, solid in solids.items()}


def guard_bodies(bodies: Sequence[FEBody], settings: FESettings, poisson: float
                 ) -> dict[int, SolidMesh]:
    """The closed tibial solids of `bodies` tetrahedralized (`mesh_solid`, by the solid's
    identity), and the size guard of every layer and solid before anything is assembled
    (`fecheck.fe.bodies.budget.guard_layers`)."""
    meshed = _mesh_solids(bodies, settings.refine)
    guard_layers([b for b in bodies if b.solid is None], settings, poisson,
                 solid_dofs=_solid_dofs(bodies, meshed, settings))
    return meshed


def _solid_dofs(bodies: Sequence[FEBody], meshed: dict[int, SolidMesh],
                settings: FESettings) -> list[int]:
    """The dofs each meshed solid of `bodies` keeps (`SolidMesh.kept_dofs`)."""
    solids = {id(b.solid): b.solid for b in bodies if b.solid is not None}
    return [m.kept_dofs(solids[key], settings.solid_base_deg) for key, m in meshed.items()]


def build_layers(bodies: Sequence[FEBody], youngs_MPa: float, poisson: float,
                 settings: FESettings, log: Callable[[str], None],
                 meshed: dict[int, SolidMesh] | None = None) -> list[FELayer]:
    """Extrude and assemble every compartment's layer (the costly setup before contact):
    on the EF faces, or on prepared sheets (``fe.prepare``); a body with a closed tibial
    solid gets the solid instead (`solid_layer`; `meshed` from `guard_bodies`, else meshed
    here); refused before assembly when the sheets and solids chosen would not fit
    (`fecheck.fe.bodies.budget.guard_layers`)."""
    levels = settings.levels(poisson)
    if meshed is None:
        meshed = _mesh_solids(bodies, settings.refine)
    big = prepared_for_size(bodies, settings, levels)
    sheets = [None if body.solid is not None else _sheet(body, settings, levels, log, too_big)
              for body, too_big in zip(bodies, big, strict=True)]
    layered = [s[0] for s in sheets if s is not None]
    guard_layers(layered, settings, poisson, prepared=[False] * len(layered),
                 solid_dofs=_solid_dofs(bodies, meshed, settings))
    out = []
    built: dict[int, dict[str, LayerSolid]] = {}
    for body, chosen in zip(bodies, sheets, strict=True):
        if chosen is None:
            out.append(solid_layer(body, youngs_MPa, poisson, settings, log, built,
                                   meshed[id(body.solid)]))
            continue
        sheet, prepared, directions, rounds = chosen
        offsets = extrusion_offsets(sheet.surface, sheet.thickness_mm, directions)
        surface, parent, h, offsets = _refined(sheet.surface, sheet.thickness_mm,
                                               settings.refine, offsets)
        solid = layer_solid(surface, h, youngs_MPa, poisson, layers=levels,
                            ratio=settings.grading, offsets=offsets,
                            formulation=settings.formulation_for(poisson))
        release_freed_heap()
        log(f"{body.name}: layer of {len(solid.mesh.tets)} quadratic tetrahedra, "
            f"{solid.n_dofs} dofs, thickness {h.min():.2f}-{h.max():.2f} mm"
            + (f" (extruded along normals smoothed {rounds} times)" if rounds else ""))
        to_ef = None
        if prepared is not None:
            ef = body.surface
            to_ef = prepared.transfer(ef.points[ef.faces].mean(axis=1), surface)
        out.append(FELayer(body, surface, parent, solid, rounds, to_ef,
                           None if sheet.indenter is body.indenter else sheet.indenter))
    return out


def _sheet(body: FEBody, settings: FESettings, levels: int, log: Callable[[str], None],
           too_big: bool = False) -> tuple[FEBody, PreparedSheet | None, np.ndarray, int]:
    """The sheet the FE meshes for `body` (its own, or prepared: ``fe.prepare``, or
    `too_big` as it is: `fecheck.fe.bodies.budget.prepared_for_size`), the preparation (None for
    its own), its extrusion directions and smoothing rounds."""
    directions, rounds = None, 0
    if settings.prepare != "on" and not too_big:
        try:
            directions, rounds = extrusion_directions(
                body.surface, body.thickness_mm, layers=levels, ratio=settings.grading)
        except ExtrusionError as err:
            if settings.prepare == "off":
                raise _extrusion_failure(body, err, settings) from None
    if directions is not None:
        return body, None, directions, rounds
    if body.carrier != "T":
        raise FecheckError(f"the {body.name} sheet cannot be extruded into a cartilage layer "
                           "for the FE, and only tibial sheets are prepared (fe.prepare): try "
                           "fewer fe.layers or a thinner layer")
    sheet, prepared = prepared_body(body, settings.size_mm, settings.smooth_mm,
                                    settings.terraces == "on")
    stair = prepared.staircase
    log(f"{body.name}: the FE meshes a prepared sheet of {sheet.surface.n_faces} faces "
        f"of {settings.size_mm:g} mm ({prepared.trimmed_faces} rim or sliver faces "
        f"of {body.surface.n_faces} trimmed)"
        + (f"; the sheets as read would make more than {MAX_DOFS:,} FE dofs" if too_big
           else "")
        + ("" if stair is None else
        f"; voxel terraces of {stair.step:.3f} mm fitted (fe.terraces)"))
    try:
        directions, rounds = extrusion_directions(
            sheet.surface, sheet.thickness_mm, layers=levels, ratio=settings.grading)
    except ExtrusionError as err:
        raise _extrusion_failure(body, err, settings) from None
    return sheet, prepared, directions, rounds


def prepared_body(body: FEBody, size_mm: float, smooth_mm: float, terraces: bool = False
                  ) -> tuple[FEBody, PreparedSheet]:
    """`body` with its tibial sheet prepared (`geometry.prepare.prepare_sheet`) at
    `size_mm` with smoothing length `smooth_mm`, its thickness interpolated onto it, and
    a mesh femoral surface prepared at half that size, smoothed over `FEMUR_SMOOTH` times
    `smooth_mm`, over the sheet's outline (plus `FEMUR_MARGIN_MM`); the prepared sheet.
    With `terraces`, a tibial sheet cut from voxels is fitted as a staircase
    (`geometry.terraces`), and the femoral surface then too, at the tibia's step (the same
    segmentation), through its mid-riser contours alone (`FEMUR_TERRACES`)."""
    prepared = prepare_sheet(body.surface, size_mm, smooth_mm=smooth_mm,
                             name=f"{body.name} tibial sheet",
                             terraces=TerraceFit() if terraces else None)
    mesh = prepared.mesh
    # thickness: the EF vertex values, interpolated on the EF sheet projected on the plane
    ef = body.surface
    back = _plane_interpolation(prepared, ef, mesh.points)
    thickness = back @ body.thickness_mm
    indenter = body.indenter
    if isinstance(indenter, MeshIndenter):
        femur = indenter.mesh
        uv = prepared.plane(mesh.points)
        lo, hi = uv.min(axis=0) - FEMUR_MARGIN_MM, uv.max(axis=0) + FEMUR_MARGIN_MM
        centre = prepared.plane(femur.points[femur.faces].mean(axis=1))
        near = np.flatnonzero(((centre >= lo) & (centre <= hi)).all(axis=1))
        if len(near) < 3:
            raise FecheckError(f"the femoral surface does not cover the {body.name} tibial "
                               "sheet: check the femoral file and the frame")
        faces = femur.faces[near]
        used = np.unique(faces)
        remap = np.full(femur.n_points, -1)
        remap[used] = np.arange(len(used))
        crop = TriMesh(femur.points[used], remap[faces])
        fit = (None if prepared.staircase is None
               else replace(FEMUR_TERRACES, step_mm=prepared.staircase.step))
        indenter = MeshIndenter(prepare_sheet(crop, 0.5 * size_mm, axis=-prepared.axis,
                                              smooth_mm=FEMUR_SMOOTH * smooth_mm,
                                              terraces=fit,
                                              name=f"{body.name} femoral surface").mesh)
    return replace(body, surface=mesh, thickness_mm=thickness, indenter=indenter), prepared


def _plane_interpolation(prepared: PreparedSheet, mesh: TriMesh, points: np.ndarray
                         ) -> sp.csr_matrix:
    """(k, n) interpolation from `mesh`'s vertex values to `points` (k, 3), both projected
    on the prepared sheet's plane (faces of `mesh` folded or steep in that projection
    included: the nearest vertex decides where no face covers a point)."""
    return plane_interpolation(prepared.plane(mesh.points), mesh.faces, prepared.plane(points))


def _extrusion_failure(body: FEBody, err: ExtrusionError, settings: FESettings
                       ) -> FecheckError:
    """The extrusion error of one compartment with its name, place and the keys to try."""
    where = densest(err.where)
    keys = ("fe.prepare = 'on' (remesh the sheet), or a thinner layer" if settings.prepare == "off"
            else f"a larger fe.size_mm (now {settings.size_mm:g} mm), or a thinner layer")
    return FecheckError(f"the {body.name} tibial sheet cannot be extruded into a cartilage layer "
                        f"for the FE: {len(err.where)} faces invert, e.g. at ({where[0]:.1f}, "
                        f"{where[1]:.1f}, {where[2]:.1f}) mm (tibia frame); try {keys}")


def solid_layer(body: FEBody, youngs_MPa: float, poisson: float, settings: FESettings,
                log: Callable[[str], None], built: dict[int, dict[str, LayerSolid]],
                meshed: SolidMesh) -> FELayer:
    """The compartment's view of its closed tibial solid (`fecheck.fe.bodies.volume`; `meshed` by
    `mesh_solid`), assembled once per solid (`built`, by the solid's identity)."""
    key = id(body.solid)
    if key not in built:
        built[key] = solid_layers(body.solid, youngs_MPa, poisson,
                                  base_deg=settings.solid_base_deg, refine=settings.refine,
                                  formulation=settings.formulation_for(poisson), meshed=meshed)
        release_freed_heap()
        one = next(iter(built[key].values()))
        log(f"{body.solid.name}: closed solid of {len(one.mesh.tets)} quadratic tetrahedra, "
            f"{one.n_dofs} dofs, base fixed, walls free")
    solid = built[key][body.name]
    return FELayer(body, solid.surface, parent_faces(solid.surface, body.surface), solid, 0)


@dataclass(frozen=True)
class Drive:
    """The FE's rigid-body unknowns: the tibia's pose in the world (the femur's frame),
    X_WT, its twist basis, the generalised load and its stiffness as functions of the
    unknowns x, and the start x0."""

    pose: Callable[[np.ndarray], FramePose]
    basis: Callable[[np.ndarray], np.ndarray]
    load: Callable[[np.ndarray], np.ndarray]
    stiffness: Callable[[np.ndarray], np.ndarray] | None
    x0: np.ndarray
    full: Callable[[np.ndarray], np.ndarray]


def joint_drive(scene: Scene, q_ef: np.ndarray, springs: Sequence[Callable],
                flexion: tuple[float, np.ndarray] | None = None) -> Drive:
    """The scene's free DOFs under its load, gravity and ligament springs; `flexion` =
    (θx rad, Q (3, 3)) holds θx about Q's first column (`fecheck flex`) instead of
    dofs.flexion_deg about world x."""
    free = list(free_indices(scene))
    theta, base = flexion or (math.radians(scene["dofs.flexion_deg"]), None)
    parts = [applied_load(scene), *springs]

    def full(x: np.ndarray) -> np.ndarray:
        q = np.array(q_ef, dtype=float)
        q[free] = x
        return q

    def wrench(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q = full(x)
        rot, t = pose(q, theta, base)
        w, dw = np.zeros(6), np.zeros((6, 6))
        for part in parts:
            wp, dp = part(rot, t)
            w += wp
            dw += dp
        return q, w, dw

    def load(x: np.ndarray) -> np.ndarray:
        q, w, _ = wrench(x)
        return (twist_basis(q, theta, base).T @ w)[free]

    def stiffness(x: np.ndarray) -> np.ndarray:
        q, w, dw = wrench(x)
        b = twist_basis(q, theta, base)
        return (b.T @ dw @ b + geometric_tangent(q, w, theta, base))[np.ix_(free, free)]

    return Drive(lambda x: FramePose(*pose(full(x), theta, base), "W", "T"),
                  lambda x: twist_basis(full(x), theta, base)[:, free], load, stiffness,
                  np.asarray(q_ef, dtype=float)[free], full)


def push_drive(X_WT: FramePose, force_on_tibia: np.ndarray) -> Drive:
    """One compartment pushed from the tibia's pose X_WT along the line of the EF force
    on the tibia (world), with its magnitude: the unknown is the translation s (mm) into
    the femur."""
    magnitude = float(np.linalg.norm(force_on_tibia))
    u = -np.asarray(force_on_tibia, dtype=float) / magnitude
    twist = np.concatenate([u, np.zeros(3)])[:, None]
    return Drive(lambda x: FramePose(X_WT.rotation, X_WT.translation + x[0] * u, "W", "T"),
                 lambda x: twist,
                  lambda x: np.array([magnitude]), None, np.zeros(1),
                  lambda x: np.asarray(x, dtype=float))


def carried_by(layer: FELayer, bodies: dict[str, tuple[FramePose, np.ndarray]]
               ) -> FramePose:
    """The pose of the rigid body that carries `layer`, of `bodies`
    (`fecheck.fe.solve.joint.rigid_bodies`; a lone body carries every layer)."""
    if len(bodies) == 1:
        return next(iter(bodies.values()))[0]
    return bodies[layer.body.carrier][0]


def rigid_gaps(layer: FELayer, X_WT: FramePose, idx: np.ndarray | None = None) -> np.ndarray:
    """Rigid gaps (mm) along the normals of the layer's surface vertices (all, or `idx`)
    with the tibia at X_WT."""
    pts, nrm = layer.surface.points, layer.solid.normals
    if idx is not None:
        pts, nrm = pts[idx], nrm[idx]
    return layer.indenter.gap(X_WT.points(pts), X_WT.vectors(nrm)).gap_mm


def femoral_give(layer: FELayer, contact, X_WT: FramePose) -> np.ndarray:
    """(s,) the give of the deformable femoral layer `contact` pressed (0 for a rigid
    femoral surface) along the normal of every surface vertex of `layer` with the tibia
    at X_WT, mm: what it adds to their gaps."""
    if contact.femur is None:
        return np.zeros(layer.surface.n_points)
    nrm = X_WT.vectors(layer.solid.normals)
    _, face, weights = MeshIndenter(contact.femur.solid.surface).hits(
        X_WT.points(layer.surface.points), nrm)
    return femoral_shift(contact.femur, contact.femoral_u, face, weights, nrm)


def solve_pressed(layers: Sequence[FELayer], drive: Drive, margin_mm: float,
                           settings: FESettings, log: Callable[[str], None],
                           femoral: Callable | None = None
                           ) -> tuple[JointSolution, float, list[np.ndarray], float]:
    """Condense onto the vertices within `margin_mm` of the femoral surface at the start
    pose, solve, and widen the candidates while a vertex outside them penetrates;
    `femoral` ((layers, candidates, X_WT) → their femoral layers, or None: rigid femoral
    surfaces) builds deformable femoral layers under the candidates.

    Returns the solution, the condensation time (s), every layer's final gaps at all its
    surface vertices (mm) and the worst penetration found (mm, ≥ 0)."""
    placed = rigid_bodies(drive.pose, drive.basis, drive.x0)
    start = {i: np.flatnonzero(rigid_gaps(lay, carried_by(lay, placed)) < margin_mm)
             for i, lay in enumerate(layers)}
    condense = 0.0

    def solve(cands: dict[int, np.ndarray]) -> Round[JointSolution]:
        nonlocal condense, placed
        if any(len(c) == 0 for c in cands.values()):
            empty = [lay.body.name for i, lay in enumerate(layers) if not len(cands[i])]
            raise FecheckError(f"no {' or '.join(empty)} surface vertex lies within "
                               f"{margin_mm:.2f} mm of the femoral surface at the EF pose: "
                               "nothing for the FE contact to act on")
        most = max(len(c) for c in cands.values())
        if most > MAX_CANDIDATES:
            raise FecheckError(f"{most} surface vertices may touch "
                               f"(within {margin_mm:.2f} mm of the femoral surface), more "
                               f"than the {MAX_CANDIDATES} the dense contact solve takes: "
                               "coarsen the surface (fe.refine, scanned.decimate_faces) or "
                               "lower fe.candidate_gap_mm")
        listed = [cands[i] for i in range(len(layers))]
        femurs = ([None] * len(layers) if femoral is None
                  else femoral(layers, listed, carried_by(layers[0], placed)))
        joint = JointContact([ContactLayer(lay.body.name, lay.solid, lay.indenter, c,
                                           body=lay.body.carrier)
                              if f is None else
                              ContactLayer(lay.body.name, lay.solid,
                                           MeshIndenter(f.solid.surface), c, f,
                                           body=lay.body.carrier)
                              for lay, c, f in zip(layers, listed, femurs, strict=True)],
                             solver=settings.solver, log=log)
        condense += joint.seconds
        sol = joint.solve(drive.pose, drive.basis, drive.load, drive.x0,
                          stiffness=drive.stiffness)
        placed = rigid_bodies(drive.pose, drive.basis, sol.q)
        gaps = {i: rigid_gaps(lay, carried_by(lay, placed)) - lay.solid.normal_rows @ lc.u
                + femoral_give(lay, lc, carried_by(lay, placed))
                for i, (lay, lc) in enumerate(zip(layers, sol.layers, strict=True))}
        return Round(sol, gaps, max(float(max(0.0, -g.min())) for g in gaps.values()))

    def widening(result: Round[JointSolution]) -> None:
        log(f"a vertex outside the contact candidates penetrates by {result.worst:.2e} mm: "
            "widening the candidates")

    result, outcome, _ = widened(solve, start, margin_mm, MAX_CANDIDATE_ROUNDS + 1,
                                 PENETRATION_TOL_MM, widening)
    if outcome is Outcome.SETTLED:
        return (result.solution, condense, [result.gaps[i] for i in range(len(layers))],
                result.worst)
    raise FecheckError(f"the FE contact leaves a penetration of {result.worst:.2e} mm outside "
                       "its candidate vertices; raise fe.candidate_gap_mm")
