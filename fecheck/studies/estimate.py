"""The discretization error of an FE cross-check: the same surfaces solved at a coarser
level (and with ``verify`` a finer one), Richardson extrapolation and Roache's grid
convergence index (`fecheck.studies.gci`).

The coarse level is a uniform coarsening of the default mesh: every tibial surface with
its edges about twice as long (a meshed plateau disc at twice its element sizes; a scanned
sheet decimated to a quarter of its faces, thickness from the nearest default vertex; a
prepared sheet at twice ``fe.size_mm``) and half the levels through the thickness (at
least one). The femoral surfaces, the EF pose and the load control (whole joint, or each
compartment under its EF force) are the default run's; the EF runs once. The finer level
of ``verify`` splits each surface triangle in four once more (``fe.refine`` + 1) with
twice the levels. The ratio of two levels is the effective one of Celik et al. 2008,
r = (N_fine / N_coarse)^(1/3) with N the FE dofs (2 for an exact uniform halving).

Per compartment the quantities are the FE p_max at the vertices and averaged on the
default run's EF faces (a coarse level's pressure interpolated onto the default FE
surface first, so that every level averages over the same faces), the contact area, the
force share (split) and the centre of pressure (x, y, tibia frame). With two levels the
order 2 is assumed and the safety factor is 3; with three the order is observed and the
safety factor is 1.25 (Roache). The band is the finest level's value ± the GCI (an
absolute half-width: Fs·|f1 − f2| / (r^p − 1)).

Units: mm, N, MPa; times s.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from fecheck.errors import FecheckError
from fecheck.fe.bodies.scene_bodies import FEBody
from fecheck.fe.bodies.settings import FESettings
from fecheck.fe.solve.press import FELayer
from fecheck.model.results import RunResult
from fecheck.scene import Scene
from fecheck.studies.gci import gci

COARSENING = 2.0
"""Edge-length ratio of the coarse level's tibial surfaces to the default's."""
QUANTITIES = (("p_max_vertex_MPa", "p_max vertex", 3), ("p_max_face_MPa", "p_max faces", 3),
              ("area_mm2", "area mm²", 1), ("split", "force share", 4),
              ("cop_x_mm", "CoP x mm", 3), ("cop_y_mm", "CoP y mm", 3))
"""Estimated quantities: JSON key, table label, decimals."""


@dataclass(frozen=True)
class Band:
    """One quantity at the levels (finest first), the extrapolated value and the GCI band
    of the finest level: value ± half_width; NaN where undefined."""

    values: tuple[float, ...]
    extrapolated: float
    half_width: float
    order: float
    safety_factor: float

    @property
    def low(self) -> float:
        return self.values[0] - self.half_width

    @property
    def high(self) -> float:
        return self.values[0] + self.half_width

    def contains(self, value: float) -> bool:
        return bool(self.low <= value <= self.high)

    def as_dict(self) -> dict[str, Any]:
        def num(v):
            return float(v) if math.isfinite(v) else None

        return {"values": [num(v) for v in self.values], "extrapolated": num(self.extrapolated),
                "gci_half_width": num(self.half_width), "band": [num(self.low), num(self.high)],
                "order": num(self.order), "safety_factor": self.safety_factor}


def band(values: Sequence[float], ratios: Sequence[float]) -> Band:
    """The `Band` of `values` (finest first, 2 or 3) at refinement `ratios` (r21[, r32]):
    `fecheck.studies.gci.gci`, its GCI as an absolute half-width."""
    vals = tuple(float(v) for v in values)
    if not all(math.isfinite(v) for v in vals):
        return Band(vals, math.nan, math.nan, math.nan, 3.0 if len(vals) == 2 else 1.25)
    if vals[0] == vals[1]:
        return Band(vals, vals[0], 0.0, math.nan, 3.0 if len(vals) == 2 else 1.25)
    res = gci(vals, ratios)
    growth = ratios[0] ** res.order - 1.0
    half = (res.safety_factor * abs(vals[0] - vals[1]) / growth
            if math.isfinite(res.order) and growth > 0 else math.nan)
    return Band(vals, res.extrapolated, half, res.order, res.safety_factor)


@dataclass(frozen=True)
class Level:
    """One discretization level's answer: {compartment: {quantity: value}}, its FE dofs,
    surface faces per compartment, levels through the thickness and FE time (s)."""

    label: str
    values: dict[str, dict[str, float]]
    dofs: int
    faces: dict[str, int]
    levels: int
    seconds: float


@dataclass(frozen=True)
class ErrorEstimate:
    """The levels (finest first), their ratios and per compartment the `Band` of each
    quantity; `cost` is the extra levels' FE time over the default's."""

    levels: tuple[Level, ...]
    ratios: tuple[float, ...]
    bands: dict[str, dict[str, Band]]
    cost: float

    @property
    def extra_seconds(self) -> float:
        """FE time of the levels other than the default, s."""
        return sum(lv.seconds for lv in self.levels if lv.label != "default")

    def as_dict(self) -> dict[str, Any]:
        """The ``error_estimate`` of ``fecheck fe --json``: method, levels (label, dofs,
        surface faces per compartment, levels through the thickness, FE seconds), ratios,
        cost_over_default, extra_seconds and per compartment and quantity (`QUANTITIES`)
        the values (finest first), extrapolated, gci_half_width, band [low, high], order
        and safety_factor (null where undefined)."""
        return {"method": ("Richardson extrapolation and Roache's GCI (Celik et al. 2008): "
                           + ("2 levels, order 2 assumed, Fs 3" if len(self.levels) == 2
                              else "3 levels, observed order, Fs 1.25")),
                "levels": [{"label": lv.label, "dofs": lv.dofs, "surface_faces": lv.faces,
                            "levels_through_thickness": lv.levels, "fe_seconds": lv.seconds}
                           for lv in self.levels],
                "ratios": list(self.ratios), "cost_over_default": self.cost,
                "extra_seconds": self.extra_seconds,
                "compartments": {c: {q: b.as_dict() for q, b in bands.items()}
                                 for c, bands in self.bands.items()}}


# ---------------------------------------------------------------------- the levels
def _plane_uv(layer: FELayer) -> np.ndarray:
    """(3, 2) an orthonormal basis of the plane normal to `layer`'s mean surface normal."""
    s = layer.surface
    n = (s.face_normals * s.face_areas[:, None]).sum(axis=0)
    n /= np.linalg.norm(n)
    a = np.eye(3)[int(np.argmin(np.abs(n)))]
    u = np.cross(n, a)
    u /= np.linalg.norm(u)
    return np.column_stack([u, np.cross(n, u)])


