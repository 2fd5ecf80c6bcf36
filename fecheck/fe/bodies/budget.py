"""Size guard of the FE cross-check: the dofs and memory of the extruded P2 layers, known
from the tibial surfaces, ``fe.refine`` and the levels before anything is assembled.

Counts are exact. Splitting a surface of n vertices, E edges and F triangles in four
gives n + E vertices, 2E + 3F edges and 4F triangles. Extruding it by L levels of prisms,
each split into 3 tetrahedra along its side diagonals (no inner edge), gives 3·F·L
tetrahedra, n(L + 1) vertices and E(L + 1) + nL + EL edges: (2L + 1)(n + E) quadratic
nodes. The bottom's n + E nodes are fixed and one dof of each top edge's midside node is
tied, so the layer keeps ``6L(n + E) − E`` dofs (`fecheck.fe.bodies.solid.layer_solid`).

Memory is the measured peak of assembly and factorization (`BYTES_PER_DOF`): the
Cholesky factor fills in faster than the dofs grow, so the bytes per dof grow with them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from fecheck.fe.bodies.scene_bodies import FEBody
from fecheck.fe.bodies.settings import FESettings
from geometry import budget
from geometry.mesh import TriMesh

MAX_DOFS = 500_000
"""Most FE dofs (all layers) solved without ``--force``: minutes here, and the finest
level of validation/fe_scanned_convergence.py (the full femur-tibia knee with 4 levels,
407k dofs) stays below it."""
FIXED_BYTES = 0.2e9
"""Memory of the FE build that does not grow with the dofs (the assembly's chunk of
element matrices), bytes."""
BYTES_PER_DOF = 11_000.0
"""Peak memory per dof at `REFERENCE_DOFS` dofs, beyond `FIXED_BYTES`, bytes."""
REFERENCE_DOFS = 100_000
FILL_EXPONENT = 0.5
"""Growth of the bytes per dof: ∝ (dofs / `REFERENCE_DOFS`) ** this. With the two
constants above it bounds the peak RSS of layer assembly and factorization measured on
a disc of radius 20 mm, 6 mm thick (CHOLMOD, METIS): 0.22 GB at 17.7k dofs (estimate
0.28), 0.66 at 67.7k (0.81), 1.28 at 104k (1.37), 3.23 at 210k (3.55)."""
SOLID_GROWTH = 6.0
"""Growth of a closed solid's dofs per ``fe.refine`` level (its surface triangles split in
four; Gmsh's interior sizes follow the surface's only in part): measured 5.9 on the
generated insert of validation/implant_pair.py (2 mm top triangles: 26.9k to 158k P2 dofs,
5,175 to 33,516 tetrahedra)."""
EF_NARROWS_FROM = 0.495
"""Poisson's ratio from which a refusal explains that the EF's contact sizes the plateau
mesh: the EF's column stiffness grows as 1/(1 - 2ν) and its contact radius as its -1/4
power (5.9 times narrower at ν 0.4999 than at 0.3), while the FE's contact narrows by 8 %
(baseline medial, axisymmetric FE: 6.0 to 5.5 mm)."""


def surface_counts(surface: TriMesh, refine: int) -> tuple[int, int, int]:
    """Vertices, edges and triangles of `surface` split in four `refine` times."""
    faces = surface.faces
    edges = np.unique(np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
    n, e, f = surface.n_points, len(edges), len(faces)
    for _ in range(refine):
        n, e, f = n + e, 2 * e + 3 * f, 4 * f
    return n, e, f


def layer_dofs(surface: TriMesh, refine: int, levels: int) -> int:
    """Exact kept dofs of the layer extruded from `surface` (module docstring)."""
    n, e, _ = surface_counts(surface, refine)
    return 6 * levels * (n + e) - e


def prepared_counts(surface: TriMesh, size_mm: float) -> tuple[int, int]:
    """Vertices and edges of `surface` prepared at `size_mm` (`geometry.prepare`: a
    lattice of equilateral triangles over the sheet's area projected on its mean normal;
    a triangulation of F triangles has about F/2 vertices and 3F/2 edges)."""
    a = (surface.face_normals * surface.face_areas[:, None]).sum(axis=0)
    area = float(np.linalg.norm(a))                    # the projected area, mm²
    f = area / (np.sqrt(3.0) / 4.0 * size_mm**2)
    return int(np.ceil(0.5 * f)), int(np.ceil(1.5 * f))


def sheet_dofs(surface: TriMesh, settings: FESettings, levels: int,
               prepared: bool | None) -> int:
    """Layer dofs of one tibial sheet: as it is (`prepared` False), prepared at
    ``fe.size_mm`` (True), or the smaller of the two (None: ``fe.prepare = 'auto'``
    prepares only a sheet that does not extrude, which is not known before trying)."""
    raw = layer_dofs(surface, settings.refine, levels)
    if prepared is False:
        return raw
    n, e = prepared_counts(surface, settings.size_mm)
    f = 2 * n
    for _ in range(settings.refine):
        n, e, f = n + e, 2 * e + 3 * f, 4 * f
    ready = 6 * levels * (n + e) - e
    return ready if prepared else min(raw, ready)


def prepared_for_size(bodies: Sequence[FEBody], settings: FESettings, levels: int
                      ) -> list[bool]:
    """Per body, whether ``fe.prepare = 'auto'`` prepares its mesh sheet for size alone: the
    layers of all the sheets as they are would make more than `MAX_DOFS` dofs, and this
    sheet prepared at ``fe.size_mm`` makes fewer than as it is (known from the counts, so
    decided before the EF run); never a sheet on another body than the tibia (the
    patella's: a prepared sheet and its femoral surface are cut for a tibial one)."""
    mesh = [settings.prepare == "auto" and b.tibial_surface.startswith("mesh:")
            and b.carrier == "T" for b in bodies]
    raw = [layer_dofs(b.surface, settings.refine, levels) for b in bodies]
    if not any(mesh) or sum(raw) <= MAX_DOFS:
        return [False] * len(bodies)
    return [m and sheet_dofs(b.surface, settings, levels, True) < r
            for b, m, r in zip(bodies, mesh, raw, strict=True)]


def _prepared_flags(bodies: Sequence[FEBody], settings: FESettings, levels: int
                    ) -> list[bool | None]:
    """Whether the FE meshes each body's sheet prepared (``fe.prepare``): 'auto' prepares a
    mesh sheet too large as it is (`prepared_for_size`) or that does not extrude (None:
    not known before trying); generated plateaus always extrude."""
    if settings.prepare in ("on", "off"):
        return [settings.prepare == "on"] * len(bodies)
    return [True if big else (None if b.tibial_surface.startswith("mesh:")
                              and b.carrier == "T" else False)
            for b, big in zip(bodies, prepared_for_size(bodies, settings, levels), strict=True)]


def fe_estimate(bodies: Sequence[FEBody], refine: int, levels: int,
                settings: FESettings | None = None,
                prepared: Sequence[bool | None] | None = None) -> budget.Estimate:
    """The dofs of every compartment's layer, their memory and `MAX_DOFS`. Every layer
    keeps its own factor, so the memory is summed over the layers (the full femur-tibia
    knee, two layers of 97k and 100k dofs: estimate 2.4 GB, measured peak RSS 1.7 GB of
    the whole `fecheck fe` run). With `settings`, each sheet is counted as the FE will
    mesh it (`sheet_dofs`, `prepared` per body; default from ``fe.prepare``)."""
    if settings is None:
        counts = [layer_dofs(b.surface, refine, levels) for b in bodies]
    else:
        s = replace(settings, refine=refine)
        flags = prepared if prepared is not None else _prepared_flags(bodies, s, levels)
        counts = [sheet_dofs(b.surface, s, levels, p)
                  for b, p in zip(bodies, flags, strict=True)]
    dofs = np.array(counts, dtype=float)
    factors = dofs * BYTES_PER_DOF * (dofs / REFERENCE_DOFS) ** FILL_EXPONENT
    return budget.Estimate("FE dofs", float(dofs.sum()), FIXED_BYTES + float(factors.sum()),
                           MAX_DOFS)


def guard_layers(bodies: Sequence[FEBody], settings: FESettings, poisson: float,
                 prepared: Sequence[bool | None] | None = None,
                 solid_dofs: Sequence[int] = ()) -> None:
    """`geometry.budget.guard` of the FE layers before they are built (each sheet counted
    as `fe_estimate` says) and of the closed tibial solids tetrahedralized but not yet
    assembled (`solid_dofs`, their P2 dofs at ``fe.refine``; at another refine level
    `SOLID_GROWTH` per level): the remedy lowers ``fe.refine`` (``--refine``)."""
    levels = settings.levels(poisson)

    def estimate(refine: int) -> budget.Estimate:
        layers = fe_estimate(bodies, refine, levels, settings, prepared)
        solids = [d * SOLID_GROWTH ** (refine - settings.refine) for d in solid_dofs]
        dofs = np.array(solids, dtype=float)
        extra = float((dofs * BYTES_PER_DOF * (dofs / REFERENCE_DOFS) ** FILL_EXPONENT).sum())
        return replace(layers, count=layers.count + float(dofs.sum()),
                       bytes=layers.bytes + extra)

    otherwise = ("lower fe.layers or coarsen the surfaces (scanned.decimate_faces, "
                 "mesh.plateau_refine_mm)")
    if poisson >= EF_NARROWS_FROM and not any(b.tibial_surface.startswith("mesh:") for b in bodies):
        otherwise += (f"; at contact.poisson {poisson:g} the EF's contact, which the plateau's "
                      "automatic refinement follows, is several times narrower than the "
                      "FE's: set mesh.plateau_refine_mm = 0.4 (the size ν 0.49 gets; the FE's "
                      "p_max and area within 1 % there)")
    budget.guard("fecheck fe", "fe.refine", settings.refine, lambda r: estimate(int(r)),
                 unit="", level=True,
                 otherwise=otherwise)
