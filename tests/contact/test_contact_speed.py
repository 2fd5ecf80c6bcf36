"""Compiled contact path (issues 3, 4): light CLI imports, the compiled broad-phase
selection against a NumPy reference, and the evaluation benchmark's measurement."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fecheck.contact.bvh import PointTree
from geometry.icosphere import icosahedron, icosphere
from geometry.io import save_mesh
from geometry.mesh import TriMesh

VALIDATION = Path(__file__).resolve().parents[2] / "validation"


def test_help_and_mesh_info_do_not_import_numba(tmp_path):
    # numba (and llvmlite) are loaded only by the run path: `fecheck --help` and
    # `fecheck mesh info` must stay light.
    mesh = tmp_path / "ico.stl"
    save_mesh(TriMesh(*icosahedron()), mesh)
    env = dict(os.environ, FECHECK_CACHE_DIR=str(tmp_path / "cache"))
    for args in (["--help"], ["mesh", "info", str(mesh)]):
        code = (f"import sys\nfrom fecheck.cli import main\ntry:\n    main({args!r})\n"
                "except SystemExit:\n    pass\nprint(sorted(m for m in sys.modules "
                "if m.split('.')[0] in ('numba', 'llvmlite')))")
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             env=env, check=True)
        assert out.stdout.strip().splitlines()[-1] == "[]", (args, out.stdout[-300:])


def test_compiled_candidate_selection_matches_numpy_reference():
    # faces with a vertex flagged near, their vertices (np.unique) and local corners
    mesh = icosphere(10.0, 3)
    tree = PointTree(mesh.points, mesh.faces, mesh.face_normals, mesh.face_areas)
    rng = np.random.default_rng(3)
    for fraction in (0.0, 0.05, 0.5, 1.0):
        near = rng.random(mesh.n_points) < fraction
        faces, vertices, local, points, normals, areas = tree.faces_of(
            rng.permutation(np.flatnonzero(near)))
        ref_faces = np.flatnonzero(near[mesh.faces].any(axis=1))
        np.testing.assert_array_equal(faces, ref_faces)
        np.testing.assert_array_equal(np.sort(vertices), np.unique(mesh.faces[ref_faces]))
        assert len(set(vertices.tolist())) == len(vertices)
        np.testing.assert_array_equal(vertices[local], mesh.faces[faces])
        np.testing.assert_array_equal(points, mesh.points[vertices])
        np.testing.assert_array_equal(normals, mesh.face_normals[faces])
        np.testing.assert_array_equal(areas, mesh.face_areas[faces])
    assert (tree.vertex_index == -1).all() and not tree.face_bits.any()   # left clean


def _measure():
    from fecheck.studies import bench_evaluation

    return bench_evaluation, bench_evaluation.measure(0.05, thesis=False)


def test_evaluation_benchmark_measures_every_quantity():
    # A short measurement (no thesis stack): every quantity is timed and reported.
    bench_evaluation, result = _measure()
    sec = result["seconds"]
    for case in ("plane", "sphere"):
        assert {f"{case}_evaluate", f"{case}_law", f"{case}_evaluate_law"} <= set(sec)
        assert result["sizes"][case]["contact_faces"] > 50
    assert result["sizes"]["plane"]["slave_faces"] == 5120
    assert all(v > 0 for v in sec.values())
    lines = bench_evaluation.report(sec)
    assert any("timing_s.solve" in line for line in lines)


@pytest.mark.bench
def test_the_baseline_solve_costs_a_few_hundred_evaluations():
    # The whole baseline solve (~8 Newton evaluations of two compartments, plus
    # broad-phase rebuilds) stays within a few hundred contact-and-tangent evaluations
    # of the sphere-master compartment (loose: it guards against per-iteration overhead,
    # not against machine load).
    _, result = _measure()
    sec = result["seconds"]
    assert sec["solve_condyle"] < 300 * sec["sphere_evaluate_law"]
