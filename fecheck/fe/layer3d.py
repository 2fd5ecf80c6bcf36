"""3D FE cross-check: a rigid sphere pressed on a cartilage layer bonded to rigid bone.

Quadratic tetrahedra (skfem ``ElementVector(ElementTetP2())``, small-strain isotropic
linear elasticity, degree-2 quadrature: exact for affine P2 stiffness) on a Gmsh layer
from `geometry.layer.cartilage_layer`, refined to ``size_mm`` under the contact and to
``edge_size_mm`` in a band around the expected contact edge, which bounds the area's
accuracy (baseline medial and lateral against the converged axisymmetric solution: 1.5 mm
everywhere, area +2.3% / +2.2%; with the default 0.9 mm band, +0.4% / +0.1%, +1.8% / +1.1%
at the EF loads of `fecheck fe`, +0.5% to +1.9% when the band's radius is shifted by up to
±0.2 mm: the margin to 2% is thin; p_max scatters by about ±1.5% from mesh to mesh at
1.5 mm; 1.15x to 1.6x the time). The bottom is fixed (bonded to rigid bone), the sides
free. The sphere's centre lies above the origin; the layer is centred under the point
where the sphere first touches its top.

Contact acts on the top vertices near the contact (within 1.3 × the Hertz contact
radius, an upper bound for a bonded layer). There the vertical displacement of each top
edge's midside node is tied to the mean of its end vertices (u = T ũ, K̃ = Tᵀ K T), so the
top is piecewise linear in w and each vertex force is the positive lumped load of the
pressure: p_i = λ_i / (tributary area). The solve is exact and load controlled
(`fecheck.fe.contact`); the area is the zero contour of the extrapolated p²
(`fecheck.fe.recovery.zero_contour_area`). Measured against the axisymmetric reference
(baseline medial, 323.7 N), the alternatives were worse: node-wise constraints on all
quadratic top nodes let corner nodes lift off inside the contact (their consistent loads
vanish under a uniform pressure; 2 µm gaps at the centre, p_max +1%, area -12% at 1 mm);
P2-P1 mortar constraints gave p_max +1.5%, area -4.6%; P1 multipliers on the four
sub-triangles of each facet, p_max +2%, area -5%. Tied vertices: p_max -0.1%.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from fecheck.errors import FecheckError
from fecheck.fe.contact import solve_contact
from fecheck.fe.recovery import contact_metrics, tributary_areas, zero_contour_area
from fecheck.fe.results import FEContactResult
from fecheck.fe.solid import edge_lookup, p2_elasticity
from fecheck.reference.closed_forms import hertz_sphere_on_plane

GAPS = ("reference", "deformed")

MIN_SIZE_MM = 0.2
"""Smallest element size under the contact: below it the 3D layer needs millions of dofs
(`estimate_cost`); the default 1.5 mm with its 0.9 mm edge band is within 2% of the
converged axisymmetric answer on the baseline compartments."""

DOFS_PER_SIZE_INTEGRAL = 15.9
DOFS_OFFSET = 3740.0
"""n_dofs ≈ 15.9·∫ dV / s(x)³ + 3740 over the layer, s(x) the element size field of
`geometry.layer.cartilage_layer` (`size_integral`): least squares on 18 meshes of the
baseline compartments (medial 323.71 N at 0.6-5 mm, lateral 456.67 N at 0.85-1.5 mm;
9,559-108,441 dofs), within 2.2% of every count from 0.6 to 2 mm (+5-8% at 3-5 mm)."""

SECONDS_PER_10K_DOFS = 1.74
SECONDS_EXPONENT = 2.17
"""CPU seconds of one 3D solve (meshing, assembly, CHOLMOD factorization, condensation
onto the contact candidates, active set) ≈ 1.74·(n_dofs / 1e4)^2.17, one core: fitted
on 11 of those meshes (10,351 dofs: 2.4 s … 108,441 dofs: 319 s), within 20%, 8% from
16,000 dofs up. The factorization and the condensation (one solve per contact
candidate) dominate. Wall time equals it on an idle core and grows when other processes
share the core (1.0-2.9x measured on a loaded machine)."""

MEGABYTES_PER_10K_DOFS = 133.0
MEMORY_EXPONENT = 1.06
"""Peak memory of one 3D solve above the process's own ≈ 133 MB·(n_dofs / 1e4)^1.06
(sparse P2 stiffness and quadrature data, the Cholesky factor, block solves): fitted on
the 18 meshes, within 6% (127 MB at 9,559 dofs, 1.76 GB at 108,441)."""


@dataclass(frozen=True)
class CostEstimate:
    """The estimated size and cost of one 3D layer solve (`estimate_cost`).

    n_dofs : degrees of freedom; seconds : CPU time, s; bytes : peak memory above the
    process's own, bytes; available_bytes : MemAvailable of /proc/meminfo (None if
    unknown)
    """

    size_mm: float
    n_dofs: int
    seconds: float
    bytes: float
    available_bytes: float | None

    def text(self, dofs: bool = True) -> str:
        """One line: dofs (if `dofs`), time and memory."""
        avail = ("" if self.available_bytes is None
                 else f" of {_gigabytes(self.available_bytes)} GB available")
        count = f"~{self.n_dofs:,} dofs, " if dofs else ""
        return (f"{count}~{_duration(self.seconds)} and ~{_gigabytes(self.bytes)} GB{avail} "
                "(fitted cost model)")


def _duration(seconds: float) -> str:
    for unit, length in (("days", 172800.0), ("h", 7200.0), ("min", 120.0)):
        if seconds >= length:
            return f"{seconds / (length / 2):,.0f} {unit}"
    return f"{seconds:.0f} s"


def _gigabytes(n_bytes: float) -> str:
    gb = n_bytes / 1e9
    return f"{gb:.2g}" if gb < 100 else f"{gb:,.0f}"


def available_memory_bytes() -> float | None:
    """MemAvailable of /proc/meminfo, bytes (None where there is no /proc/meminfo)."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except OSError:
        return None
    return None


