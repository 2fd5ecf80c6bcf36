"""Plausibility rules (`fecheck.scene.unit_hints` on the inputs, `fecheck.model.plausibility`
on the assembled sheets and the results): each rule fires on the implausible value it
guards, names the likely unit mistake, and stays silent on the shipped scenes. The contact
sheets' own checks: tests/geometry/test_sheet_checks.py."""

from __future__ import annotations

import dataclasses
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from fecheck.errors import FecheckError, ImplausibleInput
from fecheck.model import plausibility as pl
from fecheck.model.run import run_scene
from fecheck.scene import load_scene
from fecheck.scene import unit_hints as uh
from geometry.plateau import plane_patch

SCENES = Path(__file__).resolve().parents[2] / "validation" / "scenes"
SHIPPED = ("baseline", "hertz", "volumetric", "rigid", "rigid_ligaments", "springs",
           "ligaments", "equal_force", "additional_left")


def _implausible(record) -> list[str]:
    return [str(w.message) for w in record if issubclass(w.category, ImplausibleInput)]


@pytest.fixture(scope="module")
def baseline():
    scene = load_scene()
    return scene, run_scene(scene)


# ----------------------------------------------------------------------- inputs
@pytest.mark.parametrize("e, words", [
    (2e7, ["Pa typed as MPa", "UHMWPE"]), (0.05, ["GPa typed as MPa"]),
    (0.1, []), (20.0, []), (1000.0, []), (5000.0, []),
])
def test_modulus_outside_knee_materials_names_the_unit_mistake(e, words):
    text = uh.modulus_warning(e)
    assert all(w in text for w in words) and bool(text) == bool(words)


def test_load_below_the_weight_is_warned_and_hinted(baseline):
    # 15 N is a knee load but does not lift the 2 kg tibia (2 · 9.81 = 19.62 N)
    scene = load_scene(overrides=["load.force_N=15"])
    hints = uh.input_warnings(scene)
    assert len(hints) == 1 and "kN typed as N" in hints[0] and "19.62 N" in hints[0]
    assert uh.load_hint(baseline[0]) == ""
    assert uh.load_hint(load_scene(overrides=["load.force_N=0.8", "gravity=false"])) == ""
    held = load_scene(SCENES / "springs.toml", ["load.force_N=15"])     # ligaments hold it
    assert uh.load_hint(held) == ""


@pytest.mark.parametrize("force, words", [
    (0.8, ["0.8 N is below any knee load (10 N-10 kN)", "kN typed as N? (0.8 kN = 800 N)"]),
    (9.99, ["9.99 N is below", "(9.99 kN = 9990 N)"]),
    (1e-6, ["1e-06 N is below", "even read as kN"]),
    (50000.0, ["50000 N is above any knee load (10 N-10 kN)",
               "mN typed as N? (50000 mN = 50 N)"]),
    (10001.0, ["10001 N is above", "(10001 mN = 10.001 N)"]),
    (1e9, ["1e+09 N is above", "even read as mN"]),
    (10.0, []), (800.0, []), (10000.0, []),
])
@pytest.mark.parametrize("gravity", [False, True])
def test_a_load_outside_knee_loads_names_the_unit_with_or_without_gravity(force, words,
                                                                          gravity):
    scene = load_scene(overrides=[f"load.force_N={force}", f"gravity={str(gravity).lower()}"])
    found = uh.input_warnings(scene)
    if words:                            # one warning: the weight hint would say it again
        assert len(found) == 1 and all(w in found[0] for w in words), found
    else:                                # 10 N under the 19.62 N weight: only that hint
        assert not [w for w in found if "any knee load" in w]
        assert (found != []) == (gravity and force < 19.62), found


def _never_solved(monkeypatch):
    """Make any Newton solve fail the test: the refusals below come before it."""
    import fecheck.model.equilibrium

    def solve(problem):
        raise AssertionError("the solve ran")
    monkeypatch.setattr(fecheck.model.equilibrium, "solve", solve)


@pytest.mark.parametrize("overrides, words", [
    (["gravity=false"], ["load.force_N = 0 and no weight", "the equilibrium is no contact",
                         "load.force_N = 800"]),
    ([], ["load.force_N = 0: nothing holds the tibia", "weight (19.62 N"]),
], ids=["no-gravity", "gravity"])
def test_a_zero_load_is_its_own_error_before_the_solve(monkeypatch, overrides, words):
    _never_solved(monkeypatch)
    scene = load_scene(overrides=["load.force_N=0", *overrides])
    with pytest.raises(FecheckError) as err:
        run_scene(scene)
    assert all(w in str(err.value) for w in words), str(err.value)
    assert "within 1 m" not in str(err.value)


