"""Sweeps: value parsing, overrides of vector components, serial = parallel, CSV, failing
points recorded in their rows, values checked up front, Dask through the same path."""

from __future__ import annotations

import csv
import io
import multiprocessing
import sys
import types
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from fecheck.cli import main
from fecheck.errors import FecheckError
from fecheck.scene import load_scene
from fecheck.studies import sweep
from fecheck.studies.sweep import (
    SweepInterrupted,
    override_for,
    parse_values,
    pin_geometry_dir,
    run_sweep,
    write_csv,
)

REPO = Path(__file__).resolve().parents[2]
SCENES = REPO / "validation" / "scenes"


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
    for a, b in zip(serial, parallel, strict=True):
        assert a.result.converged and b.result.converged
        for c in ("medial", "lateral"):
            assert a.result.compartments[c].force_N == pytest.approx(
                b.result.compartments[c].force_N, abs=1e-4)


def test_a_worker_starts_from_the_last_point_it_solved_in_the_same_sweep():
    # a worker's next point is near its last one: started there, Newton needs fewer
    # iterations than from the scene's start, and reaches the same equilibrium
    scene = load_scene(overrides=["mesh.plateau_refine_mm=1.5"])
    first, near = (override_for(scene, "load.point_mm[0]", x) for x in (4.0, 5.0))
    sweep.solve_on_worker(scene, first, 4.0, "x = 4", "sweep A")
    warm = sweep.solve_on_worker(scene, near, 5.0, "x = 5", "sweep A").result
    cold = sweep.solve_on_worker(scene, near, 5.0, "x = 5", "sweep B").result
    assert warm.converged and cold.converged
    assert warm.iterations < cold.iterations
    for c in ("medial", "lateral"):
        assert warm.compartments[c].force_N == pytest.approx(cold.compartments[c].force_N,
                                                             abs=1e-4)


def test_sweep_cli_writes_one_csv_row_per_value(tmp_path, capsys):
    out = tmp_path / "s.csv"
    assert main(["sweep", str(SCENES / "rigid.toml"), "--param", "contact.youngs_MPa",
                 "--values", "9,15,30", "--workers", "2", "--csv", str(out)]) == 0
    with open(out) as fh:
        rows = list(csv.DictReader(fh))
    assert [float(r["contact.youngs_MPa"]) for r in rows] == [9.0, 15.0, 30.0]
    # the rigid split does not depend on E (Table 5.4's "force distribution unchanged")
    assert len({round(float(r["medial_force_N"]), 9) for r in rows}) == 1
    err = capsys.readouterr().err             # not a terminal: plain lines, no redraw
    assert "sweep: 3/3 points" in err and "\r" not in err


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


YOUNGS = ["--param", "contact.youngs_MPa", "--values", "20,10,0.1,5"]
"""E = 0.1 MPa crushes the 6 mm layer under 800 N: that point's solve raises."""


def _csv(path) -> list[dict[str, str]]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.mark.parametrize("workers", ["1", "2"])
def test_a_failing_point_is_recorded_in_its_row_and_the_sweep_goes_on(tmp_path, capsys,
                                                                       workers):
    out = tmp_path / "s.csv"
    out.write_text("stale,rows\n1,2\n")
    assert main(["sweep", *YOUNGS, "--workers", workers, "--csv", str(out)]) == 1
    rows = _csv(out)
    assert [float(r["contact.youngs_MPa"]) for r in rows] == [20.0, 10.0, 0.1, 5.0]
    assert [r["converged"] for r in rows] == ["True", "True", "False", "True"]
    assert "crushed" in rows[2]["error"] and rows[2]["medial_force_N"] == ""
    assert all(r["error"] == "" and float(r["medial_force_N"]) > 0 for i, r in
               enumerate(rows) if i != 2)
    if workers == "2":        # said where it failed: the point and the worker
        assert "contact.youngs_MPa = 0.1 failed on worker" in rows[2]["error"]
    captured = capsys.readouterr()
    assert "error: " in captured.out and "crushed" in captured.out
    assert "1 of 4 points failed: contact.youngs_MPa = 0.1" in captured.err