def size_integral(size_mm: float, far_size_mm: float, half_extent_mm: float,
                  thickness_mm: float, refine_radius_mm: float, edge_radius_mm: float,
                  edge_size_mm: float | None, edge_band_mm: float = 1.0) -> float:
    """∫ dV / s(x)³ (dimensionless) over the layer, a disc of `half_extent_mm` and
    `thickness_mm`, for the size field of `geometry.layer.cartilage_layer`: `size_mm`
    within `refine_radius_mm` (3D distance) of the touch point, `edge_size_mm` within
    `edge_band_mm` of the edge circle of `edge_radius_mm`, growing linearly to
    `far_size_mm` over a further thickness + far size (band: band + far size)."""
    rho = np.linspace(0.0, half_extent_mm, 600)[:, None]
    z = np.linspace(0.0, thickness_mm, 120)[None, :]
    far = far_size_mm
    ramp = (np.hypot(rho, z) - refine_radius_mm) / (thickness_mm + far)
    s = np.clip(size_mm + (far - size_mm) * ramp, size_mm, far)
    if edge_size_mm is not None and edge_size_mm < size_mm:
        ramp = (np.hypot(rho - edge_radius_mm, z) - edge_band_mm) / (edge_band_mm + far)
        s = np.minimum(s, np.clip(edge_size_mm + (far - edge_size_mm) * ramp, edge_size_mm,
                                  far))
    inner = np.trapezoid(2.0 * np.pi * rho / s ** 3, z[0], axis=1)
    return float(np.trapezoid(inner, rho[:, 0]))


def estimate_cost(load_N: float, radius_mm: float, E_MPa: float, nu: float,
                  thickness_mm: float, size_mm: float, far_size_mm: float = 5.0,
                  half_extent_mm: float = 30.0, edge_size_mm: float | None = 0.9
                  ) -> CostEstimate:
    """dofs, CPU time and memory of `sphere_on_layer_3d` with these arguments, before
    any meshing: the refined zone and edge band from the Hertz contact radius, the
    counts from `size_integral`, the cost from the fits above."""
    a = math.sqrt(hertz_sphere_on_plane(load_N, radius_mm, E_MPa, nu).area_mm2 / math.pi)
    edge = None if edge_size_mm is None else min(edge_size_mm, size_mm)
    integral = size_integral(size_mm, far_size_mm, half_extent_mm, thickness_mm, 1.3 * a, a,
                             edge)
    n = DOFS_PER_SIZE_INTEGRAL * integral + DOFS_OFFSET
    return _cost(size_mm, n)


def _cost(size_mm: float, n_dofs: float) -> CostEstimate:
    """The cost model at `n_dofs` (see the fits above)."""
    seconds = SECONDS_PER_10K_DOFS * (n_dofs / 1e4) ** SECONDS_EXPONENT
    n_bytes = 1e6 * MEGABYTES_PER_10K_DOFS * (n_dofs / 1e4) ** MEMORY_EXPONENT
    return CostEstimate(size_mm, int(round(n_dofs)), seconds, n_bytes, available_memory_bytes())