def _on_default_faces(default: FELayer, layer: FELayer, pressure: np.ndarray) -> np.ndarray:
    """`layer`'s vertex `pressure` interpolated onto the `default` layer's FE vertices
    (both projected on the plane normal to the default surface), then averaged onto the
    default run's EF faces."""
    from fecheck.fe.knee.crosscheck import on_ef_faces
    from geometry.planar import plane_interpolation

    if layer is default:
        return on_ef_faces(default, pressure)
    uv = _plane_uv(default)
    to = plane_interpolation(layer.surface.points @ uv, layer.surface.faces,
                             default.surface.points @ uv)
    return on_ef_faces(default, to @ pressure)


def _values(metrics: dict, defaults: dict[str, FELayer], layers: dict[str, FELayer],
            pressures: dict[str, np.ndarray]) -> dict[str, dict[str, float]]:
    """{compartment: {quantity: value}} of one level from its SideMetrics."""
    total = sum(m.force_N for c, m in metrics.items() if layers[c].body.carrier == "T")
    out = {}
    for c, m in metrics.items():
        cop = (m.center_of_pressure_mm if m.center_of_pressure_mm is not None
               else (math.nan, math.nan))
        faces = _on_default_faces(defaults[c], layers[c], pressures[c])
        out[c] = {"p_max_vertex_MPa": m.max_pressure_MPa,
                  "p_max_face_MPa": float(np.nanmax(faces)),
                  "area_mm2": m.area_mm2,
                  "split": (m.force_N / total if total > 0 and layers[c].body.carrier == "T"
                            else math.nan),
                  "cop_x_mm": float(cop[0]), "cop_y_mm": float(cop[1])}
    return out


