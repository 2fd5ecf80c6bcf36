"""`fecheck run --explain`: the plan, and a run that does nothing outside it.

Imports are checked in fresh interpreters (a pytest process has imported everything).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from fecheck.model.explain import plan_scene
from fecheck.scene import load_scene

PROBE = """
import json, sys
from fecheck.cli import main
code = main({argv!r})
{after}
print("PROBE " + json.dumps({{"code": code, "heavy": sorted(m for m in
      ("gmsh", "pyvista", "skfem", "igl", "fcl", "trimesh") if m in sys.modules)}}))
"""


def _run(argv: list[str], cache_dir, after: str = "") -> tuple[str, dict]:
    env = dict(os.environ, FECHECK_CACHE_DIR=str(cache_dir), OPENBLAS_NUM_THREADS="1")
    proc = subprocess.run([sys.executable, "-c", PROBE.format(argv=argv, after=after)],
                          capture_output=True, text=True, env=env, timeout=120, check=False)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    probe = json.loads(next(line for line in lines if line.startswith("PROBE "))[6:])
    return proc.stdout, probe


def test_rigid_scene_builds_no_mesh_and_imports_no_gmsh(tmp_path):
    out, probe = _run(["run", "--explain", "--set", "model.kind=rigid"], tmp_path)
    assert probe["code"] == 0
    assert "meshes: none" in out
    assert "audit: the run kept to the plan" in out
    assert probe["heavy"] == []
    assert not any(tmp_path.iterdir())           # nothing written to the mesh cache


def test_analytic_masters_build_no_bvh_and_a_run_without_plot_imports_no_pyvista(tmp_path):
    out, probe = _run(["run", "--explain"], tmp_path)
    assert probe["code"] == 0
    assert out.count("closed form (analytic sphere), no BVH") == 2     # medial, lateral
    assert "plots: skipped (no --plot)" in out
    assert "audit: the run kept to the plan" in out
    assert "igl" not in probe["heavy"] and "pyvista" not in probe["heavy"]
    assert "fcl" not in probe["heavy"] and "skfem" not in probe["heavy"]


def test_second_run_reuses_the_cached_meshes(tmp_path):
    """First run: both plateau meshes built (Gmsh imported); second run in a new process:
    both read from the cache and Gmsh is never imported. The plan prints both times."""
    first, p1 = _run(["run", "--explain"], tmp_path)
    second, p2 = _run(["run", "--explain"], tmp_path)
    built = next(line for line in first.splitlines() if "meshes:" in line)
    cached = next(line for line in second.splitlines() if "meshes:" in line)
    assert "0 from the cache, 2 built" in built and "gmsh" in p1["heavy"]
    assert "2 from the cache, 0 built" in cached and "gmsh" not in p2["heavy"]
    print(f"\nfirst: {built.strip()}\nsecond: {cached.strip()}")


def test_audit_reports_an_import_outside_the_plan(tmp_path):
    pytest.importorskip("trimesh")
    out, _ = _run(["run", "--explain", "--set", "model.kind=rigid"], tmp_path,
                  after="from fecheck.model import explain\n"
                        "from fecheck.scene import load_scene\n"
                        "plan = explain.plan_scene(load_scene(overrides=['model.kind=rigid']))\n"
                        "import trimesh\nprint('DEVIATIONS', plan.audit())")
    deviations = next(line for line in out.splitlines() if line.startswith("DEVIATIONS"))
    assert "trimesh (thesis stack) was imported but not planned" in deviations


def test_plan_lists_every_contact_pair_with_its_detection_path():
    plan = plan_scene(load_scene(overrides=["contact.master=plateau",
                                            "mesh.sphere_subdivisions=2"]))
    assert set(plan.pairs) == {"medial", "lateral"}
    for faces, how in plan.pairs.values():
        assert faces == 320
        assert how.startswith("closed form (analytic plane), no BVH")
    assert plan.meshes_built + plan.meshes_cached == 2