def check_cost(estimate: CostEstimate) -> CostEstimate:
    """`FecheckError`, with the estimate, for a size below `MIN_SIZE_MM` or a solve whose
    memory exceeds the memory available; else the estimate."""
    if estimate.size_mm < MIN_SIZE_MM:
        raise FecheckError(f"3D FE element size {estimate.size_mm:g} mm is below the "
                           f"{MIN_SIZE_MM:g} mm floor: {estimate.text()} per compartment; "
                           f"use a size ≥ {MIN_SIZE_MM:g} mm (the default 1.5 mm with its "
                           "0.9 mm edge band is within 2% of the converged answer)")
    avail = estimate.available_bytes
    if avail is not None and estimate.bytes > avail:
        raise FecheckError(f"3D FE at {estimate.size_mm:g} mm needs more memory than is "
                           f"available: {estimate.text()}; use a larger size (fe.size_mm, "
                           "--size)")
    return estimate


def sphere_on_layer_3d(load_N: float, radius_mm: float, E_MPa: float, nu: float,
                       thickness_mm: float, *, footprint: str = "ellipse",
                       half_extent_mm: float = 30.0, size_mm: float = 1.0,
                       far_size_mm: float = 5.0, edge_size_mm: float | None = 0.9,
                       edge_band_mm: float = 1.0, edge_radius_mm: float | None = None,
                       sagittal_deg: float = 0.0,
                       frontal_deg: float = 0.0, top=None, gap: str = "reference",
                       solver: str = "cholmod", cache: bool = True,
                       log: Callable[[str], None] | None = None) -> FEContactResult:
    """Rigid sphere of radius R pressed vertically with `load_N` on a bonded layer.

    Parameters
    ----------
    load_N : vertical load, N
    radius_mm : sphere radius, mm
    E_MPa, nu : Young's modulus (MPa) and Poisson's ratio of the layer
    thickness_mm : layer thickness h (vertical), mm
    footprint : "ellipse" (a disc here) or "rectangle"; half_extent_mm its half size, mm
    size_mm : element size under the contact, mm; far_size_mm : size elsewhere, mm
    edge_size_mm : element size in a band around the expected contact edge, mm (used when
        smaller than ``size_mm``; None: no band). The area converges like the element size
        at the edge: 0.9 mm there with 1.5 mm inside gives both p_max and area within 2%
        of the converged axisymmetric solution (baseline compartments) at a fraction of
        the cost of 1 mm everywhere (`validation/fe_convergence.py`)
    edge_band_mm : half-width of that band (3D distance to the edge circle on the top), mm
    edge_radius_mm : radius of the edge circle around the touch point, mm; None: the
        contact radius of a coarse (0.25 mm) axisymmetric solve of the flat layer
    sagittal_deg, frontal_deg : plane-top tilt (see `geometry.layer`), degrees
    top : optional `Polynomial2D` top surface z = f(x, y) in the sphere's frame, mm
    gap : "reference" (vertical gap, reference configuration) or "deformed" (vertical gap
        from the displaced node position)
    solver : "cholmod" or "superlu"
    cache : reuse the cached Gmsh mesh
    log : called with a progress line before each step (meshing, assembly, factorization
        and contact) and with the counts and times after; None: silent

    Returns
    -------
    FEContactResult over the top vertices near the contact; ``pressure_MPa`` is the
    piecewise-linear contact pressure on ``faces`` (the top triangles there);
    ``gap_mm`` and ``nodal_force_N`` are given at all quadratic top nodes there.
    """

    from geometry.layer import cartilage_layer, top_height

    if gap not in GAPS:
        raise FecheckError(f"gap convention must be one of {GAPS}, got {gap!r}")
    if not (0 < size_mm <= far_size_mm):
        raise FecheckError(f"FE sizes must satisfy 0 < size ({size_mm}) <= far size "
                           f"({far_size_mm}) mm")
    say = log or (lambda message: None)
    check_cost(estimate_cost(load_N, radius_mm, E_MPa, nu, thickness_mm, size_mm,
                             far_size_mm, half_extent_mm, edge_size_mm))
    hertz = hertz_sphere_on_plane(load_N, radius_mm, E_MPa, nu)
    a_max = float(np.sqrt(hertz.area_mm2 / np.pi))
    if 1.3 * a_max + 2 * size_mm >= half_extent_mm:
        raise FecheckError(f"the contact (radius up to {a_max:.1f} mm) does not fit on a layer "
                           f"of half-extent {half_extent_mm} mm: enlarge it or lower the load")

    def z_top(xy: np.ndarray, pivot=(0.0, 0.0)) -> np.ndarray:
        return top_height(xy, pivot, top, sagittal_deg, frontal_deg)

    touch = _touch_point(radius_mm, z_top)
    edge_size = None if edge_size_mm is None else min(edge_size_mm, size_mm)
    edge_radius = None
    if edge_size is not None and edge_size < size_mm:
        edge_radius = (_expected_contact_radius(load_N, radius_mm, E_MPa, nu, thickness_mm,
                                                half_extent_mm)
                       if edge_radius_mm is None else float(edge_radius_mm))
    timing = {}
    t = time.perf_counter()
    say(f"meshing the layer ({size_mm:g} mm under the contact, {far_size_mm:g} mm away)")
    layer = cartilage_layer(footprint, center_xy=tuple(touch), half_x=half_extent_mm,
                            half_y=half_extent_mm, thickness=thickness_mm, top=top,
                            sagittal_deg=sagittal_deg, frontal_deg=frontal_deg,
                            size=far_size_mm, refine_point=tuple(touch), refine_size=size_mm,
                            refine_radius=1.3 * a_max, band_radius=edge_radius,
                            band_size=edge_size, band_width=edge_band_mm, cache=cache)
    timing["mesh"] = time.perf_counter() - t
    say(_mesh_line(layer, timing["mesh"]))
    t = time.perf_counter()
    mesh, basis, K = p2_elasticity(layer, E_MPa, nu)
    timing["assemble"] = time.perf_counter() - t
    t = time.perf_counter()
    nv = mesh.p.shape[1]
    find_edge = edge_lookup(mesh.edges, nv)
    bottom = layer.boundaries["bottom"]
    bottom_e = np.unique(np.concatenate([find_edge(bottom[:, i], bottom[:, j])
                                         for i, j in ((0, 1), (1, 2), (0, 2))]))
    fixed = np.concatenate([basis.nodal_dofs[:, np.unique(bottom)].ravel(),
                            basis.edge_dofs[:, bottom_e].ravel()])
    free = np.setdiff1d(np.arange(basis.N), fixed)
    index = np.full(basis.N, -1)
    index[free] = np.arange(len(free))

    # Contact surface: the top vertices near the contact. The vertical displacement of
    # each top edge's midside node there is tied to the mean of its end vertices, so the
    # top is piecewise linear in w and the vertex contact forces are the positive, lumped
    # loads of the pressure.
    tri = layer.boundaries["top"]
    top_v = np.unique(tri)
    cand_v = top_v[np.hypot(mesh.p[0, top_v] - touch[0], mesh.p[1, top_v] - touch[1])
                   <= 1.3 * a_max]
    is_cand = np.zeros(nv, dtype=bool)
    is_cand[cand_v] = True
    edges = np.unique(np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [0, 2]]]),
                              axis=1), axis=0)
    edges = edges[is_cand[edges[:, 0]] & is_cand[edges[:, 1]]]
    tied = index[basis.edge_dofs[2, find_edge(edges[:, 0], edges[:, 1])]]
    T, kept = _tie_matrix(len(free), tied, index[basis.nodal_dofs[2][edges]])
    red = np.full(len(free), -1)
    red[kept] = np.arange(len(kept))
    K_red = (T.T @ K[free][:, free] @ T).tocsc()
    cand = red[index[basis.nodal_dofs[2, cand_v]]]
    tangential = [red[index[basis.nodal_dofs[c, cand_v]]] for c in (0, 1)]
    xy = mesh.p[:2, cand_v].T
    z0 = mesh.p[2, cand_v]
    R = radius_mm
    # The layer's plane top pivots on the touch point; the sphere's centre sits so that its
    # vertical gap to the top is zero there.
    zc = np.sqrt(R * R - touch @ touch) + z_top(touch[None, :], tuple(touch))[0]

    def gap0(shift: np.ndarray | None) -> np.ndarray:
        pxy = xy if shift is None else xy + shift
        r2 = np.sum(pxy * pxy, axis=1)
        if np.any(r2 >= R * R):
            raise FecheckError("contact candidates lie beyond the sphere's radius")
        return zc - np.sqrt(R * R - r2) - z0

    timing["setup"] = time.perf_counter() - t
    say(f"assembled {K_red.shape[0]:,} free dofs in {timing['assemble']:.1f} s; factorizing "
        f"({solver}), condensing onto {len(cand_v)} contact candidates, contact iterations")
    sol = solve_contact(K_red, cand, gap0, load_N, hertz.depth_mm, tangential=tangential,
                        solver=solver, deformed_gap=(gap == "deformed"))
    timing.update(sol.timing_s)
    say(f"factorization {timing['factorize']:.1f} s, condensation {timing['condense']:.1f} "
        f"s, {sol.iterations} active-set iterations ({timing['active_set']:.2f} s)")
    pos = np.full(nv, -1)
    pos[cand_v] = np.arange(len(cand_v))
    faces = pos[tri]
    faces = faces[np.all(faces >= 0, axis=1)]
    pts = np.column_stack([xy, z0])
    tributary = tributary_areas(pts, faces)
    pressure = np.divide(sol.force_N, tributary, out=np.zeros_like(sol.force_N),
                         where=tributary > 0)
    area = zero_contour_area(pts, faces, pressure, sol.active)
    metrics = contact_metrics(pressure, sol.force_N, area, sol.delta_mm)
    return FEContactResult(metrics=metrics, points=pts, pressure_MPa=pressure,
                           gap0_mm=gap0(None), nodal_force_N=sol.force_N, gap_mm=sol.gap_mm,
                           active=sol.active, faces=faces, n_dofs=len(kept),
                           n_elements=mesh.t.shape[1], element="tet P2",
                           size_under_contact_mm=_size_under(layer.points, tri, touch,
                                                             np.sqrt(area / np.pi)),
                           iterations=sol.iterations, timing_s=timing,
                           max_penetration_mm=float(max(0.0, -sol.gap_mm.min())),
                           node_area_mm2=float(tributary[sol.active].sum()))


