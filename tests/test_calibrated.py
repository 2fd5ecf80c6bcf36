"""The calibrated EF law (contact.law = 'ef-calibrated'): its pressure, its wiring into the
scenes, its calibration files and the fit of `fecheck calibrate`."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from fecheck.errors import FecheckError
from fecheck.laws import calibrated, ef_stiffness, foundation
from fecheck.laws.calibrated import Calibration, calibrated_pressure
from fecheck.model.run import run_scene
from fecheck.scene import load_scene, with_values
from fecheck.studies import calibrate as cal

E, NU, H = 20.0, 0.3, 6.0


def test_pressure_and_slope_of_the_law():
    law = calibrated_pressure(Calibration(5.0, 0.6))
    d = np.array([0.0, 1e-3, 0.05, 0.4, 1.2])
    p, slope = law(d)
    ds = calibrated.SOFT_DEPTH_MM
    np.testing.assert_allclose(p, 5.0 * d * (d + ds) ** -0.4, rtol=1e-14)
    step = 1e-7
    fd = (law(d + step)[0] - law(np.maximum(d - step, 0.0))[0]) / (d + step
                                                                   - np.maximum(d - step, 0))
    np.testing.assert_allclose(slope, fd, rtol=1e-5)
    assert slope[0] == pytest.approx(5.0 * ds ** -0.4)          # finite at the edge


def test_sphere_on_a_plate_integrates_the_law_over_the_cap():
    from fecheck.contact.analytic import Sphere
    from fecheck.contact.pair import ContactPair
    from geometry.plateau import plane_patch

    R, delta, law = 25.5, 0.7, Calibration(5.3, 0.57)
    plate = plane_patch((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), radius=9.0, size=0.5,
                        refine_point=(0.0, 0.0, 0.0), refine_size=0.2, refine_radius=8.0)
    surface = ContactPair(plate, Sphere([0.0, 0.0, R - delta], R)).evaluate(
        (np.eye(3), np.zeros(3)), (np.eye(3), np.zeros(3)))
    result = foundation(surface, calibrated_pressure(law))
    # the plate's depth under the sphere along the plate normal: sqrt(R² - r²) - (R - δ)
    a = math.sqrt(R ** 2 - (R - delta) ** 2)
    r = np.linspace(0.0, a, 200_001)
    depth = np.sqrt(R ** 2 - r ** 2) - (R - delta)
    force = np.trapezoid(calibrated_pressure(law)(depth)[0] * 2 * math.pi * r, r)
    assert -result.force[2] == pytest.approx(force, rel=3e-3)
    assert result.area == pytest.approx(math.pi * a * a, rel=3e-3)


def _write(path, medial: Calibration, lateral: Calibration) -> None:
    calibrated.write_calibration(path, {"medial": medial, "lateral": lateral}, {})


def test_exponent_one_is_the_linear_ef_through_the_scene(tmp_path):
    k = ef_stiffness(E, NU, H)
    _write(tmp_path / "c.json", Calibration(k, 1.0), Calibration(k, 1.0))
    base = load_scene()
    linear = run_scene(base)
    same = run_scene(with_values(base, contact__law="ef-calibrated",
                                 contact__calibration=str(tmp_path / "c.json")))
    for c in ("medial", "lateral"):
        a, b = linear.compartments[c], same.compartments[c]
        assert b.force_N == pytest.approx(a.force_N, rel=1e-9)
        assert b.area_mm2 == pytest.approx(a.area_mm2, rel=1e-9)
        assert b.max_pressure_MPa == pytest.approx(a.max_pressure_MPa, rel=1e-9)


def test_calibration_paths_resolve_against_the_scene_file(tmp_path):
    k = ef_stiffness(E, NU, H)
    _write(tmp_path / "c.json", Calibration(k, 0.8), Calibration(2 * k, 0.9))
    (tmp_path / "s.toml").write_text('[contact]\nlaw = "ef-calibrated"\n'
                                     'calibration = "c.json"\n')
    result = run_scene(load_scene(tmp_path / "s.toml"))
    assert result.converged


@pytest.mark.parametrize("content, message", [
    (None, "not found; write it with `fecheck calibrate"),
    ("{", "is not a calibration file"),
    ('{"compartments": {"medial": {"C": 1.0}}}', "is not a calibration file"),
    ('{"compartments": {"medial": {"C": 1.0, "n": 3.0}}}', "0.3 <= n <= 1.5")])
def test_bad_calibration_files_are_refused_clearly(tmp_path, content, message):
    path = tmp_path / "c.json"
    if content is not None:
        path.write_text(content)
    scene = with_values(load_scene(), contact__law="ef-calibrated",
                        contact__calibration=str(path))
    with pytest.raises(FecheckError, match=message):
        run_scene(scene)


def test_calibrate_recovers_the_law_that_made_its_reference(monkeypatch):
    """The FE replaced by the calibrated EF itself with known C and n per compartment:
    the fit must find them again (the fit, not the FE, is under test)."""
    truth = {"medial": Calibration(5.3, 0.57), "lateral": Calibration(4.1, 0.66)}
    scene = load_scene()

    def reference(s, loads, log):
        runs = cal._EFRuns(s, loads, tmp)
        return runs(truth)

    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        monkeypatch.setattr(cal, "fe_answers", reference)
        fit = cal.calibrate(scene, (0.6, 1.4))
    for c, p in truth.items():
        assert fit.parameters[c].n == pytest.approx(p.n, abs=2e-3)
        assert fit.parameters[c].C == pytest.approx(p.C, rel=5e-3)
    worst = max(abs(v) for row in fit.errors("fitted") for v in row.values())
    assert worst < 1e-3
    assert max(abs(v) for row in fit.errors("linear") for v in row.values()) > 0.05


def test_a_written_calibration_reads_back(tmp_path):
    path = calibrated.write_calibration(tmp_path / "x.json",
                                        {"medial": Calibration(1.5, 0.7),
                                         "lateral": Calibration(2.5, 0.9)}, {"loads_N": [1.0]})
    back = calibrated.read_calibration(path)
    assert back["lateral"] == Calibration(2.5, 0.9)
    assert json.loads(path.read_text())["loads_N"] == [1.0]


def test_the_table_interpolates_through_its_grid_points():
    table = json.loads((Path(calibrated.__file__).parent / calibrated.TABLE_FILE).read_text())
    axes = table["axes"]
    i, j, k = 0, 4, 2
    nu, h, r = axes["poisson"][i], axes["thickness_mm"][j], axes["radius_mm"][k]
    m, c = table["m"][i][j][k], math.exp(table["log_c"][i][j][k])
    got = calibrated.table_calibration(20.0, nu, h, r)
    assert got.n == pytest.approx(m - 1.0, rel=1e-12)
    assert got.C == pytest.approx(20.0 * c * m * (2 * math.pi * r) ** (m - 1), rel=1e-12)
    with pytest.raises(FecheckError, match="outside the built-in table"):
        calibrated.table_calibration(20.0, 0.3, 30.0, r)


def test_the_table_law_gives_the_axisymmetric_fe_area_on_the_baseline():
    """No fit to this scene: the table's law reproduces the FE's contact area (it is
    built to); its p_max runs high, as a local law matching the area must where the
    contact is as wide as the layer (measured +14 % / +12 %)."""
    from fecheck.fe.axisym import axisym_sphere_on_layer

    result = run_scene(with_values(load_scene(), contact__law="ef-calibrated"))
    for c, radius in (("medial", 25.5), ("lateral", 31.8)):
        ef = result.compartments[c]
        fe = axisym_sphere_on_layer(ef.force_N, radius, E, NU, H, size_mm=0.1).metrics
        assert ef.area_mm2 == pytest.approx(fe.area_mm2, rel=0.04)
        assert 1.05 < ef.max_pressure_MPa / fe.max_pressure_MPa < 1.2


@pytest.mark.parametrize("factors", [(0.0, 1.0), (float("nan"),), ()])
def test_calibrate_refuses_meaningless_loads_before_any_solve(factors):
    with pytest.raises(FecheckError, match="load factors must be positive"):
        cal.calibrate(load_scene(), factors)
