"""Speed of the EF equilibrium with menisci (the target: "EF equilibrium with menisci under
1 s after the build").

Builds and solves the packaged scene ``femur_tibia_menisci`` (800 N, both menisci free)
several times in one process and reports the solve after the build (`fecheck.statics.
newton.solve`, the time `fecheck run` prints as "solve"): median and range of the wall
clock and of the process's CPU time, Newton iterations, contact evaluations. Interleaved
with each run it solves the same scene the way fecheck did before the meniscus volumes
got their side grid and tree (`fecheck.contact.winding`): libigl's winding number at
every point, the broad phase's points included, and gives the ratio of the medians and
the largest difference of the two runs' poses. Times are from a shared machine: read the
CPU times and the ratio; the wall clock moves with the load.

    python validation/menisci_speed.py [--quick] [--out DIR]

--quick: 2 runs of each (5 by default). Writes DIR/menisci_speed.csv.
"""

from __future__ import annotations

import csv
import sys
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.contact.mesh_master import MeshMaster
from fecheck.contact.winding import SideGrid, WindingTree
from fecheck.model import menisci
from fecheck.scene import load_scene
from fecheck.statics.newton import solve
from fecheck.studies.thesis.report import knee_script_args

SCENE = "femur_tibia_menisci"
RUNS, QUICK_RUNS = 5, 2


@contextmanager
def libigl_winding():
    """Within the block, mesh masters take every side from ``igl.winding_number`` (no side
    grid, the broad phase's points signed too), as before `fecheck.contact.winding`."""
    import igl

    saved = (WindingTree.__call__, SideGrid.sides, MeshMaster.margin_reach)

    def nothing(*tables):
        n = len(tables[-1])
        return np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)

    WindingTree.__call__ = lambda self, p: igl.winding_number(self._points, self._faces, p)
    SideGrid.sides = staticmethod(nothing)
    MeshMaster.margin_reach = lambda self, margin_mm: self.reach
    try:
        yield
    finally:
        WindingTree.__call__, SideGrid.sides, MeshMaster.margin_reach = saved


def timed_solve() -> dict:
    """Build and solve the scene once: build and solve wall seconds, solve CPU seconds,
    iterations, evaluations and the tibia's coordinates (6,)."""
    t0 = time.perf_counter()
    problem = menisci.build_problem(load_scene(SCENE))[0]
    t1, c1 = time.perf_counter(), time.process_time()
    sol = solve(problem)
    return {"build_s": t1 - t0, "solve_s": time.perf_counter() - t1,
            "solve_cpu_s": time.process_time() - c1, "iterations": sol.iterations,
            "evaluations": sol.evaluations, "converged": sol.converged,
            "q": np.concatenate(sol.q)}


def main(argv=None) -> int:
    args = knee_script_args(__doc__.splitlines()[0], f"{QUICK_RUNS} runs of each", argv)
    if args is None:
        return 0
    rows = []
    for run in range(QUICK_RUNS if args.quick else RUNS):
        for path in ("fecheck", "libigl"):
            if path == "libigl":
                with libigl_winding():
                    row = timed_solve()
            else:
                row = timed_solve()
            rows.append({"run": run, "path": path, **row})
            print(f"run {run} {path:8s} build {row['build_s']:.2f} s, solve "
                  f"{row['solve_s']:.3f} s wall / {row['solve_cpu_s']:.3f} s CPU, "
                  f"{row['iterations']} iterations, {row['evaluations']} evaluations",
                  flush=True)
    q = {p: np.array([r["q"] for r in rows if r["path"] == p]) for p in ("fecheck", "libigl")}
    print(f"largest pose difference between the paths: "
          f"{np.abs(q['fecheck'] - q['libigl']).max():.3g} (mm, rad)")
    for key in ("solve_s", "solve_cpu_s"):
        med = {p: float(np.median([r[key] for r in rows if r["path"] == p])) for p in q}
        spread = {p: (min(r[key] for r in rows if r["path"] == p),
                      max(r[key] for r in rows if r["path"] == p)) for p in q}
        print(f"{key}: fecheck median {med['fecheck']:.3f} ({spread['fecheck'][0]:.3f}-"
              f"{spread['fecheck'][1]:.3f}), libigl {med['libigl']:.3f} "
              f"({spread['libigl'][0]:.3f}-{spread['libigl'][1]:.3f}), ratio "
              f"{med['libigl'] / med['fecheck']:.2f}")
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "menisci_speed.csv"
    fields = ["run", "path", "build_s", "solve_s", "solve_cpu_s", "iterations",
              "evaluations", "converged"]
    with path.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {path}")
    return 0 if all(r["converged"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
