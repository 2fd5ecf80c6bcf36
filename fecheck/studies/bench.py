"""Run time against error: every way to get contact pressure and area, on one problem.

The problem is each baseline compartment alone (thesis Table 5.1 loads): a rigid condyle
sphere (medial R 25.5 mm, lateral 31.8 mm) pressed on a flat cartilage layer (E 20 MPa, ν 0.3,
h 6 mm) by its thesis Table 5.1 force (323.71 N, 456.67 N). Every method solves it under
load control (Newton on the approach δ until the normal force is F to 1e-8) and reports
p_max and the contact area. Methods and their references:

* ``ef-clipped``, ``ef-whole-face``: EF law, icosphere slave (levels 2-7) on an analytic
  plane, exact clipping or the thesis's whole-face counting; against the exact EF
  formula at the same force (`fecheck.reference.closed_forms.ef_sphere_plane`).
* ``ef-analytic-master``: EF law, analytic sphere master over a meshed plateau disc
  refined under the contact (element size 1.4 … 0.175 mm); same reference.
* ``thesis-fcl``: the thesis's stack for the same EF problem: python-fcl per-face
  contacts (slave icosphere BVH against a convex plateau box, GJK/EPA), whole faces at
  their deepest point; same reference.
* ``hertz-mesh``: Hertz law from the icosphere's maximum depth; against Hertz's formula.
  ``hertz-formula``: the formula itself (its own reference: error 0).
* ``fe-3d`` (element sizes 5 … 0.5 mm under the contact: the general path of `fecheck
  fe` on the flat layer, `fecheck.fe.reference.sphere_layer`) and ``fe-axisym``: the scikit-fem
  layer solves of `fecheck.fe`; against the axisymmetric FE at a finer size than any row
  (the converged FE).
* ``scene-ef-clipped``, ``scene-thesis-fcl``: the whole baseline scene (both
  compartments, 2-DOF Newton, `fecheck.model.run.run_scene`) at 5,120 faces per condyle, our
  way and the thesis's (fcl, whole faces); the compartment farthest from the exact EF
  answer at its solved force is reported.

Every row also carries ``error_vs_fe``, its error against the converged FE, which is
what a user wanting the physical answer cares about. Times are medians over repeats of
pair construction + solve (meshes come from the cache, built once before timing).
Errors are relative: ``error`` = max(|Δp_max|/p_max, |ΔA|/A).

Scaling: time per contact evaluation (candidates reused, at the solved pose) against
the faces of the slave, (a) refining the icosphere (faces near the contact grow with
all faces) and (b) padding a level-4 icosphere with far copies of itself (faces near
the contact fixed): the time must follow the near faces, not all faces. Each time is
the best of its evaluations, all meshes timed in the same interleaved rounds, so a busy
spell on a shared machine cannot tilt one slope.
"""

from __future__ import annotations

import math
import os
import platform
import statistics
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np

from fecheck.laws import ef_stiffness
from fecheck.scene.constants import COMPARTMENTS
from fecheck.statics.load_control import load_controlled

E_MPA, NU, H_MM = 20.0, 0.3, 6.0
BASELINE_COMPARTMENTS = {"medial": (25.5, 323.71), "lateral": (31.8, 456.67)}
"""Compartment → (condyle radius mm, thesis Table 5.1 force N)."""
THESIS_LEVEL = 4           # 5,120 faces per sphere, the thesis's resolution
ONE_PERCENT = 0.01
EXACT = 1e-12              # errors below this are round-off (Hertz under load control)


@dataclass(frozen=True)
class BenchConfig:
    """What one bench run covers (`quick` trims levels, sizes and repeats)."""

    levels: tuple[int, ...] = (2, 3, 4, 5, 6, 7)
    thesis_levels: tuple[int, ...] = (2, 3, 4, 5)
    hertz_levels: tuple[int, ...] = (2, 3, 4, 5)
    plateau_sizes_mm: tuple[float, ...] = (1.4, 0.7, 0.35, 0.175)
    fe3d_sizes_mm: tuple[float, ...] = (5.0, 2.0, 1.0, 0.5)
    axisym_sizes_mm: tuple[float, ...] = (0.5, 0.2, 0.1, 0.05)
    fe_reference_size_mm: float = 0.025
    compartments: tuple[str, ...] = COMPARTMENTS
    fe_compartments: tuple[str, ...] = ("medial",)
    repeats: int = 7
    slow_s: float = 5.0
    scaling_levels: tuple[int, ...] = (3, 4, 5, 6, 7)
    scaling_copies: tuple[int, ...] = (1, 4, 16, 64)
    scaling_evaluations: int = 20

    @classmethod
    def quick(cls) -> BenchConfig:
        return cls(levels=(2, 3, 4, 5), thesis_levels=(3, 4), hertz_levels=(3, 4),
                   plateau_sizes_mm=(1.4, 0.7), fe3d_sizes_mm=(5.0, 2.0),
                   axisym_sizes_mm=(0.5, 0.2, 0.1), fe_reference_size_mm=0.05,
                   repeats=5, slow_s=0.5,
                   scaling_levels=(3, 4, 5, 6), scaling_copies=(1, 4, 16),
                   scaling_evaluations=10)


