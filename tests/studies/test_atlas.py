"""`fecheck atlas`: the error model on a known error function, the design's choice of
points, the region within the tolerance, and the refused inputs."""

from __future__ import annotations

import numpy as np
import pytest

from fecheck.cli import main
from fecheck.studies import atlas


def _errors(u: np.ndarray) -> dict[str, np.ndarray]:
    """A smooth made-up error field over two unit-cube keys: p_max crosses ±0.05 inside
    the cube (|p_max| ≤ 0.05 where u0 ≤ 0.5 exactly)."""
    return {"p_max": 0.1 * u[:, 0] ** 2 - 0.025, "area": 0.01 * u[:, 1],
            "split": 0.001 * u[:, 0] * u[:, 1], "cop_mm": 0.5 + 0.2 * u[:, 1]}


@pytest.fixture(scope="module")
def model():
    u = atlas.initial_design(24, 2, seed=0)
    return atlas.fit_error_model(u, _errors(u))


def test_error_model_predicts_a_smooth_error_within_its_stated_error(model):
    test = np.random.default_rng(5).random((200, 2))
    pred = model.predict(test)
    truth = _errors(test)
    for name in model.models:
        miss = np.sqrt(np.mean((pred[name][0] - truth[name]) ** 2))
        scale = np.ptp(truth[name])
        # measured: misses below 1 % of each output's range; the stated (cross-validated)
        # error is of the same size or larger
        assert miss < 0.02 * scale
        assert miss < 3.0 * model.cv_rmse[name] + 1e-6


def test_the_region_within_the_tolerance_is_where_the_error_is_small(model):
    grid = np.column_stack([np.linspace(0.02, 0.98, 49), np.full(49, 0.5)])
    inside = atlas.within(model.predict(grid), 0.05)
    # p_max = 0.1 u0² − 0.025 is within ±0.05 for u0 ≤ √0.75 = 0.866
    expected = grid[:, 0] <= np.sqrt(0.75)
    assert np.mean(inside == expected) >= 0.95


def test_the_next_points_are_where_the_model_is_least_sure_and_apart():
    u = atlas.initial_design(8, 2, seed=0) * 0.5          # every point in one corner
    corner = atlas.fit_error_model(u, _errors(u))
    candidates = np.random.default_rng(1).random((300, 2))
    pick = atlas.least_sure(corner, candidates, u, 3)
    chosen = candidates[pick]
    assert len(pick) == 3
    # the least sure points lie away from the corner the model has seen
    assert np.all(chosen.max(axis=1) > 0.6)
    gaps = [np.linalg.norm(chosen[i] - chosen[j]) for i in range(3) for j in range(i)]
    assert min(gaps) >= 0.05


@pytest.mark.parametrize("argv, message", [
    (["--vary", "contact.youngs_MPa=uniform:10:30", "--fe", "3"],
     "needs at least 4 FE design points"),
    (["--vary", "contact.youngs=uniform:10:30", "--fe", "8"], "unknown scene key"),
    (["--vary", "contact.poisson=uniform:0.2:0.5", "--fe", "8"], "outside what the scene"),
    (["--vary", "contact.youngs_MPa=uniform:10:30", "--fe", "8", "--tolerance", "2"],
     "--tolerance 2"),
])
def test_bad_input_is_refused_before_any_run(argv, message, capsys):
    assert main(["atlas", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]
