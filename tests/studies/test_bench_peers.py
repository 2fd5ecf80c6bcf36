"""`fecheck bench peers` on its quick sizes: the JSON schema, ratios, skipped peers, and
that every method sees the same contact (times are only checked to be positive)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from fecheck.studies import bench_peers

ROW_KEYS = {"method", "faces", "mode", "us", "us_min", "us_max"}
MODES = {("fecheck", "reused"), ("fecheck", "scratch"), ("drake", "query"), ("opensim", "ef")}
FACES = [20 * 4**level for level in bench_peers.LEVELS_QUICK]


@pytest.fixture(scope="module")
def result():
    return json.loads(json.dumps(bench_peers.run(quick=True)))    # as written by the CLI


def _checks(result, method, mode):
    """Contact checks of one method and mode by face count."""
    return {c["faces"]: c for c in result["checks"] if (c["method"], c["mode"]) == (method, mode)}


def _present(result, peer):
    if peer in result["skipped"]:
        pytest.skip(f"{peer}: {result['skipped'][peer]}")


def test_json_schema(result):
    assert {"rows", "ratios", "skipped", "machine"} <= set(result)
    for r in result["rows"]:
        assert set(r) == ROW_KEYS
        assert (r["method"], r["mode"]) in MODES and r["faces"] in FACES
        assert isinstance(r["faces"], int) and 0 < r["us_min"] <= r["us"] <= r["us_max"]
    keys = {(r["method"], r["mode"], r["faces"]) for r in result["rows"]}
    assert {("fecheck", m, n) for m in ("reused", "scratch") for n in FACES} <= keys
    assert set(result["ratios"]) == set(bench_peers.RATIOS)
    assert "cpus" in result["machine"]
    assert "1,280" in bench_peers.table(result)


def test_ratios_are_positive_and_finite_for_present_peers_and_empty_for_skipped(result):
    for name, by_faces in result["ratios"].items():
        peer = bench_peers.RATIOS[name][1][0]
        if peer in result["skipped"]:
            assert by_faces == {}
        else:
            assert set(by_faces) == {str(n) for n in FACES}
            assert all(math.isfinite(v) and v > 0 for v in by_faces.values())


def test_every_peer_is_timed_or_named_as_skipped(result):
    for peer in bench_peers.PEERS:
        rows = [r for r in result["rows"] if r["method"] == peer]
        if peer in result["skipped"]:
            assert not rows and peer in result["skipped"][peer]
        else:
            assert len(rows) == len(bench_peers.LEVELS_QUICK)


def test_a_missing_or_failing_peer_is_skipped_with_its_reason(monkeypatch):
    def broken(mesh, folder):
        raise RuntimeError("no licence")

    monkeypatch.setitem(bench_peers.PEER_MODULES, "drake", "no_such_module_for_fecheck")
    monkeypatch.setitem(bench_peers.PEER_MODULES, "opensim", "numpy")   # "installed"
    monkeypatch.setitem(bench_peers.PEERS, "opensim", broken)
    out = bench_peers.run(quick=True)
    assert "not installed" in out["skipped"]["drake"] and "[peers]" in out["skipped"]["drake"]
    assert "no licence" in out["skipped"]["opensim"]
    assert {r["method"] for r in out["rows"]} == {"fecheck"}
    assert all(v == {} for v in out["ratios"].values())


def test_reused_and_scratch_give_the_same_force(result):
    reused = _checks(result, "fecheck", "reused")
    scratch = _checks(result, "fecheck", "scratch")
    assert set(reused) == set(scratch) == set(FACES)
    for faces, c in reused.items():
        assert c["force_N"] > 0
        assert scratch[faces]["force_N"] == pytest.approx(c["force_N"], rel=1e-12)


def test_the_evaluator_follows_the_pose_and_scratch_matches_reused_wrench_and_tangent():
    reused, scratch = (bench_peers.fecheck_evaluator(3, scratch=s) for s in (False, True))
    forces = []
    for dz in (0.0, 1e-4, 0.0, 1e-4):                  # the benchmark's two poses, mm
        pose = (np.eye(3), np.array([0.0, 0.0, 24.5 + dz]))
        (w, t), (w0, t0) = reused(pose), scratch(pose)
        (f, m), (f0, m0) = (w[:3], w[3:]), (w0[:3], w0[3:])
        scale = np.linalg.norm(f0)
        np.testing.assert_allclose(f, f0, rtol=1e-12, atol=1e-12 * scale)
        np.testing.assert_allclose(m, m0, rtol=1e-12, atol=1e-12 * scale * 25.5)
        assert t.shape == (6, 6)
        np.testing.assert_allclose(t, t0, rtol=1e-12, atol=1e-12 * np.abs(t0).max())
        forces.append(f[2])
    assert forces[0] != forces[1] and forces[0] == forces[2]    # recomputed at each pose


def test_drake_contact_is_the_sphere_zone_with_fechecks_force(result):
    """Drake's surface is the rigid mesh inside the half space (area ≈ 2πRd) and its
    linear pressure field integrates to fecheck's clipped EF force."""
    _present(result, "drake")
    ours = _checks(result, "fecheck", "reused")
    checks = _checks(result, "drake", "query")
    assert set(checks) == set(FACES)
    for faces, c in checks.items():
        assert 0.9 < c["area_mm2"] / (2 * math.pi * 25.5 * 1.0) < 1.01
        assert c["force_N"] == pytest.approx(ours[faces]["force_N"], rel=1e-9)


def test_opensim_contact_force_is_near_fechecks(result):
    """Simbody's elastic foundation (one spring per face) within 1% of fecheck's force."""
    _present(result, "opensim")
    ours = _checks(result, "fecheck", "reused")
    checks = _checks(result, "opensim", "ef")
    assert set(checks) == set(FACES)
    for faces, c in checks.items():
        assert c["force_N"] > 0
        assert c["force_N"] == pytest.approx(ours[faces]["force_N"], rel=0.01)