@dataclass(frozen=True)
class Row:
    """One method at one resolution on one compartment (times s, errors relative)."""

    method: str
    compartment: str
    resolution: str
    n_faces: int
    time_s: float
    time_min_s: float
    time_max_s: float
    repeats: int
    max_pressure_MPa: float
    area_mm2: float
    error_pmax: float
    error_area: float
    error: float
    error_vs_fe: float
    error_vs_fe_pmax: float
    error_vs_fe_area: float
    iterations: int = 0


@dataclass(frozen=True)
class Outcome:
    """p_max (MPa), area (mm²), Newton iterations and the face count of one solve; a
    solve that picks its own compartment gives its references (p_max, area) too."""

    max_pressure_MPa: float
    area_mm2: float
    iterations: int
    n_faces: int
    reference: tuple[float, float] | None = None
    fe_reference: tuple[float, float] | None = None


def machine() -> dict:
    """The machine the numbers were measured on."""
    import scipy

    return {"platform": platform.platform(), "processor": platform.processor() or
            platform.machine(), "cpus": os.cpu_count(), "python": platform.python_version(),
            "numpy": np.__version__, "scipy": scipy.__version__,
            "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS")}


def _rel(value: float, ref: float) -> float:
    return abs(value - ref) / abs(ref)


def baseline_ef_stiffness() -> float:
    """The baseline layer's EF stiffness (E 20 MPa, ν 0.3, h 6 mm), N/mm³."""
    return ef_stiffness(E_MPA, NU, H_MM)


def ef_start_depth(radius_mm: float, force_N: float) -> float:
    """A start for the load-controlled approach (mm): the EF cap depth without its d/3."""
    return math.sqrt(force_N / (baseline_ef_stiffness() * math.pi * radius_mm))


def _icosphere(radius_mm: float, level: int):
    from geometry.icosphere import icosphere

    return icosphere(radius_mm, level, (0.0, 0.0, radius_mm))


def ef_on_icosphere(radius_mm: float, force_N: float, level: int, area: str
                    ) -> Callable[[], Outcome]:
    """EF solve of an icosphere slave on the analytic plane z = 0 (mesh built now)."""
    from fecheck.contact import ContactPair, Plane
    from fecheck.laws import elastic_foundation

    slave, k = _icosphere(radius_mm, level), baseline_ef_stiffness()
    plane = Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0])

    def run() -> Outcome:
        pair = ContactPair(slave, plane, area=area)
        res, _, it = load_controlled(pair, lambda s: elastic_foundation(s, k),
                                     np.array([0.0, 0.0, -1.0]), force_N,
                                     ef_start_depth(radius_mm, force_N))
        return Outcome(res.max_pressure, res.area, it, slave.n_faces)

    return run


def ef_analytic_master(radius_mm: float, force_N: float, size_mm: float
                       ) -> Callable[[], Outcome]:
    """EF solve of a meshed plateau disc (refined to `size_mm`) under an analytic sphere."""
    from fecheck.contact import ContactPair, Sphere
    from fecheck.laws import elastic_foundation
    from geometry.plateau import plane_patch

    a = math.sqrt(2 * radius_mm * 1.2 * ef_start_depth(radius_mm, force_N))
    slave = plane_patch((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), radius=a + 5.0,
                        size=max(2.0, size_mm), refine_point=(0.0, 0.0, 0.0),
                        refine_size=size_mm, refine_radius=a + 1.0)
    sphere, k = Sphere((0.0, 0.0, radius_mm), radius_mm), baseline_ef_stiffness()

    def run() -> Outcome:
        pair = ContactPair(slave, sphere)
        res, _, it = load_controlled(pair, lambda s: elastic_foundation(s, k),
                                     np.array([0.0, 0.0, 1.0]), force_N,
                                     ef_start_depth(radius_mm, force_N))
        return Outcome(res.max_pressure, res.area, it, slave.n_faces)

    return run


