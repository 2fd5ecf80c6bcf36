"""Sweeps: value parsing, overrides of vector components, serial = parallel, CSV."""

from __future__ import annotations

import csv
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from fecheck.cli import main
from fecheck.errors import FecheckError
from fecheck.scene import load_scene
from fecheck.studies.sweep import override_for, parse_values, run_sweep

SCENES = Path(__file__).resolve().parents[1] / "validation" / "scenes"


def test_values_parse_ranges_and_lists():
    assert parse_values("-8:8:3") == [-8.0, 0.0, 8.0]
    assert parse_values("0.15,0.4,0.45") == [0.15, 0.4, 0.45]
    for bad in ("1:2", "a,b", "1:2:0", "nan"):
        with pytest.raises(FecheckError):
            parse_values(bad)


def test_overrides_set_vector_components_and_reject_non_numeric_keys():
    scene = load_scene()
    assert override_for(scene, "load.point_mm[0]", 3.95) == "load.point_mm=[3.95, 12.8, -380.0]"
    assert override_for(scene, "contact.youngs_MPa", 9.0) == "contact.youngs_MPa=9.0"
    with pytest.raises(FecheckError, match="numeric"):
        override_for(scene, "contact.law", 1.0)
    with pytest.raises(FecheckError, match="unknown scene key"):
        override_for(scene, "contact.youngs", 1.0)


def test_rigid_load_point_sweep_is_linear_as_in_fig_5_2():
    # rigid statics: F_medial(x) = (28.3·780.38 − 800 x)/48.7, a straight line in x
    scene = load_scene(SCENES / "rigid.toml")
    xs = [-0.1, 3.95, 7.9, 15.9]
    points = run_sweep(scene, "load.point_mm[0]", xs, progress=False)
    f_m = np.array([p.result.compartments["medial"].force_N for p in points])
    expected = (28.3 * (800 - 19.62) - 800 * np.array(xs)) / 48.7
    assert np.allclose(f_m, expected, rtol=0, atol=1e-9)


def test_serial_warm_started_and_parallel_sweeps_agree():
    # the equilibrium does not depend on the start: warm-started serial points equal the
    # independent points (run here on threads, the same executor code path as processes
    # and Dask), to the Newton tolerance (residual < 1e-8·800 N: forces agree to ~1e-5 N)
    scene = load_scene(overrides=["mesh.plateau_refine_mm=1.5"])
    xs = [0.0, 8.0]
    serial = run_sweep(scene, "load.point_mm[0]", xs, progress=False)
    with ThreadPoolExecutor(2) as pool:
        parallel = run_sweep(scene, "load.point_mm[0]", xs, executor=pool, progress=False)
    for a, b in zip(serial, parallel):
        assert a.result.converged and b.result.converged
        for c in ("medial", "lateral"):
            assert a.result.compartments[c].force_N == pytest.approx(
                b.result.compartments[c].force_N, abs=1e-4)


def test_sweep_cli_writes_one_csv_row_per_value(tmp_path, capsys):
    out = tmp_path / "s.csv"
    assert main(["sweep", str(SCENES / "rigid.toml"), "--param", "contact.youngs_MPa",
                 "--values", "9,15,30", "--workers", "2", "--csv", str(out)]) == 0
    with open(out) as fh:
        rows = list(csv.DictReader(fh))
    assert [float(r["contact.youngs_MPa"]) for r in rows] == [9.0, 15.0, 30.0]
    # the rigid split does not depend on E (Table 5.4's "force distribution unchanged")
    assert len({round(float(r["medial_force_N"]), 9) for r in rows}) == 1
    assert "sweep [" in capsys.readouterr().err


def test_missing_dask_is_a_clear_error(capsys):
    pytest.importorskip("concurrent.futures")
    try:
        import dask.distributed  # noqa: F401
        pytest.skip("dask is installed")
    except ImportError:
        pass
    assert main(["sweep", "--param", "contact.youngs_MPa", "--values", "9,15",
                 "--scheduler", "tcp://127.0.0.1:8786"]) == 2
    assert "fecheck[dask]" in capsys.readouterr().err


def test_numpy_values_give_overrides_the_scene_parser_reads():
    # np.linspace hands sweeps np.float64 values; their repr ("np.float64(3.5)") is not TOML.
    scene = load_scene()
    text = override_for(scene, "load.point_mm[0]", np.float64(3.5))
    assert load_scene(None, [text])["load.point_mm"][0] == 3.5
    text = override_for(scene, "contact.poisson", np.float64(0.4))
    assert load_scene(None, [text])["contact.poisson"] == 0.4