@pytest.mark.parametrize("path, overrides", [
    (SCENES / "springs.toml", []),                            # ligament springs hold it
    (SCENES / "baseline.toml", ["dofs.free=['abduction']", "dofs.z_mm=0.5"]),   # driven z
    (SCENES / "rigid.toml", ["gravity=false"]),               # forces of the given pose
], ids=["springs", "driven-z", "rigid"])
def test_a_zero_load_something_else_holds_is_no_input_error(path, overrides):
    scene = load_scene(path, ["load.force_N=0", *overrides])
    assert uh.input_errors(scene) == [] and uh.input_warnings(scene) == []


def test_a_ligament_scene_without_load_that_finds_no_contact_says_why():
    scene = load_scene(SCENES / "springs.toml", ["load.force_N=0"])
    assert "only the ligaments and the tibia's weight act" in uh.no_equilibrium_hint(scene)
    assert uh.no_equilibrium_hint(load_scene(SCENES / "springs.toml")) == ""


@pytest.mark.parametrize("overrides, words", [
    (["contact.youngs_MPa=1e-6"], ["contact.youngs_MPa = 1e-06 MPa (1 Pa)", "even read as GPa"]),
    (["contact.youngs_MPa=9e-5"], ["9e-05 MPa (90 Pa)"]),
    (["contact.youngs_MPa=2e7"], ["contact.youngs_MPa = 2e+07 MPa", "Pa typed as MPa"]),
    (["contact.youngs_MPa=1e6"], ["contact.youngs_MPa = 1e+06 MPa", "Pa typed as MPa"]),
    (["contact.law=hertz", "contact.indenter_youngs_MPa=2.1e11"],
     ["contact.indenter_youngs_MPa = 2.1e+11 MPa", "implant metal", "Pa typed as MPa"]),
    (["contact.law=volumetric", "contact.volumetric_stiffness_N_per_mm3=1e7"],
     ["contact.volumetric_stiffness_N_per_mm3 = 1e+07", "N/m³ typed as N/mm³? (1e+07 N/m³ = "
      "0.01 N/mm³"]),
], ids=["1e-6", "9e-5", "2e7", "1e6", "indenter-2.1e11", "volumetric-1e7"])
def test_an_absurd_material_is_an_error_naming_key_and_unit_before_the_solve(
        monkeypatch, overrides, words):
    _never_solved(monkeypatch)
    with pytest.raises(FecheckError) as err:
        run_scene(load_scene(overrides=overrides))
    assert all(w in str(err.value) for w in words), str(err.value)


@pytest.mark.parametrize("overrides, words", [
    (["contact.youngs_MPa=1e-4"], ["GPa typed as MPa"]),             # 0.1 GPa = 100 MPa
    (["contact.youngs_MPa=2e4"], ["kPa typed as MPa? (20000 kPa = 20 MPa)"]),
    (["contact.youngs_MPa=2e5"], ["Pa or kPa typed as MPa? (200000 Pa = 0.2 MPa)"]),
    (["contact.youngs_MPa=999999"], ["kPa typed as MPa"]),
    (["contact.law=hertz", "contact.indenter_youngs_MPa=2.1e5"], []),      # CoCr, 210 GPa
    (["contact.indenter_youngs_MPa=2.1e11"], []),             # inert: not the Hertz law
    (["contact.volumetric_stiffness_N_per_mm3=1e7"], []),     # inert: not the volumetric law
    (["contact.law=volumetric", "contact.volumetric_stiffness_N_per_mm3=0.01"], []),
    (["model.kind=rigid", "contact.youngs_MPa=1e-6"], []),    # rigid: no material
])
def test_a_modulus_a_unit_slip_explains_only_warns(overrides, words):
    scene = load_scene(overrides=overrides)
    assert uh.input_errors(scene) == []
    found = uh.input_warnings(scene)
    assert len(found) == int(bool(words)) and all(w in "".join(found) for w in words), found