def thesis_fcl(radius_mm: float, force_N: float, level: int) -> Callable[[], Outcome]:
    """The thesis's stack: fcl per-face contacts against a convex plateau box, whole faces."""
    from fecheck.contact import ContactPair
    from fecheck.laws import elastic_foundation
    from geometry.plateau import plateau_box

    slave, k = _icosphere(radius_mm, level), baseline_ef_stiffness()
    box = plateau_box((0.0, 0.0, 0.0), 4 * radius_mm, 4 * radius_mm, 10.0)

    def run() -> Outcome:
        pair = ContactPair(slave, box, method="fcl", area="whole-face")
        res, _, it = load_controlled(pair, lambda s: elastic_foundation(s, k),
                                     np.array([0.0, 0.0, -1.0]), force_N,
                                     ef_start_depth(radius_mm, force_N))
        return Outcome(res.max_pressure, res.area, it, slave.n_faces)

    return run


def hertz_on_icosphere(radius_mm: float, force_N: float, level: int) -> Callable[[], Outcome]:
    """Hertz law (from the maximum depth) of an icosphere slave on the plane z = 0."""
    from fecheck.contact import ContactPair, Plane
    from fecheck.laws import hertz, hertz_modulus
    from fecheck.reference.closed_forms import hertz_approach

    slave, e_star = _icosphere(radius_mm, level), hertz_modulus(E_MPA, NU)
    plane = Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    start = hertz_approach(force_N, radius_mm, e_star)

    def run() -> Outcome:
        pair = ContactPair(slave, plane)
        res, _, it = load_controlled(pair, lambda s: hertz(s, radius_mm, e_star),
                                     np.array([0.0, 0.0, -1.0]), force_N, start)
        return Outcome(res.max_pressure, res.area, it, slave.n_faces)

    return run


def hertz_formula(radius_mm: float, force_N: float) -> Callable[[], Outcome]:
    """Hertz's closed form (p0, πa²) at the force (no mesh, no solve)."""
    from fecheck.reference.closed_forms import hertz_sphere_on_plane

    def run() -> Outcome:
        m = hertz_sphere_on_plane(force_N, radius_mm, E_MPA, NU)
        return Outcome(m.max_pressure_MPa, m.area_mm2, 0, 0)

    return run


def fe_3d(radius_mm: float, force_N: float, size_mm: float) -> Callable[[], Outcome]:
    """The general FE path (`fecheck.fe.reference.sphere_layer`), `size_mm` under the contact."""
    from fecheck.fe.reference.sphere_layer import sphere_on_flat_layer

    def run() -> Outcome:
        r = sphere_on_flat_layer(force_N, radius_mm, E_MPA, NU, H_MM, refine_size_mm=size_mm)
        return Outcome(r.metrics.max_pressure_MPa, r.metrics.area_mm2, r.iterations, r.n_dofs)

    return run


def fe_axisym(radius_mm: float, force_N: float, size_mm: float) -> Callable[[], Outcome]:
    from fecheck.fe.reference.axisym import axisym_sphere_on_layer

    def run() -> Outcome:
        r = axisym_sphere_on_layer(force_N, radius_mm, E_MPA, NU, H_MM, size_mm=size_mm)
        return Outcome(r.metrics.max_pressure_MPa, r.metrics.area_mm2, r.iterations, r.n_dofs)

    return run


def scene_solve(overrides: list[str], fe_refs: dict) -> Callable[[], Outcome]:
    """The baseline scene (both compartments, 2-DOF Newton) through `run_scene`: p_max and
    area of the compartment farthest from the exact EF answer at its solved force, with
    that answer and the converged FE of that compartment (`fe_refs`) as references."""
    from fecheck.model.run import run_scene
    from fecheck.scene import load_scene

    scene = load_scene(overrides=overrides)

    def run() -> Outcome:
        res = run_scene(scene)
        dev = {c: max(abs(v) for k, v in ref["deviation_percent"].items()
                      if k in ("max_pressure_MPa", "area_mm2"))
               for c, ref in res.exact.items()}
        worst = max(dev, key=dev.get)
        comp, ref = res.compartments[worst], res.exact[worst]
        return Outcome(comp.max_pressure_MPa, comp.area_mm2, res.iterations,
                       sum(res.record.contact_faces.values()),
                       (ref["max_pressure_MPa"], ref["area_mm2"]), fe_refs[worst])

    return run


