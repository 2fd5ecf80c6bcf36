"""Speed of the scanned femur-on-tibia equilibrium (thesis Fig. 3.25).

For the full meshes (8,602 tibial and 29,782 femoral cartilage faces) and decimated ones,
solves ``validation/scenes/femur_tibia.toml`` and reports the Newton iterations, contact
evaluations, time per contact evaluation (both compartments, detection + law + tangent)
and total times. On the same meshes and in the same run, it times the thesis's detection
(Algorithm 3: ray-parity `contains` of the slave vertices in the master through trimesh,
Embree-accelerated, plus a cKDTree nearest-vertex query for the depth) and gives the
ratio thesis / fecheck per evaluation. Times are wall clock on a shared machine: read the
ratios, not the absolute values.

    python validation/scanned_speed.py [--quick] [--out DIR]

--quick runs the 2,000-face decimation only. Writes DIR/scanned_speed.csv.
"""

from __future__ import annotations

import csv
import sys
import time
from pathlib import Path

import numpy as np

from fecheck.model.assembly import ContactModel
from fecheck.model.run import run_scene
from fecheck.model.scanned import build_compartments
from fecheck.scene import load_scene
from fecheck.statics.newton import pose

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.studies.thesis.report import knee_script_args

SCENE = Path(__file__).resolve().parent / "scenes" / "femur_tibia.toml"
REPEATS = 5
PYTHON_RAYS_MAX_FACES = 20_000
"""Largest master timed with trimesh's pure-Python ray engine: its memory grows with
rays x candidate triangles (over 4.5 GB and minutes at the full 29,782 faces here)."""


def best_time(fn, repeats: int = REPEATS) -> float:
    """Shortest of `repeats` wall-clock times of fn() after one warm-up call, s."""
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def thesis_detection(slaves: list, master, engine: str) -> callable:
    """The thesis's per-evaluation detection on these meshes: ray parity + cKDTree.

    engine "embree": trimesh's Embree ray engine (embreex installed); "python": trimesh's
    pure-Python ray/triangle engine, which trimesh falls back to without embreex.
    """
    import trimesh
    from scipy.spatial import cKDTree
    from trimesh.ray import ray_triangle

    mesh = trimesh.Trimesh(master.points, master.faces, process=False)
    if engine == "python":
        mesh.ray = ray_triangle.RayMeshIntersector(mesh)
    tree = cKDTree(master.points)                   # built once, as a fair lower bound
    points = np.vstack([s.points for s in slaves])

    def detect():
        inside = mesh.contains(points)
        dist, _ = tree.query(points[inside])
        return inside, dist

    return detect


def measure(decimate_faces: int) -> dict:
    """One resolution: solve, then time fecheck's and the thesis's detection there."""
    scene = load_scene(SCENE, [f"scanned.decimate_faces={decimate_faces}"])
    t0 = time.perf_counter()
    result = run_scene(scene)
    wall = time.perf_counter() - t0
    comps = build_compartments(scene)
    model = ContactModel(comps)
    rot, t = pose(np.asarray(result.pose.q), 0.0)
    ours = best_time(lambda: model(rot, t))
    eye, zero = np.eye(3), np.zeros(3)
    detect = best_time(lambda: [c.pair.evaluate((rot, t), (eye, zero)) for c in comps])
    master = comps[0].pair.master.mesh
    slaves = [c.pair.slave.transformed(rot, t) for c in comps]
    thesis = best_time(thesis_detection(slaves, master, "embree"), repeats=2)
    python = (best_time(thesis_detection(slaves, master, "python"), repeats=1)
              if master.n_faces <= PYTHON_RAYS_MAX_FACES else float("nan"))
    return {"decimate_faces": decimate_faces,
            "tibial_faces": sum(c.pair.slave.n_faces for c in comps),
            "femoral_faces": master.n_faces, "converged": result.converged,
            "iterations": result.iterations, "evaluations": result.record.evaluations,
            "solve_s": result.timing_s["solve"], "build_s": result.timing_s["build"],
            "run_wall_s": wall, "evaluation_ms": 1e3 * ours, "detection_ms": 1e3 * detect,
            "thesis_embree_ms": 1e3 * thesis, "thesis_python_ms": 1e3 * python,
            "ratio_embree_over_evaluation": thesis / ours,
            "ratio_embree_over_detection": thesis / detect,
            "ratio_python_over_evaluation": python / ours,
            "medial_force_N": result.compartments["medial"].force_N,
            "lateral_force_N": result.compartments["lateral"].force_N}


def main(argv: list[str] | None = None) -> int:
    args = knee_script_args(__doc__.splitlines()[0], "the 2,000-face decimation only", argv)
    if args is None:
        return 0
    rows = [measure(n) for n in ((2000,) if args.quick else (0, 5000, 2000))]
    args.out.mkdir(parents=True, exist_ok=True)
    with (args.out / "scanned_speed.csv").open("w", newline="") as fh:
        w = csv.DictWriter(fh, list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print("femur_tibia.toml: tibial / femoral faces, Newton iterations (evaluations), times; "
          "a contact evaluation = detection + law + tangent of both compartments; thesis = "
          "ray-parity contains + cKDTree of the tibial vertices (detection only)")
    for r in rows:
        print(f"  {r['tibial_faces']:5d} / {r['femoral_faces']:5d}: {r['iterations']} "
              f"({r['evaluations']}), solve {r['solve_s']:.2f} s, build {r['build_s']:.2f} s, "
              f"evaluation {r['evaluation_ms']:.1f} ms (detection {r['detection_ms']:.1f}); "
              f"thesis Embree {r['thesis_embree_ms']:.1f} ms "
              f"(×{r['ratio_embree_over_evaluation']:.2f} of an evaluation, "
              f"×{r['ratio_embree_over_detection']:.2f} of a detection), pure-Python rays "
              f"{r['thesis_python_ms']:.0f} ms (×{r['ratio_python_over_evaluation']:.0f}); "
              f"forces {r['medial_force_N']:.1f} / {r['lateral_force_N']:.1f} N, "
              f"converged {r['converged']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
