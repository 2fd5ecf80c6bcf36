"""`fecheck population`: the Sobol estimator on the Ishigami function (exact indices from
its closed form), each refused input, and a small study of the baseline scene."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from fecheck.cli import main
from fecheck.studies.population_inputs import parse_distribution
from fecheck.studies.sobol import design, sobol_indices

ISHIGAMI_A, ISHIGAMI_B = 7.0, 0.1


def _ishigami_exact() -> tuple[np.ndarray, np.ndarray]:
    """(S1, ST) of f = sin x1 + a sin² x2 + b x3⁴ sin x1, x ~ U(−π, π)³ (Ishigami & Homma
    1990; Saltelli et al. 2008 §4.6): V1 = ½(1 + bπ⁴/5)², V2 = a²/8, V13 = b²π⁸(1/18 −
    1/50), V = V1 + V2 + V13."""
    a, b, pi = ISHIGAMI_A, ISHIGAMI_B, math.pi
    v1 = 0.5 * (1.0 + b * pi**4 / 5.0) ** 2
    v2 = a**2 / 8.0
    v13 = b**2 * pi**8 * (1.0 / 18.0 - 1.0 / 50.0)
    v = v1 + v2 + v13
    return np.array([v1, v2, 0.0]) / v, np.array([v1 + v13, v2, v13]) / v


@pytest.mark.parametrize("method", ["sobol", "lhs"])
def test_sobol_indices_of_the_ishigami_function_match_the_closed_form(method):
    # the verb's path: Saltelli's design in the unit cube, each key's distribution
    # (uniform:-pi:pi), SALib's estimator on the evaluations
    u = design(4096, 3, method, seed=1)
    dist = parse_distribution(f"uniform:{-math.pi!r}:{math.pi!r}")
    x = dist.value(u, 0.0)
    y = (np.sin(x[:, 0]) + ISHIGAMI_A * np.sin(x[:, 1]) ** 2
         + ISHIGAMI_B * x[:, 2] ** 4 * np.sin(x[:, 0]))
    got = sobol_indices(y, ["x1", "x2", "x3"])
    s1, st = _ishigami_exact()
    # measured: largest error 0.001 (sobol) and 0.02 (lhs, 4,096 base rows, seed 1)
    tol = 0.02 if method == "sobol" else 0.03
    assert np.abs(got.s1 - s1).max() < tol
    assert np.abs(got.st - st).max() < tol
    assert got.groups == 4096
    # the intervals cover the exact values
    assert np.all(np.abs(got.st - st) <= got.st_conf + 1e-3)


def test_the_bootstrap_intervals_are_fixed_by_the_seed_zero_included():
    # a study's default seed is 0: its intervals must not change from run to run (a study
    # on a cluster is compared with the serial one to the last digit)
    u = design(256, 3, "sobol", seed=0)
    y = np.sin(2.0 * u[:, 0]) + 0.3 * u[:, 1] ** 2 + 0.1 * u[:, 0] * u[:, 2]
    for seed in (0, 7):
        a = sobol_indices(y, ["x1", "x2", "x3"], seed=seed)
        np.random.seed(12345)                   # whatever the global generator holds
        b = sobol_indices(y, ["x1", "x2", "x3"], seed=seed)
        assert np.array_equal(a.s1_conf, b.s1_conf) and np.array_equal(a.st_conf, b.st_conf)


def test_a_failed_run_drops_its_whole_base_row():
    u = design(64, 2, "sobol", seed=3)
    y = u[:, 0] + 0.5 * u[:, 1] ** 2
    y[5] = math.nan
    assert sobol_indices(y, ["a", "b"]).groups == 63


def _run(argv, capsys):
    code = main(["population", *argv])
    return code, capsys.readouterr()


@pytest.mark.parametrize("argv, message", [
    (["--vary", "contact.youngs=uniform:10:30", "--samples", "40"],
     "unknown scene key 'contact.youngs'"),
    (["--vary", "contact.poisson=uniform:0.3:0.6", "--samples", "40"],
     "draws a value of 0.6"),
    (["--vary", "contact.youngs_MPa=normal:20:8", "--samples", "40"],
     "outside what the scene accepts"),
    (["--vary", "contact.youngs_MPa=uniform:10:30", "--samples", "20"],
     "Sobol indices of 1 key(s) need at least 24 samples"),
    (["--vary", "contact.youngs_MPa=gauss:10:30", "--samples", "40"],
     "expected uniform:LO:HI"),
    (["--vary", "load.point_mm=uniform:1:2", "--samples", "40"],
     "a vector key takes scale:LO:HI"),
])
def test_bad_input_is_refused_in_one_line_before_any_sample(argv, message, capsys):
    code, out = _run(argv, capsys)
    assert code == 2
    lines = out.err.strip().splitlines()
    assert len(lines) == 1 and message in lines[0]
    assert "population [" not in out.err


def test_a_key_that_rebuilds_meshes_at_every_sample_is_refused_with_its_cost(capsys):
    # the plateau's element size: a new gmsh mesh at each sample
    code, out = _run(["--vary", "mesh.plateau_refine_mm=uniform:0.5:0.7",
                      "--samples", "24"], capsys)
    assert code == 2
    line = out.err.strip().splitlines()[-1]
    assert "rebuilds the model's meshes" in line and "more for 24 samples" in line
    assert "population [" not in out.err


def test_baseline_study_split_is_set_by_the_load_point_alone(tmp_path, capsys):
    """With the tibia free in z and abduction, the medial share is set by moment
    balance: by the load point's lever arm, not by the cartilage modulus or the load."""
    out_csv, out_json = tmp_path / "pop.csv", tmp_path / "pop.json"
    argv = ["--vary", "load.point_mm[0]=uniform:3:12", "--vary",
            "contact.youngs_MPa=lognormal:20:4", "--samples", "64", "--csv", str(out_csv),
            "--json", str(out_json), "--outputs", "medial_share", "max_pressure_MPa"]
    code, out = _run(argv, capsys)
    assert code == 0, out.err
    data = json.loads(out_json.read_text())
    assert data["failed"]["count"] == 0 and data["finished"] == 64
    assert data["provenance"]["scene"]["set_keys"] == []    # the provenance of every --json
    split = data["indices"]["medial_share"]["inputs"]
    assert split["load.point_mm[0]"]["ST"] > 0.9
    assert split["contact.youngs_MPa"]["ST"] < 0.01
    # the modulus drives the peak pressure
    peak = data["indices"]["max_pressure_MPa"]["inputs"]
    assert peak["contact.youngs_MPa"]["ST"] > peak["load.point_mm[0]"]["ST"]
    rows = list(csv.DictReader(out_csv.open()))
    assert len(rows) == 64

    # resume: half of the rows removed, the same command runs only the missing ones
    lines = out_csv.read_text().splitlines()
    out_csv.write_text("\n".join(lines[:33]) + "\n")
    code, out = _run(argv, capsys)
    assert code == 0 and "resuming: 32 of 64 samples" in out.err
    again = list(csv.DictReader(out_csv.open()))
    # every sample starts from the baseline pose with fresh contact state: the samples run
    # again equal the first run's to the last digit (the CSV keeps each number's repr)
    assert [_untimed(r) for r in again] == [_untimed(r) for r in rows]

    # a CSV of another study is not resumed
    code, out = _run([*argv[:4], "--samples", "64", "--seed", "5", "--csv", str(out_csv)],
                     capsys)
    assert code == 2 and "holds samples of another study" in out.err