# ------------------------------------------------------------------------- timing
def timed(run: Callable[[], Outcome], repeats: int, slow_s: float
          ) -> tuple[Outcome, list[float]]:
    """Run once untimed-for-the-median if fast (warm-up), then `repeats` timed runs;
    a run slower than `slow_s` is timed once."""
    t = time.perf_counter()
    out = run()
    first = time.perf_counter() - t
    if first > slow_s:
        return out, [first]
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        out = run()
        times.append(time.perf_counter() - t)
    return out, times


@dataclass
class Bench:
    """Collects rows and prints progress (`log`)."""

    config: BenchConfig
    log: Callable[[str], None] = lambda s: None
    rows: list[Row] = field(default_factory=list)

    def add(self, method: str, compartment: str, resolution: str,
            run: Callable[[], Outcome], ref: tuple[float, float] | None = None,
            fe_ref: tuple[float, float] | None = None) -> Row:
        """Time `run` and add its row; `ref`/`fe_ref` are (p_max MPa, area mm²), or None
        when the run gives its own."""
        out, times = timed(run, self.config.repeats, self.config.slow_s)
        ref, fe_ref = out.reference or ref, out.fe_reference or fe_ref
        ep, ea = _rel(out.max_pressure_MPa, ref[0]), _rel(out.area_mm2, ref[1])
        fp, fa = _rel(out.max_pressure_MPa, fe_ref[0]), _rel(out.area_mm2, fe_ref[1])
        efe = max(fp, fa)
        row = Row(method, compartment, resolution, out.n_faces, statistics.median(times),
                  min(times), max(times), len(times), out.max_pressure_MPa, out.area_mm2,
                  ep, ea, max(ep, ea), efe, fp, fa, out.iterations)
        self.rows.append(row)
        self.log(f"{method:19s} {compartment:8s} {resolution:>10s} {row.n_faces:8d} "
                 f"{row.time_s:10.4f} s  error {row.error:9.2e}  vs FE {efe:8.2e}")
        return row


def run_bench(config: BenchConfig, log: Callable[[str], None] = lambda s: None) -> dict:
    """All rows, references, ratios and scaling of one bench run (JSON-ready dict)."""
    from fecheck.reference.closed_forms import ef_sphere_plane, hertz_sphere_on_plane

    bench = Bench(config, log)
    references = {}
    log(f"{'method':19s} {'side':8s} {'resolution':>10s} {'faces':>8s} {'median time':>12s}")
    for c in config.compartments:
        radius, force = BASELINE_COMPARTMENTS[c]
        ef = ef_sphere_plane(force, radius, baseline_ef_stiffness())
        ef_ref = (ef["max_pressure_MPa"], ef["area_mm2"])
        hz = hertz_sphere_on_plane(force, radius, E_MPA, NU)
        hz_ref = (hz.max_pressure_MPa, hz.area_mm2)
        fe = fe_axisym(radius, force, config.fe_reference_size_mm)()
        fe_ref = (fe.max_pressure_MPa, fe.area_mm2)
        references[c] = {"radius_mm": radius, "force_N": force,
                         "ef_exact": {"max_pressure_MPa": ef_ref[0], "area_mm2": ef_ref[1]},
                         "hertz": {"max_pressure_MPa": hz_ref[0], "area_mm2": hz_ref[1]},
                         "fe_converged": {"max_pressure_MPa": fe_ref[0], "area_mm2": fe_ref[1],
                                          "axisym_size_mm": config.fe_reference_size_mm}}
        for n in config.levels:
            for area in ("clipped", "whole-face"):
                bench.add(f"ef-{area}", c, f"level {n}",
                          ef_on_icosphere(radius, force, n, area), ef_ref, fe_ref)
        for s in config.plateau_sizes_mm:
            bench.add("ef-analytic-master", c, f"{s:g} mm",
                      ef_analytic_master(radius, force, s), ef_ref, fe_ref)
        for n in config.thesis_levels:
            bench.add("thesis-fcl", c, f"level {n}", thesis_fcl(radius, force, n),
                      ef_ref, fe_ref)
        for n in config.hertz_levels:
            bench.add("hertz-mesh", c, f"level {n}",
                      hertz_on_icosphere(radius, force, n), hz_ref, fe_ref)
        bench.add("hertz-formula", c, "closed form", hertz_formula(radius, force),
                  hz_ref, fe_ref)
        if c in config.fe_compartments:
            for s in config.axisym_sizes_mm:
                bench.add("fe-axisym", c, f"{s:g} mm", fe_axisym(radius, force, s),
                          fe_ref, fe_ref)
            for s in config.fe3d_sizes_mm:
                bench.add("fe-3d", c, f"{s:g} mm", fe_3d(radius, force, s),
                          fe_ref, fe_ref)
    fe_refs = {c: (r["fe_converged"]["max_pressure_MPa"], r["fe_converged"]["area_mm2"])
               for c, r in references.items()}
    if set(fe_refs) == set(BASELINE_COMPARTMENTS):
        for method, extra in (("scene-ef-clipped", []),
                              ("scene-thesis-fcl", ["contact.detection=fcl",
                                                    "contact.area=whole-face"])):
            run = scene_solve(["contact.master=plateau",
                               f"mesh.sphere_subdivisions={THESIS_LEVEL}"] + extra, fe_refs)
            bench.add(method, "both", f"level {THESIS_LEVEL}", run)
    return {"problem": {"youngs_MPa": E_MPA, "poisson": NU, "thickness_mm": H_MM,
                        "compartments": {c: BASELINE_COMPARTMENTS[c] for c in config.compartments}},
            "machine": machine(), "config": asdict(config), "references": references,
            "rows": [asdict(r) for r in bench.rows], "ratios": ratios(bench.rows),
            "scaling": scaling(config, log)}


