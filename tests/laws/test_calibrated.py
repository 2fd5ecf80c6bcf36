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
    from fecheck.fe.reference.axisym import axisym_sphere_on_layer

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


# ------------------------------------------------------------ warnings (issue 26 item 5)
def _answer(area: float, p_max: float, force: float = 400.0) -> cal.Answer:
    return cal.Answer({c: {"force_N": force, "area_mm2": area, "max_pressure_MPa": p_max}
                       for c in ("medial", "lateral")})


def _fit(n_lateral: float, area_error: float) -> cal.CalibrationFit:
    """A fit whose calibrated EF misses the FE's area by `area_error` (relative) at the
    second of two loads; p_max and shares exact."""
    fe = [_answer(200.0, 3.0), _answer(300.0, 4.0)]
    fitted = [_answer(200.0, 3.0), _answer(300.0 * (1 + area_error), 4.0)]
    return cal.CalibrationFit({"medial": Calibration(5.0, 0.8),
                               "lateral": Calibration(5.0, n_lateral)},
                              [480.0, 800.0], fe, fe, fitted, {"fe": 1.0, "fit": 1.0})


def test_a_bound_exponent_and_a_poor_fit_are_warned_about():
    lines = cal.fit_warnings(_fit(1.5, -0.25), "knee.toml")
    assert len(lines) == 2 and all("\n" not in w for w in lines)
    bound, poor = lines
    assert bound.startswith("calibrate knee.toml: the lateral exponent n = 1.5 sits on its "
                            "bound (0.3 <= n <= 1.5)") and "fecheck fe" in bound
    # |300·0.75 / 300 - 1| = 25 %, medial and lateral alike: the first compartment named
    assert "misses the FE by up to 25.0 % (" in poor and "area at 800 N" in poor
    assert "--loads" in poor
    assert cal.fit_warnings(_fit(1.499 - cal.BOUND_TOLERANCE, 0.099), "k") == []
    assert len(cal.fit_warnings(_fit(0.3, 0.0), "k")) == 1           # the lower bound too


def test_calibrate_warns_when_its_fit_sits_on_a_bound(monkeypatch):
    """The FE replaced by the calibrated EF with n = 1.5 (the upper bound) on the lateral
    side: the fit finds it and warns."""
    import tempfile

    truth = {"medial": Calibration(5.3, 0.57), "lateral": Calibration(1.2, 1.5)}
    scene = load_scene()
    with tempfile.TemporaryDirectory() as folder:
        monkeypatch.setattr(cal, "fe_answers",
                            lambda s, loads, log: cal._EFRuns(s, loads, Path(folder))(truth))
        with pytest.warns(UserWarning, match=r"the lateral exponent n = 1\.5 sits on its bound"):
            fit = cal.calibrate(scene, (0.6, 1.4))
    assert fit.parameters["lateral"].n == pytest.approx(1.5, abs=cal.BOUND_TOLERANCE)
    from fecheck.model.fingerprint import scene_fingerprint

    assert fit.fingerprint == scene_fingerprint(scene) and len(fit.fingerprint) == 64


def test_the_written_file_carries_the_fingerprint_and_its_scene_reads_it_silently(tmp_path):
    import dataclasses
    import warnings

    from fecheck.model.fingerprint import scene_fingerprint

    scene = load_scene()
    fit = dataclasses.replace(_fit(0.8, 0.0), fingerprint=scene_fingerprint(scene))
    path = cal.write(fit, scene, tmp_path / "c.json")
    assert json.loads(path.read_text())["fingerprint"] == fit.fingerprint
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert run_scene(_calibrated_scene(path)).converged


def _calibrated_scene(path: Path, **values):
    return with_values(load_scene(), contact__law="ef-calibrated",
                       contact__calibration=str(path), **values)


def test_a_calibration_made_for_another_scene_is_warned_about(tmp_path):
    import warnings

    from fecheck.model.fingerprint import scene_fingerprint

    k = ef_stiffness(E, NU, H)
    path = tmp_path / "own.json"
    scene = _calibrated_scene(path)
    calibrated.write_calibration(path, {"medial": Calibration(k, 1.0),
                                        "lateral": Calibration(k, 1.0)},
                                 {"fingerprint": scene_fingerprint(scene)})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert run_scene(scene).converged                          # its own scene: silent
        run_scene(with_values(scene, load__force_N=600.0))         # a load is no geometry
    for change in ({"contact__youngs_MPa": 10.0}, {"contact__thickness_mm": 3.0},
                   {"plateau__kind": "inclined"}):
        with pytest.warns(UserWarning, match=rf"contact.calibration: {path} was fitted to "
                                             r"other surfaces.*run `fecheck calibrate"):
            run_scene(_calibrated_scene(path, **change))


def test_an_old_calibration_file_is_warned_about_once(tmp_path):
    import warnings

    path = tmp_path / "old.json"
    _write(path, Calibration(5.0, 0.8), Calibration(5.0, 0.8))       # no fingerprint
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run_scene(_calibrated_scene(path))
        run_scene(_calibrated_scene(path, load__force_N=600.0))
    said = [str(w.message) for w in caught if "fingerprint" in str(w.message)]
    assert len(said) == 1 and str(path) in said[0] and "cannot be checked" in said[0]
    assert "fecheck calibrate SCENE -o old.json" in said[0]


def test_the_fingerprint_follows_the_surfaces_not_their_paths(tmp_path):
    from fecheck.model.fingerprint import scene_fingerprint
    from fecheck.scene.document import toml_value
    from geometry.synthetic.knee import write_knee

    scenes = []
    for name in ("a", "b"):
        keys = write_knee(tmp_path / name)
        text = f"[model]\nkind = 'femur-tibia'\n[geometry]\ndir = '{name}'\n" + "".join(
            f"{k} = {toml_value(v)}\n" for k, v in keys.items())
        (tmp_path / f"{name}.toml").write_text(text)
        scenes.append(load_scene(tmp_path / f"{name}.toml"))
    a, b = (scene_fingerprint(s) for s in scenes)
    assert a == b                                             # same arrays, other folder
    assert scene_fingerprint(with_values(scenes[0], scanned__decimate_faces=2000)) != a
    plane = with_values(scenes[0], geometry__tibia_split="sagittal", geometry__split_x_mm=-15.0)
    assert scene_fingerprint(plane) != a                      # other compartments
    lifted = with_values(scenes[0], geometry__translation_mm=[0.0, 0.0, 0.05])
    assert scene_fingerprint(lifted) != a                     # same faces, points moved
    # a file rewritten with other points: a new fingerprint (not the one kept for the keys)
    from geometry.mesh import TriMesh
    from geometry.synthetic.knee import tibia_mesh, write_mesh

    moved = tibia_mesh()
    write_mesh(TriMesh(moved.points + [0.0, 0.0, 0.05], moved.faces), tmp_path / "a" / "tibia.stl")
    assert scene_fingerprint(load_scene(tmp_path / "a.toml")) != a