def test_fail_fast_stops_at_the_failing_value_and_keeps_the_finished_rows(tmp_path, capsys):
    out = tmp_path / "s.csv"
    assert main(["sweep", *YOUNGS, "--fail-fast", "--csv", str(out)]) == 1
    rows = _csv(out)
    assert [float(r["contact.youngs_MPa"]) for r in rows] == [20.0, 10.0, 0.1]
    assert "crushed" in rows[2]["error"]
    err = capsys.readouterr().err
    assert "--fail-fast" in err and "1 of 4 points not run" in err
    assert "contact.youngs_MPa = 0.1" in err


def test_a_bad_value_fails_before_any_solve_naming_values(tmp_path, capsys, monkeypatch):
    import fecheck.model.run

    def no_solve(*args, **kwargs):
        raise AssertionError("solved a point before checking every value")

    monkeypatch.setattr(fecheck.model.run, "run_scene", no_solve)
    out = tmp_path / "s.csv"
    assert main(["sweep", "--param", "contact.youngs_MPa", "--values", "20,10,-1",
                 "--csv", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--values" in err and "-1" in err
    assert "--set" not in err
    assert not out.exists()


def test_output_paths_are_checked_before_any_solve(tmp_path, capsys, monkeypatch):
    import fecheck.model.run

    monkeypatch.setattr(fecheck.model.run, "run_scene", None)     # any solve would fail
    for flag in ("--csv", "--plot"):
        target = tmp_path / "a-file-not-a-folder"
        target.write_text("")
        path = target / "x.csv" if flag == "--csv" else target
        assert main(["sweep", *YOUNGS, flag, str(path)]) == 2
        assert "cannot write" in capsys.readouterr().err


def test_csv_dash_writes_a_clean_csv_to_stdout(capsys):
    assert main(["sweep", str(SCENES / "rigid.toml"), "--param", "contact.youngs_MPa",
                 "--values", "9,15,30", "--csv", "-"]) == 0
    captured = capsys.readouterr()
    rows = list(csv.DictReader(io.StringIO(captured.out)))
    assert [float(r["contact.youngs_MPa"]) for r in rows] == [9.0, 15.0, 30.0]
    assert all(r["converged"] == "True" and float(r["medial_force_N"]) > 0 for r in rows)
    assert "medial_force_N" in captured.err          # the table went to stderr


def test_the_csv_is_rewritten_after_each_point_in_value_order(tmp_path):
    scene = load_scene(SCENES / "rigid.toml")
    out = tmp_path / "s.csv"
    out.write_text("stale\n")
    seen = []

    def save(points):
        write_csv(points, "contact.youngs_MPa", out)
        seen.append([float(r["contact.youngs_MPa"]) for r in _csv(out)])

    with ThreadPoolExecutor(2) as pool:
        run_sweep(scene, "contact.youngs_MPa", [30.0, 9.0, 15.0], executor=pool,
                  progress=False, on_point=save)
    assert [len(s) for s in seen] == [1, 2, 3]
    assert all(s == sorted(s, key=[30.0, 9.0, 15.0].index) for s in seen)
    assert seen[-1] == [30.0, 9.0, 15.0]


def test_the_cli_keeps_the_csv_up_to_date_at_a_pace_that_stays_cheap(tmp_path, monkeypatch):
    """`fecheck sweep --csv` rewrites the file after the first point at once, then once
    `CHECKPOINT_S` has passed (or ten times the last write's duration, if longer)."""
    from fecheck.cli import sweep as cli_sweep

    scene = load_scene(SCENES / "rigid.toml")
    points = run_sweep(scene, "contact.youngs_MPa", [5.0, 10.0, 20.0], progress=False)
    clock = iter([100.0, 100.0,          # first point: written at once, taking 0 s
                  100.5,                 # 0.5 s later: not yet
                  101.0, 103.0,          # 1 s later: written, taking 2 s
                  110.0,                 # 7 s after that write: not yet (10 x 2 s)
                  123.0, 123.0])         # 20 s after: written
    monkeypatch.setattr(cli_sweep.time, "monotonic", lambda: next(clock))
    out = tmp_path / "s.csv"
    save = cli_sweep._Checkpoint(str(out), "contact.youngs_MPa")
    written = []
    for k in (1, 2, 2, 3, 3):
        save(points[:k])
        written.append(len(_csv(out)))
    assert written == [1, 1, 2, 2, 3]
    cli_sweep._Checkpoint("-", "contact.youngs_MPa")(points)       # stdout: at the end only
    cli_sweep._Checkpoint(None, "contact.youngs_MPa")(points)


@pytest.mark.parametrize("workers", [1, 2])
def test_an_interrupt_keeps_the_finished_points_and_stops_the_workers(workers):
    scene = load_scene(SCENES / "rigid.toml")

    def interrupt_after_two(points):
        if len(points) == 2:
            raise KeyboardInterrupt

    with pytest.raises(SweepInterrupted) as stop:
        run_sweep(scene, "contact.youngs_MPa", [5.0, 10.0, 20.0, 30.0, 40.0, 50.0],
                  workers=workers, progress=False, on_point=interrupt_after_two)
    assert len(stop.value.points) == 2 and stop.value.total == 6
    assert all(p.converged for p in stop.value.points)
    assert multiprocessing.active_children() == []


def _fake_dask(monkeypatch, client_class) -> None:
    dask = types.ModuleType("dask")
    distributed = types.ModuleType("dask.distributed")
    distributed.Client = client_class
    dask.distributed = distributed
    monkeypatch.setitem(sys.modules, "dask", dask)
    monkeypatch.setitem(sys.modules, "dask.distributed", distributed)


def test_a_bad_scheduler_address_is_a_one_line_error(monkeypatch, capsys):
    class Client:
        def __init__(self, address):
            raise ValueError(f"Could not parse address {address!r}")

    _fake_dask(monkeypatch, Client)
    assert main(["sweep", *YOUNGS, "--scheduler", "notanaddress"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "notanaddress" in err and "Dask scheduler" in err


def test_dask_points_run_through_the_executor_path_and_the_client_is_closed(
        monkeypatch, tmp_path):
    closed = []

    class Client:
        def __init__(self, address):
            self.pool = ThreadPoolExecutor(2)

        def get_executor(self):
            return self.pool

        def close(self, timeout=None):
            self.pool.shutdown()
            closed.append(True)

    _fake_dask(monkeypatch, Client)
    out = tmp_path / "s.csv"
    assert main(["sweep", *YOUNGS, "--scheduler", "tcp://x:8786", "--csv", str(out)]) == 1
    assert closed == [True]
    rows = _csv(out)
    assert "contact.youngs_MPa = 0.1 failed on worker" in rows[2]["error"]


def test_scenes_reading_files_pin_an_absolute_folder_for_remote_workers(tmp_path):
    relative = load_scene(SCENES / "femur_tibia.toml", ["geometry.dir='../data'"])
    pinned = pin_geometry_dir(relative)["geometry.dir"]
    assert Path(pinned).is_absolute()
    # relative to the scene file's own folder (fecheck/scenes: validation/scenes links there)
    assert Path(pinned) == REPO / "fecheck" / "data"
    packaged = load_scene(SCENES / "femur_tibia.toml")   # found wherever fecheck is installed
    assert pin_geometry_dir(packaged) is packaged
    named = load_scene(SCENES / "femur_tibia.toml", [f"geometry.dir='{tmp_path}'"])
    assert pin_geometry_dir(named)["geometry.dir"] == str(tmp_path)
    baseline = load_scene()
    assert pin_geometry_dir(baseline) is baseline


def test_sweeping_a_key_with_no_effect_warns_before_the_solve(capsys):
    # the default condyles are exact spheres: their mesh level changes nothing
    assert main(["sweep", "--param", "mesh.sphere_subdivisions", "--values=3,4"]) == 0
    err = capsys.readouterr().err
    assert err.count("mesh.sphere_subdivisions has no effect") == 1