def _untimed(row: dict[str, str]) -> dict[str, str]:
    """A CSV row without its timing columns (which differ from run to run)."""
    return {k: v for k, v in row.items() if k not in ("build_s", "solve_s")}


def test_a_study_on_a_local_dask_cluster_equals_the_serial_one(tmp_path, capsys):
    """The same samples on two Dask worker processes give every number of the serial
    study (each sample depends on its values alone, not on where or after what it ran)."""
    distributed = pytest.importorskip(
        "distributed", reason="the Dask check needs the dask extra: pip install 'fecheck[dask]'")
    argv = ["--vary", "load.point_mm[0]=uniform:3:12", "--vary",
            "contact.youngs_MPa=lognormal:20:4", "--samples", "24", "--indices", "none",
            "--outputs", "medial_share", "max_pressure_MPa"]
    code, out = _run([*argv, "--csv", str(tmp_path / "serial.csv")], capsys)
    assert code == 0, out.err
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        code, out = _run([*argv, "--csv", str(tmp_path / "dask.csv"), "--scheduler",
                          cluster.scheduler_address], capsys)
    assert code == 0, out.err
    serial = [_untimed(r) for r in csv.DictReader((tmp_path / "serial.csv").open())]
    cluster_rows = [_untimed(r) for r in csv.DictReader((tmp_path / "dask.csv").open())]
    assert len(serial) == 24 and cluster_rows == serial


