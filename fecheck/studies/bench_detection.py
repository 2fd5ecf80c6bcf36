"""Detection benchmark: our contact engine against the thesis's stack, measured in one run.

Scenarios (R = 31.8 mm lateral condyle, icospheres of 20·4^n faces):

* ``bisect`` — thesis Figs. 3.21/3.25: an icosphere bisected by a plane (d = R).
  Exact: area πR², ∫d dA = 2πR³/3.
* ``statics`` — the Newton regime: the same icosphere 1 mm into the plane, evaluated at
  a sequence of nearby poses (candidate set reused) and from scratch.
  Exact: cap area π(2Rd - d²), cap volume πd²(R - d/3).
* ``sphere-master`` — an analytic sphere master over a flat plateau mesh (depth along
  the plateau normal), 1 mm; the thesis stack meets an icosphere of 5,120 faces.
* ``mesh-mesh`` — thesis Fig. 3.25's concave-concave case: an icosphere slave (R) into
  an icosphere master (25.5 mm) of as many faces, overlapping by 1 mm. Exact, for the
  closest-point depth d = R₂ - |x - c₂| over the slave surface inside the master:
  area 2πR₁h₁ and ∫d dA = (2πR₁/D)[R₂u²/2 - u³/3] between u = D - R₁ and R₂.

* ``locality`` — a sphere master over plateaus of growing radius refined alike under the
  contact: the time per call must follow the faces near the contact, not all faces.

Methods: ``closed-form`` (analytic master), ``bvh`` (mesh master, libigl AABB), and the
thesis stack: ``fcl`` (python-fcl per-face contacts through trimesh's converters, box or
icosphere master), ``ray-parity`` (trimesh ``contains`` with embree + cKDTree) and
``ray-thesis`` (the same with trimesh's pure ray engine, as the thesis ran it).
Times are medians over blocks of consecutive calls, the methods taking turns block by
block (`_time_interleaved`); compare them as ratios within one run.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from fecheck.errors import FecheckError

R_SLAVE = 31.8
R_MASTER = 25.5
DEPTH = 1.0
LEVELS_FULL = (3, 4, 5, 6, 7)            # 1,280 … 327,680 faces
LEVELS_QUICK = (3, 4, 5)                 # … 20,480 faces
IDENTITY = (np.eye(3), np.zeros(3))
THESIS_RAY_LIMIT = 20480                 # the pure ray engine takes seconds per call there


def _cap(d: float, R: float = R_SLAVE) -> tuple[float, float]:
    """Projected base area and volume of a spherical cap of height d (plane masters)."""
    return np.pi * (2 * R * d - d * d), np.pi * d * d * (R - d / 3)


def _zone(d: float, R: float = R_SLAVE) -> tuple[float, float]:
    """Sphere surface within d of a plane and ∫ depth dA over it (surface areas, as mesh
    masters and the thesis count them): 2πRd and πRd² (Archimedes)."""
    return 2 * np.pi * R * d, np.pi * R * d * d


def _lens(R1: float, R2: float, overlap: float) -> tuple[float, float]:
    """Slave-sphere area inside the master sphere and ∫(R₂ - |x - c₂|) dA over it."""
    D = R1 + R2 - overlap
    lo, hi = D - R1, R2
    k = 2 * np.pi * R1 / D

    def primitive(u: float) -> float:                       # ∫ (R₂ - u) u du
        return R2 * u**2 / 2 - u**3 / 3

    return k * (hi**2 - lo**2) / 2, k * (primitive(hi) - primitive(lo))


def _nearby_poses(base, n: int = 8, step_mm: float = 0.02):
    """Small rigid perturbations of `base` (within the reuse window), a Newton-like walk."""
    from fecheck.statics.frames import rotation

    R, t = base
    return [(R @ rotation(0.0, 2e-4 * k, -1e-4 * k), t + step_mm * np.array([k, -k, 0.5 * k]))
            for k in range(n)]


def _time_interleaved(calls: dict, min_rounds: int = 3, budget_s: float = 0.5,
                      block_s: float = 2e-3, max_rounds: int = 200,
                      slow_s: float = 1.0) -> dict:
    """Median wall time per call (s) of each callable.

    The callables take turns (so that all see the same load on the shared machine), each
    turn a block of consecutive calls lasting about `block_s` (one call if slower): the
    time per call of a block is what a Newton loop, which calls one pair again and again,
    sees. (Alternating single calls instead makes every call start with caches emptied by
    the other methods, a fixed cost that penalises fast methods most.) A callable slower
    than `slow_s` is timed once.
    """
    times = {k: [] for k in calls}
    per_block = dict.fromkeys(calls, 1)
    start = time.perf_counter()
    n = 0
    while n < min_rounds or (time.perf_counter() - start < budget_s and n < max_rounds):
        for key, fn in calls.items():
            if times[key] and times[key][0] > slow_s:
                continue
            k = per_block[key]
            t0 = time.perf_counter()
            for _ in range(k):
                fn()
            elapsed = time.perf_counter() - t0
            times[key].append(elapsed / k)
            per_block[key] = max(1, min(1000, int(block_s * k / max(elapsed, 1e-9))))
        n += 1
    return {k: float(np.median(v)) for k, v in times.items()}


class _ThesisRayPair:
    """Thesis Algorithm 3 with trimesh's pure ray engine (no embree), as the thesis ran
    it, behind the ``evaluate(slave_pose, master_pose)`` call."""

    def __init__(self, slave, master) -> None:
        from fecheck.contact.thesis import RayParity

        self._detector = RayParity(slave, master, "clipped", engine="triangle")

    def evaluate(self, slave_pose, master_pose):
        from fecheck.contact.pair import validate_pose

        return self._detector.evaluate(*validate_pose(slave_pose, "slave"),
                                       *validate_pose(master_pose, "master"))


def _measure(scenario: str, n_faces: int, entries: list, poses, master_pose,
             budget_s: float) -> list[dict]:
    """Rows for several (method, pair, exact) entries timed together on the same poses;
    our engine also from scratch (candidate set rebuilt every call)."""
    import warnings

    rows, calls, surfaces = [], {}, {}
    counter = iter(range(10**9))

    def caller(pair, scratch=False):
        def call():
            if scratch:
                pair.cache.reset()
            pair.evaluate(poses[next(counter) % len(poses)], master_pose)
        return call

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for method, pair, _ in entries:
            try:
                surfaces[method] = pair.evaluate(poses[0], master_pose)
            except FecheckError as err:
                rows.append({"scenario": scenario, "method": method, "n_faces": int(n_faces),
                             "error": str(err)})
                continue
            calls[method] = caller(pair)
            if method in ("closed-form", "bvh"):
                calls[method + " scratch"] = caller(pair, scratch=True)
        times = _time_interleaved(calls, budget_s=budget_s)
    for method, pair, exact in entries:
        if method not in surfaces:
            continue
        extra = {}
        if method + " scratch" in times:
            extra["time_from_scratch_ms"] = 1e3 * times[method + " scratch"]
            pair.cache.reset()
            pair.evaluate(poses[0], master_pose)
            extra["n_candidate_faces"] = int(pair.cache.current.faces.size)
        rows.append(_row(scenario, method, n_faces, surfaces[method], exact, times[method],
                         **extra))
    return rows


def _row(scenario, method, n_faces, surface, exact, seconds, **extra):
    area_exact, volume_exact = exact
    volume = float((surface.qp_weight * np.maximum(surface.qp_depth, 0.0)).sum())
    row = {
        "scenario": scenario, "method": method, "n_faces": int(n_faces),
        "n_contact_faces": int(surface.n_faces), "time_ms": 1e3 * seconds,
        "area_mm2": surface.area, "area_exact_mm2": area_exact,
        "area_rel_error": surface.area / area_exact - 1.0,
        "volume_mm3": volume, "volume_exact_mm3": volume_exact,
        "volume_rel_error": volume / volume_exact - 1.0,
        "max_depth_mm": surface.max_depth,
    }
    row.update(extra)
    return row


def _box_master(half: float, depth: float):
    """A closed box whose top face is the plane z = 0 (mm)."""
    import trimesh

    from geometry.mesh import TriMesh

    box = trimesh.creation.box(extents=[2 * half, 2 * half, depth])
    return TriMesh(np.asarray(box.vertices) - [0.0, 0.0, depth / 2], np.asarray(box.faces))


def _plane_rows(levels, ray_limit, progress, budget_s):
    from fecheck.contact import ContactPair, Plane
    from geometry.icosphere import icosphere

    rows = []
    plane = Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    box = _box_master(3 * R_SLAVE, 3 * R_SLAVE)     # sides ≥ 2R from any point of the cap
    for level in levels:
        sphere = icosphere(R_SLAVE, level)
        n = sphere.n_faces
        for scenario, d in (("bisect", R_SLAVE), ("statics", DEPTH)):
            progress(f"{scenario} {n} faces")
            base = (np.eye(3), np.array([0.0, 0.0, R_SLAVE - d]))
            poses = _nearby_poses(base) if scenario == "statics" else [base]
            entries = [("closed-form", ContactPair(sphere, plane), _cap(d)),
                       ("bvh", ContactPair(sphere, box), _zone(d)),
                       ("fcl", ContactPair(sphere, box, method="fcl"), _zone(d))]
            if n <= ray_limit:
                entries.append(("ray-parity", ContactPair(sphere, box, method="ray-parity"),
                                _zone(d)))
            if n <= THESIS_RAY_LIMIT:
                entries.append(("ray-thesis", _ThesisRayPair(sphere, box), _zone(d)))
            rows += _measure(scenario, n, entries, poses, IDENTITY, budget_s)
    return rows


def _sphere_master_rows(sizes, progress, budget_s):
    from fecheck.contact import ContactPair, Sphere
    from geometry.icosphere import icosphere
    from geometry.plateau import plane_patch

    rows = []
    master_pose = (np.eye(3), np.array([0.0, 0.0, R_SLAVE - DEPTH]))
    condyle = icosphere(R_SLAVE, 4)                           # the thesis's ~5000 faces
    for size in sizes:
        plateau = plane_patch([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], radius=30.0, size=size)
        progress(f"sphere-master {plateau.n_faces} faces")
        entries = [("closed-form", ContactPair(plateau, Sphere([0.0, 0.0, 0.0], R_SLAVE)),
                    _cap(DEPTH)),
                   ("fcl", ContactPair(plateau, condyle, method="fcl"), _cap(DEPTH))]
        rows += _measure("sphere-master", plateau.n_faces, entries, _nearby_poses(IDENTITY),
                         master_pose, budget_s)
    return rows


def _locality_rows(radii, progress, budget_s):
    """A plateau refined (0.5 mm) within 12 mm of the contact, 1 mm beyond, growing in
    radius: the faces near the contact stay, all faces grow."""
    from fecheck.contact import ContactPair, Sphere
    from geometry.plateau import plane_patch

    rows = []
    master_pose = (np.eye(3), np.array([0.0, 0.0, R_SLAVE - DEPTH]))
    for radius in radii:
        plateau = plane_patch([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], radius=radius, size=1.0,
                              refine_point=[0.0, 0.0, 0.0], refine_size=0.5,
                              refine_radius=12.0)
        progress(f"locality {plateau.n_faces} faces")
        entries = [("closed-form", ContactPair(plateau, Sphere([0.0, 0.0, 0.0], R_SLAVE)),
                    _cap(DEPTH))]
        rows += _measure("locality", plateau.n_faces, entries, _nearby_poses(IDENTITY),
                         master_pose, budget_s)
    return rows


def _mesh_mesh_rows(levels, ray_limit, progress, budget_s):
    from fecheck.contact import ContactPair
    from geometry.icosphere import icosphere

    rows = []
    exact = _lens(R_SLAVE, R_MASTER, DEPTH)
    distance = R_SLAVE + R_MASTER - DEPTH
    for level in levels:
        slave = icosphere(R_SLAVE, level)
        master = icosphere(R_MASTER, level, center=(0.0, 0.0, -distance))
        n = slave.n_faces
        progress(f"mesh-mesh {n} faces")
        entries = [("bvh", ContactPair(slave, master), exact)]
        if n <= ray_limit:
            entries += [("ray-parity", ContactPair(slave, master, method="ray-parity"), exact),
                        ("fcl", ContactPair(slave, master, method="fcl"), exact)]
        if n <= THESIS_RAY_LIMIT:
            entries.append(("ray-thesis", _ThesisRayPair(slave, master), exact))
        rows += _measure("mesh-mesh", n, entries, _nearby_poses(IDENTITY), IDENTITY, budget_s)
    return rows


def _mesh_mesh_ratios(t) -> dict:
    """The mesh-against-mesh ratios at 20,480 faces; `t` looks a time up in the rows."""
    out = {}
    ours, parity = t("mesh-mesh", "bvh", 20480), t("mesh-mesh", "ray-parity", 20480)
    if ours and parity:
        out["mesh_mesh_20480_ray_parity_embree_over_bvh"] = parity / ours
    thesis = t("mesh-mesh", "ray-thesis", 20480)
    if ours and thesis:
        out["mesh_mesh_20480_ray_thesis_over_bvh"] = thesis / ours
    scratch = t("mesh-mesh", "bvh", 20480, "time_from_scratch_ms")
    if ours and scratch:
        out["mesh_mesh_20480_reused_over_from_scratch"] = ours / scratch
    return out


def _ratios(rows) -> dict:
    """Speed ratios the acceptance criteria name, from rows of this run."""
    def t(scenario, method, n, key="time_ms"):
        for r in rows:
            if (r["scenario"], r["method"], r["n_faces"]) == (scenario, method, n) and key in r:
                return r[key]
        return None

    out = _mesh_mesh_ratios(t)
    for scenario in ("statics", "bisect"):
        ours, fcl = t(scenario, "closed-form", 5120), t(scenario, "fcl", 5120)
        if ours and fcl:
            out[f"{scenario}_plane_5120_fcl_over_closed_form"] = fcl / ours
        bvh, parity = t(scenario, "bvh", 5120), t(scenario, "ray-parity", 5120)
        if bvh and parity:
            out[f"{scenario}_box_5120_ray_parity_over_bvh"] = parity / bvh
    sphere = [r for r in rows if r["scenario"] == "sphere-master" and "time_ms" in r]
    if sphere:
        n = min({r["n_faces"] for r in sphere}, key=lambda k: abs(k - 5120))
        ours, fcl = t("sphere-master", "closed-form", n), t("sphere-master", "fcl", n)
        if ours and fcl:
            out[f"sphere_master_{n}_fcl_over_closed_form"] = fcl / ours
    local = sorted((r for r in rows if r["scenario"] == "locality" and "time_ms" in r),
                   key=lambda r: r["n_faces"])
    if len(local) > 1:
        out["locality_faces_ratio"] = local[-1]["n_faces"] / local[0]["n_faces"]
        out["locality_time_ratio"] = local[-1]["time_ms"] / local[0]["time_ms"]
        out["locality_from_scratch_time_ratio"] = (local[-1]["time_from_scratch_ms"]
                                                   / local[0]["time_from_scratch_ms"])
    return out


def run(quick: bool = False, progress=lambda message: None, *,
        levels: tuple[int, ...] | None = None,
        plateau_sizes: tuple[float, ...] | None = None,
        locality_radii: tuple[float, ...] | None = None, budget_s: float = 0.5) -> dict:
    """All scenarios: {"rows": [...], "ratios": {...}, "quick": bool}.

    `levels` (icosphere subdivision levels), `plateau_sizes` (mm), `locality_radii`
    (mm) override the quick/full defaults, e.g. for a smoke test; `budget_s` is the
    timing budget per group of methods (s).
    """
    levels = levels or (LEVELS_QUICK if quick else LEVELS_FULL)
    sizes = plateau_sizes or ((2.0, 1.0, 0.5) if quick else (2.0, 1.0, 0.5, 0.25))
    radii = locality_radii or ((15.0, 30.0, 60.0) if quick else (15.0, 30.0, 60.0, 90.0))
    ray_limit = 20480 if quick else 81920
    rows = _plane_rows(levels, ray_limit, progress, budget_s)
    rows += _sphere_master_rows(sizes, progress, budget_s)
    rows += _locality_rows(radii, progress, budget_s)
    rows += _mesh_mesh_rows(levels, ray_limit, progress, budget_s)
    return {"quick": quick, "rows": rows, "ratios": _ratios(rows)}


def table(result: dict) -> str:
    """A plain-text summary of the rows and ratios."""
    lines = [(f"{'scenario':14s}{'method':12s}{'faces':>8s}{'contact':>8s}{'ms':>10s}"
             f"{'scratch ms':>11s}{'area err':>10s}{'vol err':>10s}")]
    for r in result["rows"]:
        if "error" in r:
            lines.append(f"{r['scenario']:14s}{r['method']:12s}{r['n_faces']:8d}  "
                         f"error: {r['error']}")
            continue
        scratch = r.get("time_from_scratch_ms")
        lines.append(f"{r['scenario']:14s}{r['method']:12s}{r['n_faces']:8d}"
                     f"{r['n_contact_faces']:8d}{r['time_ms']:10.3f}"
                     f"{'' if scratch is None else f'{scratch:.3f}':>11s}"
                     f"{r['area_rel_error']:10.2%}{r['volume_rel_error']:10.2%}")
    lines.append("ratios (same run):")
    lines += [f"  {k}: {v:.1f}" if v >= 1 else f"  {k}: {v:.3f}"
              for k, v in result["ratios"].items()]
    return "\n".join(lines)


def plot(result: dict, folder: Path) -> list[Path]:
    """Log-log PNG: per scenario (columns), time per call and |area error| against faces,
    one colour per method."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in result["rows"] if "time_ms" in r]
    scenarios = list(dict.fromkeys(r["scenario"] for r in rows))
    methods = list(dict.fromkeys(r["method"] for r in rows))
    colour = {m: f"C{i}" for i, m in enumerate(methods)}
    fig, axes = plt.subplots(2, len(scenarios), figsize=(3.6 * len(scenarios), 7),
                             squeeze=False)
    for col, scenario in enumerate(scenarios):
        ax_t, ax_e = axes[0, col], axes[1, col]
        for method in methods:
            sel = sorted((r for r in rows if (r["scenario"], r["method"]) == (scenario, method)),
                         key=lambda r: r["n_faces"])
            if not sel:
                continue
            n = [r["n_faces"] for r in sel]
            ax_t.loglog(n, [r["time_ms"] for r in sel], "o-", color=colour[method],
                        label=method)
            ax_e.loglog(n, [max(abs(r["area_rel_error"]), 1e-6) for r in sel], "o-",
                        color=colour[method], label=method)
        ax_t.set(title=scenario, xlabel="slave faces", ylabel="median time per call, ms")
        ax_e.set(xlabel="slave faces", ylabel="|area error| vs exact")
        for ax in (ax_t, ax_e):
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=7)
    fig.suptitle("Contact detection: our engine vs the thesis stack (thesis Figs. 3.21/3.25)")
    fig.tight_layout()
    path = folder / "bench_detection.png"
    from fecheck.io.outputs import write_output

    write_output(path, lambda tmp: fig.savefig(tmp, dpi=110))
    plt.close(fig)
    return [path]


def write_json(result: dict, path: Path) -> None:
    """Write the result as JSON (rows with units in their keys)."""
    from fecheck.io.outputs import write_text

    write_text(path, json.dumps(result, indent=1))