def default_level(check) -> Level:
    """The default run's `Level` (from its cross-check)."""
    comps = check.compartments
    layers = {c: chk.layer for c, chk in comps.items()}
    values = _values({c: chk.fe for c, chk in comps.items()}, layers, layers,
                     {c: chk.fe_pressure_MPa for c, chk in comps.items()})
    return Level("default", values, int(check.geometry["dofs"]),
                 {c: lay.surface.n_faces for c, lay in layers.items()},
                 check.settings.levels(check.material["nu"]), check.timing_s["fe"])


def coarse_body(scene: Scene, body: FEBody) -> FEBody:
    """`body` with its tibial surface's edges about `COARSENING` times longer: a meshed
    plateau disc at that multiple of its element sizes, a scanned sheet decimated to
    1/COARSENING² of its faces (thickness from the nearest default vertex)."""
    from scipy.spatial import cKDTree

    from fecheck.model.meshing import plateau_mesh
    from geometry.decimate import decimate

    if scene["model.kind"] == "sphere-plane":
        surface = plateau_mesh(scene, scene.knee, body.name, scale=COARSENING)
    else:
        surface = decimate(body.surface, max(4, round(body.surface.n_faces / COARSENING ** 2)))
    _, nearest = cKDTree(body.surface.points).query(surface.points)
    return dataclasses.replace(body, surface=surface, thickness_mm=body.thickness_mm[nearest])


def solve_level(scene: Scene, check, run: RunResult, label: str, settings: FESettings,
                bodies: Sequence[FEBody], log: Callable[[str], None]) -> Level:
    """The FE of `bodies` at `settings` from the EF `run`'s pose under the default run's
    load control, as a `Level` (its face-averaged p_max on the default run's EF faces)."""
    from fecheck.fe.knee.crosscheck import fe_level

    solved, dofs, seconds = fe_level(scene, bodies, run, settings, log, check.extra)
    metrics = {name: m for name, (_, m, _) in solved.items()}
    pressures = {name: p for name, (_, _, p) in solved.items()}
    by_name = {name: lay for name, (lay, _, _) in solved.items()}
    defaults = {c: chk.layer for c, chk in check.compartments.items()}
    return Level(label, _values(metrics, defaults, by_name, pressures), dofs,
                 {c: lay.surface.n_faces for c, lay in by_name.items()},
                 settings.levels(scene["contact.poisson"]), seconds)


def estimate(scene: Scene, check, run: RunResult, *, verify: bool = False,
             log: Callable[[str], None] | None = None) -> ErrorEstimate | None:
    """The `ErrorEstimate` of `check` (the default cross-check of `scene`, from the EF
    `run`): the coarse level, and with `verify` the finer one; None for a closed tibial
    solid (its Gmsh mesh has no coarse level here)."""
    say = log or (lambda message: None)
    layers = [chk.layer for chk in check.compartments.values()]
    if any(lay.body.solid is not None for lay in layers):
        return None
    settings = check.settings
    nu = scene["contact.poisson"]
    default = default_level(check)
    levels_ = settings.levels(nu)
    prepared = any(lay.to_ef is not None for lay in layers)
    coarse_settings = dataclasses.replace(settings, layers=max(1, round(levels_ / 2)),
                                          size_mm=COARSENING * settings.size_mm,
                                          prepare="on" if prepared else settings.prepare)
    bodies = [lay.body if prepared else coarse_body(scene, lay.body) for lay in layers]
    say("error estimate: the coarse level")
    coarse = solve_level(scene, check, run, "coarse", coarse_settings, bodies, say)
    found = [default, coarse]
    if verify:
        fine_settings = dataclasses.replace(settings, refine=settings.refine + 1,
                                            layers=2 * levels_)
        say("error estimate: the finer level (--verify)")
        try:
            found.insert(0, solve_level(scene, check, run, "fine", fine_settings,
                                        [lay.body for lay in layers], say))
        except FecheckError as err:
            raise FecheckError(f"--verify: its finer level (fe.refine {fine_settings.refine}, "
                               f"{fine_settings.layers} levels through the thickness) cannot "
                               f"be solved: {err}") from None
    ratios = tuple((a.dofs / b.dofs) ** (1 / 3)
                   for a, b in zip(found[:-1], found[1:], strict=True))
    bands = {c: {q: band([lv.values[c][q] for lv in found], ratios) for q, _, _ in QUANTITIES}
             for c in default.values}
    extra = sum(lv.seconds for lv in found if lv is not default)
    return ErrorEstimate(tuple(found), ratios, bands, extra / default.seconds)