def _mesh_line(layer, seconds: float) -> str:
    """Progress line after meshing: element and dof counts, the cost they imply."""
    tets = layer.tets[:, :4]
    n_tets = len(tets)
    a, b = tets[:, [0, 0, 0, 1, 1, 2]].ravel(), tets[:, [1, 2, 3, 2, 3, 3]].ravel()
    lo, hi = np.minimum(a, b).astype(np.int64), np.maximum(a, b)
    edges = len(np.unique(lo * len(layer.points) + hi))
    n_dofs = 3 * (len(np.unique(tets)) + edges)     # P2: a node per vertex and per edge
    return (f"meshed in {seconds:.1f} s: {n_tets:,} tets (P2), {n_dofs:,} dofs; expect "
            f"{_cost(0.0, n_dofs).text(dofs=False)}")


def _expected_contact_radius(load_N: float, radius_mm: float, E_MPa: float, nu: float,
                             thickness_mm: float, layer_radius_mm: float) -> float:
    """Contact radius of the flat layer from a coarse axisymmetric solve (0.25 mm), mm."""
    from fecheck.fe.axisym import axisym_sphere_on_layer

    res = axisym_sphere_on_layer(load_N, radius_mm, E_MPa, nu, thickness_mm,
                                 layer_radius_mm=layer_radius_mm, size_mm=0.25)
    return float(np.sqrt(res.metrics.area_mm2 / np.pi))


