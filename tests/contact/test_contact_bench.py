"""The detection benchmark (smoke run) and the locality of the per-call work."""

import json
import time

import numpy as np
import pytest

from fecheck.cli import main
from fecheck.contact import ContactPair, Sphere
from fecheck.studies import bench_detection as bench
from geometry.plateau import plane_patch


def test_bench_smoke_run_reports_rows_ratios_json_and_plot(tmp_path):
    result = bench.run(levels=(3,), plateau_sizes=(2.0,), locality_radii=(10.0, 15.0),
                       budget_s=0.05)
    rows = {(r["scenario"], r["method"]): r for r in result["rows"] if "time_ms" in r}
    # Our clipped detection on the bisected icosphere is within faceting (−0.5 % area at
    # 1,280 faces); the thesis's whole-face counting (fcl) overestimates the 1 mm cap
    # area by ~+19 %, its nearest-vertex ray-parity depth is off by orders of magnitude
    # against the coarse box master.
    assert abs(rows["bisect", "closed-form"]["area_rel_error"]) < 0.01
    assert rows["statics", "fcl"]["area_rel_error"] > 0.10
    assert rows["statics", "ray-parity"]["volume_rel_error"] > 10.0
    assert rows["mesh-mesh", "bvh"]["n_contact_faces"] > 0
    assert "mesh_mesh_1280" not in result["ratios"]          # ratios name their sizes
    bench.write_json(result, tmp_path / "b.json")
    assert json.loads((tmp_path / "b.json").read_text())["rows"]
    assert bench.plot(result, tmp_path)[0].stat().st_size > 10_000
    assert "ratios (same run)" in bench.table(result)


def test_bench_verb_is_registered(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["bench", "--help"])
    assert exit_info.value.code == 0
    assert "detection" in capsys.readouterr().out


def _two_plateaus():
    """Two plateaus refined alike (0.5 mm) under the contact, one 4x wider (~6x the
    faces), each in a pair evaluated once: ((faces, pair) small, (faces, pair) large)."""
    master = (np.eye(3), np.array([0.0, 0.0, 31.8 - 1.0]))
    pairs = []
    for radius in (15.0, 60.0):
        plateau = plane_patch([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], radius=radius, size=1.0,
                              refine_point=[0.0, 0.0, 0.0], refine_size=0.5,
                              refine_radius=12.0)
        pair = ContactPair(plateau, Sphere([0.0, 0.0, 0.0], 31.8))
        pair.evaluate((np.eye(3), np.zeros(3)), master)
        pairs.append((plateau.n_faces, pair))
    return pairs


def test_per_call_work_is_the_faces_near_contact_not_all_faces():
    # the same candidate faces on ~6x the faces, and moving within the candidate set's
    # margin never rebuilds it
    (n_small, small), (n_large, large) = _two_plateaus()
    assert n_large > 5 * n_small
    # (within 10 %: the sets also hold faces up to an edge outside the margin, and the
    # wider plateau's edges there are coarser)
    assert abs(large.cache.current.faces.size / small.cache.current.faces.size - 1) < 0.1
    master = (np.eye(3), np.array([0.0, 0.0, 31.8 - 1.0]))
    for k in range(5):
        for pair in (small, large):
            pair.evaluate((np.eye(3), np.array([0.01 * k, 0.0, 0.005 * k])), master)
    assert small.cache.n_rebuilds == large.cache.n_rebuilds == 1


@pytest.mark.bench
def test_time_per_call_follows_faces_near_contact_not_all_faces():
    # with the candidate set reused the time per call must not grow with the total
    # (loose bound: < 2.5x, timed interleaved)
    (_, small), (_, large) = _two_plateaus()
    master = (np.eye(3), np.array([0.0, 0.0, 31.8 - 1.0]))
    poses = [(np.eye(3), np.array([0.01 * k, 0.0, 0.005 * k])) for k in range(5)]
    times = {id(small): [], id(large): []}
    for k in range(60):
        for pair in (small, large):
            t0 = time.process_time()
            pair.evaluate(poses[k % 5], master)
            times[id(pair)].append(time.process_time() - t0)
    ratio = np.median(times[id(large)]) / np.median(times[id(small)])
    assert ratio < 2.5