def _sheet_comps(medial_x: float, lateral_x: float) -> list:
    """Stand-in compartments: a flat tibial sheet (disc, radius 14 mm) centred at each x."""
    from types import SimpleNamespace

    from fecheck.contact import ContactPair, Plane

    def comp(name, x):
        sheet = plane_patch((x, 0.0, 0.0), (0.0, 0.0, 1.0), radius=14.0, size=2.0)
        return SimpleNamespace(name=name, slave_is_tibia=True,
                               pair=ContactPair(sheet, Plane([0.0, 0.0, 1.0], [0, 0, -1.0])))
    return [comp("medial", medial_x), comp("lateral", lateral_x)]


def test_tibial_sheets_on_the_wrong_sides_for_knee_side_are_an_error():
    right = load_scene()                             # baseline-right: medial at -x
    pl.check_sides(right, _sheet_comps(-20.0, 25.0))
    with pytest.raises(FecheckError) as err:
        pl.check_sides(right, _sheet_comps(25.0, -20.0))
    text = str(err.value)
    assert "knee.side = 'right' puts the medial compartment at -x" in text
    assert "as in a left knee" in text and "geometry.tibia_lateral" in text
    # a disc's area-weighted centre is its centre (symmetric triangulation: to a tenth)
    assert "at x = +25.0 mm and the lateral at -20.0 mm" in text


@pytest.mark.parametrize("lift_mm", [10.0, 30.0])
def test_a_condyle_sphere_far_from_its_tibial_sheet_is_an_error(lift_mm):
    from types import SimpleNamespace

    from fecheck.contact import ContactPair, Sphere

    scene = load_scene()                  # the baseline's check pose: the identity
    sheet = plane_patch((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), radius=14.0, size=1.0)
    # the sphere's lowest point lift_mm above the sheet's centre (R 25.5 mm); the nearest
    # vertex lies within a face of the centre: the gap is lift_mm + r²/(2·55.5) < lift + 0.01
    comp = SimpleNamespace(name="medial", slave_is_tibia=True, pair=ContactPair(
        sheet, Sphere(np.array([0.0, 0.0, 25.5 + lift_mm]), 25.5)))
    if lift_mm < pl.LANDMARK_GAP_MM:
        pl.check_landmarks(scene, comp)
        return
    with pytest.raises(FecheckError, match=r"medial: the condyle sphere is 30\.0 mm from the "
                                           r"tibial sheet at the start pose \(more than 20 mm\)"):
        pl.check_landmarks(scene, comp)


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_scenes_raise_no_plausibility_warning(name):
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        result = run_scene(load_scene(SCENES / f"{name}.toml"))
    assert result.converged and not _implausible(record)


def test_an_implant_modulus_runs_without_warnings():
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        result = run_scene(load_scene(overrides=["contact.youngs_MPa=1000"]))
    assert not _implausible(record)
    assert 10.0 < result.compartments["medial"].max_pressure_MPa < pl.P_MAX_MPA


# ----------------------------------------------------------------------- results
@pytest.mark.parametrize("changes, words", [
    ({"max_pressure_MPa": math.nan}, ["max pressure came out NaN"]),
    ({"area_mm2": 0.0}, ["without a contact patch"]),
    ({"max_pressure_MPa": 0.0}, ["without a contact patch"]),
    ({"max_pressure_MPa": 4263.0}, ["above the 1000 MPa", "units"]),
])
def test_non_physical_results_are_errors(baseline, changes, words):
    scene, result = baseline
    comps = dict(result.compartments)
    comps["medial"] = dataclasses.replace(comps["medial"], **changes)
    with pytest.raises(FecheckError) as err:
        pl.after_solve(scene, dataclasses.replace(result, compartments=comps))
    assert all(w in str(err.value) for w in words)
    assert str(err.value).startswith("medial:")


def test_a_contact_on_two_faces_is_warned(baseline):
    scene, result = baseline
    comps = dict(result.compartments)
    comps["lateral"] = dataclasses.replace(comps["lateral"], n_contact_faces=2)
    with pytest.warns(ImplausibleInput, match="spans only 2 face"):
        pl.after_solve(scene, dataclasses.replace(result, compartments=comps))


def test_baseline_result_passes(baseline):
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImplausibleInput)
        pl.after_solve(*baseline)


def test_rigid_balls_pulling_under_a_load_below_the_weight_is_an_error():
    scene = load_scene(SCENES / "rigid.toml", ["load.force_N=0.8"])
    with pytest.warns(ImplausibleInput), pytest.raises(FecheckError) as err:
        run_scene(scene)
    assert "tensile contact force" in str(err.value) and "kN typed as N" in str(err.value)
