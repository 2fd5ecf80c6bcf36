"""Speed of one contact-and-tangent evaluation and of the whole baseline solve.

Measured together, interleaved (the machine is shared: compare ratios within one run):

* one evaluation at 5,120 faces: `ContactPair.evaluate`, the EF law on its surface, and
  both (the contact-and-tangent evaluation the statics calls), for ``plane`` (an
  icosphere slave, R 25.5 mm, 5,120 faces, 1 mm into an analytic plane) and ``sphere``
  (the baseline's analytic sphere master over its meshed plateau, 0.8 mm under the
  contact, at the baseline equilibrium);
* the baseline equilibrium (`fecheck run`, both condyles, all Newton iterations):
  ``timing_s.solve`` for contact.master = condyle (default) and = plateau;
* one thesis-stack contact query at 5,120 faces, as the thesis ran it (structures rebuilt
  per query): trimesh's ``CollisionManager`` built with both meshes +
  ``in_collision_internal(return_data=True)``, and raw python-fcl (triangle BVHs built +
  ``collide`` with all contacts), the same icosphere 1 mm into the top of a box;
* the numba compile time of the first evaluation, with a cold cache and with the on-disk
  cache (fresh processes, ``NUMBA_CACHE_DIR`` in a temporary directory).

``--compare TREE`` measures another source tree of fecheck (e.g. an older commit
exported with ``git archive``) in subprocesses alternating with this one, and prints
the speed-ups and both trees' ratios. The thesis-stack queries need python-fcl (the
thesis extra); without it they are left out.

    python validation/bench_evaluation.py [--quick] [--compare TREE]
    python -m fecheck.studies.bench_evaluation [--quick] [--compare TREE]

--quick: 2 s of timing per measurement instead of 10, and no numba compile times (the
fresh process with a cold cache alone takes about as long as the rest).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from fecheck import laws
from fecheck.contact import ContactPair, Plane
from fecheck.model.run import run_scene
from fecheck.model.sphere_plane import build_compartments
from fecheck.scene import load_scene
from fecheck.statics.newton import pose
from geometry.icosphere import icosphere

R_SLAVE_MM = 25.5
DEPTH_MM = 1.0
LEVEL = 4                                     # 20·4^4 = 5,120 faces
FCL_MAX_CONTACTS = 100_000
BURST = 20                                    # calls per timing of a single evaluation
ROOT = Path(__file__).resolve().parents[2]
"""The source tree this module belongs to (``--compare`` measures it beside another)."""


def _plane_case():
    pair = ContactPair(icosphere(R_SLAVE_MM, LEVEL), Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]))
    slave = (np.eye(3), np.array([0.0, 0.0, R_SLAVE_MM - DEPTH_MM]))
    return pair, slave, (np.eye(3), np.zeros(3))


def _sphere_case():
    """The baseline's medial compartment (sphere master, plateau slave) at equilibrium."""

    scene = load_scene(None)
    rot, t = pose(np.asarray(run_scene(scene).pose.q))
    comp = build_compartments(scene)[0]
    return comp.pair, (rot, t), (np.eye(3), np.zeros(3))


def _box(half: float, depth: float):
    import trimesh

    box = trimesh.creation.box(extents=[2 * half, 2 * half, depth])
    box.apply_translation([0.0, 0.0, -depth / 2])
    return box


def _thesis_queries() -> dict:
    """Callables: one thesis-stack query each, structures built inside (as per query)."""
    import fcl
    import trimesh
    from trimesh.collision import CollisionManager, mesh_to_BVH


    ico = icosphere(R_SLAVE_MM, LEVEL)
    slave = trimesh.Trimesh(ico.points + [0.0, 0.0, R_SLAVE_MM - DEPTH_MM], ico.faces,
                            process=False)
    master = _box(3 * R_SLAVE_MM, 3 * R_SLAVE_MM)

    def manager():
        m = CollisionManager()
        m.add_object("slave", slave)
        m.add_object("master", master)
        _, contacts = m.in_collision_internal(return_data=True)
        return len(contacts)

    def raw_fcl():
        a = fcl.CollisionObject(mesh_to_BVH(slave), fcl.Transform())
        b = fcl.CollisionObject(mesh_to_BVH(master), fcl.Transform())
        request = fcl.CollisionRequest(num_max_contacts=FCL_MAX_CONTACTS, enable_contact=True)
        result = fcl.CollisionResult()
        fcl.collide(a, b, request, result)
        return len(result.contacts)

    return {"trimesh_manager": manager, "fcl_bvh": raw_fcl}