# ------------------------------------------------------------------------- ratios
def _find(rows: list[Row], method: str, compartment: str, resolution: str) -> Row | None:
    return next((r for r in rows if (r.method, r.compartment, r.resolution)
                 == (method, compartment, resolution)), None)


def time_to_error(rows: list[Row], target: float, attr: str = "error_pmax") -> float | None:
    """Time (s) at which a method's error first reaches `target`, interpolated log-log
    between the last row above and the first row below it (None if never reached)."""
    rows = sorted(rows, key=lambda r: r.time_s)
    prev = None
    for r in rows:
        e = getattr(r, attr)
        if e <= target:
            if prev is None or getattr(prev, attr) <= 0 or e <= 0:
                return r.time_s
            pe = getattr(prev, attr)
            frac = math.log(pe / target) / math.log(pe / e)
            return math.exp(math.log(prev.time_s) + frac * math.log(r.time_s / prev.time_s))
        prev = r
    return None


def ratios(rows: list[Row]) -> dict:
    """Each method against the thesis stack at 5,120 faces; EF against FE time."""
    out: dict = {}
    level = f"level {THESIS_LEVEL}"
    for c in sorted({r.compartment for r in rows}):
        thesis = _find(rows, "thesis-fcl", c, level)
        ours = {m: _find(rows, m, c, level) for m in ("ef-clipped", "ef-whole-face")}
        ours["ef-analytic-master"] = _find(rows, "ef-analytic-master", c, "0.7 mm")
        entry: dict = {}
        if thesis is not None:
            entry["thesis_fcl_5120"] = {"time_s": thesis.time_s, "error": thesis.error,
                                        "error_pmax": thesis.error_pmax,
                                        "error_area": thesis.error_area}
            for m, r in ours.items():
                if r is not None:
                    entry[m] = {"time_s": r.time_s, "error": r.error,
                                "thesis_time_over_method_time": thesis.time_s / r.time_s,
                                "thesis_error_over_method_error":
                                    thesis.error / r.error if r.error > 0 else None}
        ef = ours["ef-clipped"]
        for fe in ("fe-3d", "fe-axisym"):
            fe_rows = [r for r in rows if r.method == fe and r.compartment == c]
            if not fe_rows:
                continue
            t1 = time_to_error(fe_rows, ONE_PERCENT)
            entry[f"{fe}_time_to_1pct_pmax_s"] = t1
            if ef is not None and t1 is not None:
                entry[f"{fe}_time_to_1pct_over_ef_5120_time"] = t1 / ef.time_s
        out[c] = entry
    ours = _find(rows, "scene-ef-clipped", "both", level)
    thesis = _find(rows, "scene-thesis-fcl", "both", level)
    if ours is not None and thesis is not None:
        out["baseline_scene_5120"] = {
            "ef_clipped": {"time_s": ours.time_s, "error": ours.error},
            "thesis_fcl": {"time_s": thesis.time_s, "error": thesis.error},
            "thesis_time_over_ef_time": thesis.time_s / ours.time_s,
            "thesis_error_over_ef_error": thesis.error / ours.error if ours.error else None}
    return out