def _tie_matrix(n: int, tied: np.ndarray, masters: np.ndarray):
    """T (n × n_kept) with u = T u_kept: each tied dof is the mean of its two masters."""
    import scipy.sparse as sp

    keep = np.ones(n, dtype=bool)
    keep[tied] = False
    kept = np.flatnonzero(keep)
    col = np.full(n, -1)
    col[kept] = np.arange(len(kept))
    rows = np.concatenate([kept, tied, tied])
    cols = np.concatenate([col[kept], col[masters[:, 0]], col[masters[:, 1]]])
    vals = np.concatenate([np.ones(len(kept)), np.full(2 * len(tied), 0.5)])
    return sp.csr_matrix((vals, (rows, cols)), shape=(n, len(kept))), kept


def _touch_point(radius_mm: float, top_height) -> np.ndarray:
    """(x, y) where a sphere centred above the origin first touches the top, mm."""
    from scipy.optimize import minimize

    R = radius_mm

    def gap(xy: np.ndarray) -> float:
        r2 = min(float(xy @ xy), 0.81 * R * R)
        return float(R - np.sqrt(R * R - r2) - top_height(xy[None, :])[0])

    res = minimize(gap, np.zeros(2), method="Nelder-Mead",
                   options={"xatol": 1e-10, "fatol": 1e-14, "maxiter": 2000})
    return res.x


def _size_under(points: np.ndarray, tri: np.ndarray, center: np.ndarray,
                radius: float) -> float:
    """Median edge length of the top triangles inside the contact, mm."""
    c = points[tri].mean(axis=1)
    inside = np.hypot(c[:, 0] - center[0], c[:, 1] - center[1]) <= max(radius, 1e-9)
    t = tri[inside] if inside.any() else tri
    e = np.concatenate([points[t[:, i]] - points[t[:, j]] for i, j in ((0, 1), (1, 2), (0, 2))])
    return float(np.median(np.linalg.norm(e, axis=1)))