def thesis_stack() -> bool:
    """True when python-fcl is installed; else says on stderr that the thesis-stack
    queries are left out."""
    if importlib.util.find_spec("fcl") is None:
        print("thesis-stack queries left out: fcl is not installed (the thesis extra: pip "
              "install python-fcl)", file=sys.stderr)
        return False
    return True


def _timed(fn, burst: int = 1):
    """Seconds per call of `fn`, from a burst of calls (µs-scale calls are timed in bursts
    of 20 so that each measurement sees warm caches, as in a Newton loop)."""
    def call():
        t0 = time.perf_counter()
        for _ in range(burst):
            fn()
        return (time.perf_counter() - t0) / burst
    return call


def measure(budget_s: float, thesis: bool = True) -> dict:
    """Median seconds of every quantity, measured in turn (interleaved) for `budget_s`."""
    import warnings


    k = laws.ef_stiffness(20.0, 0.3, 6.0)
    calls = {}
    sizes = {}
    for name, case in (("plane", _plane_case), ("sphere", _sphere_case)):
        pair, slave_pose, master_pose = case()
        surface = pair.evaluate(slave_pose, master_pose)
        laws.elastic_foundation(surface, k)
        sizes[name] = {"contact_faces": int(surface.n_faces), "points": len(surface.qp_depth),
                       "slave_faces": int(pair.slave.n_faces)}
        calls[f"{name}_evaluate"] = _timed(lambda p=pair, s=slave_pose, m=master_pose:
                                           p.evaluate(s, m), BURST)
        calls[f"{name}_law"] = _timed(lambda s=surface: laws.elastic_foundation(s, k), BURST)
        calls[f"{name}_evaluate_law"] = _timed(
            lambda p=pair, s=slave_pose, m=master_pose:
            laws.elastic_foundation(p.evaluate(s, m), k), BURST)
    for master in ("condyle", "plateau"):
        scene = load_scene(None, [f"contact.master={master}"])
        run_scene(scene)
        calls[f"solve_{master}"] = lambda s=scene: run_scene(s).timing_s["solve"]
    if thesis:
        for name, fn in _thesis_queries().items():
            fn()
            calls[name] = _timed(fn)
    times = {key: [] for key in calls}
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        while min(len(v) for v in times.values()) < 5 or time.perf_counter() - start < budget_s:
            for key, call in calls.items():
                times[key].append(call())
    return {"seconds": {key: float(np.median(v)) for key, v in times.items()},
            "repeats": {key: len(v) for key, v in times.items()}, "sizes": sizes}


_JIT_PROBE = """
import time, numpy as np
t0 = time.perf_counter()
from fecheck import laws
from fecheck.contact import ContactPair, Plane, Sphere
from geometry.icosphere import icosphere
t1 = time.perf_counter()
ico = icosphere(25.5, 2)
for master in (Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]), Sphere([0.0, 0.0, 24.5], 25.5)):
    pair = ContactPair(ico, master)
    laws.elastic_foundation(pair.evaluate((np.eye(3), np.array([0.0, 0.0, 24.5])),
                                          (np.eye(3), np.zeros(3))), 4.0)
t2 = time.perf_counter()
print(t1 - t0, t2 - t1)
"""