# ------------------------------------------------------------------------- scaling
def _padded(mesh, copies: int):
    """`mesh` plus `copies - 1` copies of it stacked 100 mm apart above it (far from z = 0)."""
    from geometry.mesh import TriMesh

    n = mesh.n_points
    pts = np.concatenate([mesh.points + [0.0, 0.0, 100.0 * i] for i in range(copies)])
    faces = np.concatenate([mesh.faces + n * i for i in range(copies)])
    return TriMesh(pts, faces)


@dataclass
class _Timed:
    """One slave mesh pressed to the medial equilibrium depth on the plane, ready to time."""

    evaluate: Callable[[int], object]
    faces: int
    candidate_faces: int
    contact_faces: int
    first_evaluation_s: float


def _pressed(slave, radius_mm: float, force_N: float) -> _Timed:
    from fecheck.contact import ContactPair, Plane
    from fecheck.laws import elastic_foundation

    k = baseline_ef_stiffness()
    pair = ContactPair(slave, Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]))
    down = np.array([0.0, 0.0, -1.0])
    _, delta, _ = load_controlled(pair, lambda s: elastic_foundation(s, k), down, force_N,
                                  ef_start_depth(radius_mm, force_N))
    eye = np.eye(3)
    pose_master = (eye, np.zeros(3))
    fresh = ContactPair(slave, Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]))
    t = time.perf_counter()
    fresh.evaluate((eye, delta * down), pose_master)
    rebuild = time.perf_counter() - t

    def evaluate(i: int):
        wobble = (eye, (delta + 1e-4 * (i % 2)) * down)   # moves, stays within the margin
        surface = pair.evaluate(wobble, pose_master)
        elastic_foundation(surface, k)
        return surface

    surface = evaluate(0)
    cand = pair.cache.get(eye, delta * down)
    return _Timed(evaluate, slave.n_faces, int(cand.faces.size), int(surface.n_faces),
                  rebuild)


def _best_times(cases: list[_Timed], evaluations: int) -> list[float]:
    """Best time of one evaluation per case, the cases timed in interleaved rounds so a
    busy spell on a shared machine slows all of them alike (s)."""
    best = [math.inf] * len(cases)
    for i in range(evaluations):
        for j, case in enumerate(cases):
            t = time.perf_counter()
            case.evaluate(i + 1)
            best[j] = min(best[j], time.perf_counter() - t)
    return best


def _slope(xs: list[float], ys: list[float]) -> float:
    return float(np.polyfit(np.log(xs), np.log(ys), 1)[0])


def scaling(config: BenchConfig, log: Callable[[str], None] = lambda s: None) -> dict:
    """Time per contact evaluation against slave faces (medial compartment): the best of
    `config.scaling_evaluations` evaluations per mesh, all meshes timed in the same rounds."""
    radius, force = BASELINE_COMPARTMENTS["medial"]
    base = _icosphere(radius, THESIS_LEVEL)
    meshes = {"refined_icosphere": [_icosphere(radius, n) for n in config.scaling_levels],
              "padded_icosphere": [_padded(base, k) for k in config.scaling_copies]}
    cases = [(name, _pressed(m, radius, force)) for name, ms in meshes.items() for m in ms]
    best = _best_times([c for _, c in cases], config.scaling_evaluations)
    out: dict = {name: [] for name in meshes}
    for (name, c), t in zip(cases, best, strict=True):
        out[name].append({"faces": c.faces, "candidate_faces": c.candidate_faces,
                          "contact_faces": c.contact_faces, "time_per_evaluation_s": t,
                          "first_evaluation_s": c.first_evaluation_s})
    for name in meshes:
        series = out[name]
        out[f"{name}_slope_vs_faces"] = _slope([s["faces"] for s in series],
                                               [s["time_per_evaluation_s"] for s in series])
        for s in series:
            log(f"scaling {name:18s} faces {s['faces']:7d}  near {s['candidate_faces']:6d}  "
                f"per evaluation {1e3 * s['time_per_evaluation_s']:8.3f} ms  first "
                f"{1e3 * s['first_evaluation_s']:8.3f} ms")
    refined = out["refined_icosphere"]
    out["refined_icosphere_slope_vs_candidate_faces"] = _slope(
        [s["candidate_faces"] for s in refined], [s["time_per_evaluation_s"] for s in refined])
    return out