def test_a_sample_not_solved_from_the_baseline_pose_is_reached_by_a_continuation():
    """With Newton cut to 3 iterations, the baseline's equilibrium at the far ends of the
    load point and modulus is not reached from the baseline pose, but is along a path from
    the scene's values: the same equilibrium as the uncut solve's (to its tolerance).
    Cut to 2 iterations, no path gets there either: the unconverged direct result is
    kept (the study counts it as not converged)."""
    from fecheck.scene import load_scene
    from fecheck.studies.population import baseline_pose, solve_sample
    from fecheck.studies.population_inputs import parse_varied

    keys = ["load.point_mm[0]=uniform:3:12", "contact.youngs_MPa=uniform:10:30"]
    full = load_scene("baseline", [])
    start = baseline_pose(full)
    for u in ([1.0, 1.0], [0.0, 0.0]):
        ref, steps = solve_sample(full, parse_varied(keys, full), np.array(u), start, {})
        assert ref.converged and steps == 0
        cut = load_scene("baseline", ["solver.max_iterations=3"])
        result, steps = solve_sample(cut, parse_varied(keys, cut), np.array(u), start, {})
        assert result.converged and steps >= 4
        np.testing.assert_allclose(result.pose.q, ref.pose.q, rtol=0, atol=1e-9)
        assert result.compartments["medial"].force_N == pytest.approx(
            ref.compartments["medial"].force_N, rel=1e-9)
    cut = load_scene("baseline", ["solver.max_iterations=2"])
    result, steps = solve_sample(cut, parse_varied(keys, cut), np.array([0.0, 0.0]), start, {})
    assert not result.converged and steps == 0


def test_a_sample_started_from_its_predicted_equilibrium_reaches_the_same_one(
        monkeypatch):
    """The baseline's equilibrium linearised in the load point and modulus
    (`predict_starts`) predicts each sample's pose: solved from there, a sample at the
    ends of the ranges reaches the equilibrium it reaches from the baseline pose (to the
    solver's tolerance), and the predicted pose is closer to it than the baseline's.
    The moves here are under a millimetre: by default such a sample starts from the
    baseline pose (`NEAR_BASELINE_MM`), here lowered to 0 to start from the prediction."""
    from fecheck.scene import load_scene
    from fecheck.studies import population
    from fecheck.studies.population import baseline_pose, predict_starts, solve_sample
    from fecheck.studies.population_inputs import parse_varied

    scene = load_scene("baseline", [])
    varied = parse_varied(["load.point_mm[0]=uniform:3:12",
                           "contact.youngs_MPa=uniform:10:30"], scene)
    start = baseline_pose(scene)
    starts = predict_starts(scene, varied, start)
    nominal = [(v.nominal - v.dist.a) / (v.dist.b - v.dist.a) for v in varied]
    np.testing.assert_allclose(starts.at(varied, np.array(nominal)), start, rtol=0,
                               atol=1e-12)
    assert starts.start(varied, np.array([1.0, 1.0])) is None
    monkeypatch.setattr(population, "NEAR_BASELINE_MM", 0.0)
    for u in ([1.0, 1.0], [0.0, 0.0], [1.0, 0.0]):
        ref, steps = solve_sample(scene, varied, np.array(u), start, {})
        assert ref.converged and steps == 0
        np.testing.assert_array_equal(starts.start(varied, np.array(u)),
                                      starts.at(varied, np.array(u)))
        result, steps = solve_sample(scene, varied, np.array(u), starts, {})
        assert result.converged and steps == 0
        assert result.iterations <= ref.iterations
        # the depth's response to the modulus is curved (about 1/E), so a linear prediction
        # misses a third of the way at the stiff corner (0.34, measured); zero slopes: 1
        miss = np.linalg.norm(starts.at(varied, np.array(u)) - ref.pose.q)
        assert miss < 0.5 * np.linalg.norm(start - ref.pose.q)
        np.testing.assert_allclose(result.pose.q, ref.pose.q, rtol=0, atol=1e-9)
        assert result.compartments["medial"].force_N == pytest.approx(
            ref.compartments["medial"].force_N, rel=1e-9)