def jit_times() -> dict:
    """Import time and first plane + sphere evaluation (with the law) in fresh processes:
    cold numba cache, then the on-disk cache it wrote."""
    out = {}
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        for label in ("cold", "cached"):
            text = subprocess.run([sys.executable, "-c", _JIT_PROBE], env=env, check=True,
                                  capture_output=True, text=True).stdout.split()
            out[f"import_{label}"], out[f"first_evaluations_{label}"] = map(float, text)
    return out


def _subprocess_measure(tree: Path, budget_s: float) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree))
    text = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--measure-json",
                           "--budget", str(budget_s)], env=env, cwd=tree, check=True,
                          capture_output=True, text=True).stdout
    return json.loads(text.strip().splitlines()[-1])


def report(sec: dict) -> list[str]:
    """The speed ratios, from median seconds."""
    us = {k: 1e6 * v for k, v in sec.items()}
    lines = [("one evaluation (µs, median; plane: 5,120-face icosphere slave, sphere: the "
              "baseline plateau slave):")]
    for case in ("plane", "sphere"):
        lines.append(f"  {case:7s} evaluate {us[f'{case}_evaluate']:8.1f}   law "
                     f"{us[f'{case}_law']:7.1f}   contact-and-tangent "
                     f"{us[f'{case}_evaluate_law']:8.1f}")
    lines.append("baseline solve, timing_s.solve (ms): "
                 f"condyle master {1e3 * sec['solve_condyle']:.2f}, "
                 f"plateau master {1e3 * sec['solve_plateau']:.2f}")
    if "fcl_bvh" in sec:
        lines.append("one thesis-stack query at 5,120 faces (ms): trimesh CollisionManager "
                     f"{1e3 * sec['trimesh_manager']:.2f}, raw fcl BVH {1e3 * sec['fcl_bvh']:.2f}")
        for master in ("condyle", "plateau"):
            s = sec[f"solve_{master}"]
            lines.append(f"  whole baseline solve ({master} master) / one query: "
                         f"{s / sec['trimesh_manager']:.2f} (trimesh), "
                         f"{s / sec['fcl_bvh']:.2f} (fcl)")
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="short timing budget")
    ap.add_argument("--compare", type=Path, help="another fecheck source tree to compare")
    ap.add_argument("--budget", type=float, help="seconds of timing per measurement")
    ap.add_argument("--measure-json", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    budget = args.budget or (2.0 if args.quick else 10.0)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    thesis = thesis_stack()
    if args.measure_json:
        print(json.dumps(measure(budget, thesis)))
        return 0
    if args.compare is None:
        result = measure(budget, thesis)
        print(f"contact sizes: {result['sizes']}")
        print("\n".join(report(result["seconds"])))
    else:
        rounds = 2 if args.quick else 4
        runs = {"this": [], "other": []}
        for _ in range(rounds):                # alternate the trees: same machine load
            runs["other"].append(_subprocess_measure(args.compare.resolve(), budget / rounds))
            runs["this"].append(_subprocess_measure(ROOT, budget / rounds))
        sec = {tree: {k: float(np.median([r["seconds"][k] for r in rs]))
                      for k in rs[0]["seconds"]} for tree, rs in runs.items()}
        print(f"{'quantity (µs)':24s}{'other':>12s}{'this':>12s}{'speed-up':>10s}")
        for key in sec["this"]:
            a, b = sec["other"][key], sec["this"][key]
            print(f"{key:24s}{1e6 * a:12.1f}{1e6 * b:12.1f}{a / b:10.2f}")
        for tree in ("other", "this"):
            print(f"{tree}:")
            print("\n".join(report(sec[tree])))
    if args.quick:
        print("numba compile times: not measured with --quick")
        return 0
    jit = jit_times()
    print(f"numba: first plane + sphere evaluation with the law "
          f"{jit['first_evaluations_cold']:.2f} s with a cold cache, "
          f"{jit['first_evaluations_cached']:.2f} s cached; import of the contact modules "
          f"{jit['import_cold']:.2f} s / {jit['import_cached']:.2f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