# ------------------------------------------------------------------------- output
def table(result: dict) -> str:
    """The rows as a text table, then the ratios and the scaling slopes."""
    header = (f"{'method':19s} {'side':8s} {'resolution':>11s} {'faces/dofs':>10s} "
              f"{'time s':>9s} {'spread s':>9s} {'p_max':>7s} {'area':>7s} {'error':>9s} "
              f"{'vs FE':>9s}")
    lines = [header]
    for r in result["rows"]:
        lines.append(f"{r['method']:19s} {r['compartment']:8s} {r['resolution']:>11s} "
                     f"{r['n_faces']:10d} {r['time_s']:9.4f} "
                     f"{r['time_max_s'] - r['time_min_s']:9.4f} {r['max_pressure_MPa']:7.3f} "
                     f"{r['area_mm2']:7.1f} {r['error']:9.2e} {r['error_vs_fe']:9.2e}")
    for c, entry in result["ratios"].items():
        for key, value in entry.items():
            if isinstance(value, dict):
                text = ", ".join(f"{k} {v:.3g}" for k, v in value.items() if v is not None)
            else:
                text = "not reached" if value is None else f"{value:.3g}"
            lines.append(f"ratio {c} {key}: {text}")
    sc = result["scaling"]
    lines.append("scaling: time per evaluation ∝ "
                 f"faces^{sc['refined_icosphere_slope_vs_faces']:.2f}"
                 f" refining the sphere, ∝ faces^{sc['padded_icosphere_slope_vs_faces']:.2f} "
                 f"adding far faces (near faces fixed)")
    m = result["machine"]
    lines.append(f"machine: {m['platform']}, {m['cpus']} cpus, python {m['python']}, "
                 f"numpy {m['numpy']}")
    return "\n".join(lines)


def json_text(result: dict) -> str:
    """The bench result (rows, ratios, scaling, machine) as JSON text."""
    import json

    return json.dumps(result, indent=2) + "\n"


def write_json(result: dict, path: str) -> None:
    """Write the bench result as JSON, atomically (``-``: standard output)."""
    from fecheck.io.outputs import write_text

    write_text(path, json_text(result))


def pareto_front(rows: list[dict], key: str = "error") -> list[dict]:
    """Rows not beaten in both time and `key` error by another row."""
    front = []
    for r in sorted(rows, key=lambda r: (r["time_s"], r[key])):
        if not front or r[key] < front[-1][key]:
            front.append(r)
    return front


def plot(result: dict, folder: str) -> list[str]:
    """Pareto plots (time against error, log-log): own reference and against FE. Paths."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from fecheck.io.outputs import write_output

    paths = []
    for key, title in (("error", "error against the model's converged reference"),
                       ("error_vs_fe", "error against the converged FE")):
        fig, ax = plt.subplots(figsize=(7, 5))
        colors = {}
        for method in dict.fromkeys(r["method"] for r in result["rows"]):
            for c, style in zip(BASELINE_COMPARTMENTS, ("o-", "s--"), strict=True):
                rs = [r for r in result["rows"] if (r["method"], r["compartment"]) == (method, c)
                      and r[key] > EXACT]
                if not rs:
                    continue
                line, = ax.plot([r["time_s"] for r in rs], [r[key] for r in rs], style, ms=4,
                                color=colors.get(method),
                                label=f"{method} ({c})")
                colors[method] = line.get_color()
        front = pareto_front([r for r in result["rows"] if r[key] > EXACT], key)
        ax.plot([r["time_s"] for r in front], [r[key] for r in front], "k--", lw=1,
                label="Pareto front")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("median time per solve, s")
        ax.set_ylabel("relative error, max(p_max, area)")
        ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
        path = os.path.join(folder, f"bench_pareto_{key}.png")
        write_output(path, lambda tmp, fig=fig: fig.savefig(tmp, dpi=120, bbox_inches="tight"))
        plt.close(fig)
        paths.append(path)
    return paths
