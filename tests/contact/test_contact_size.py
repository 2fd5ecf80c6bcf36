"""Expected contact size before the solve, and the plateau mesh sized from it."""

import math

import pytest

from fecheck import laws
from fecheck.model.meshing import (
    DISC_MARGIN,
    ELEMENTS_PER_CONTACT_RADIUS,
    expected_contact_radius_mm,
    plateau_mesh_sizes,
)
from fecheck.reference import closed_forms as cf
from fecheck.reference.closed_forms import ef_sphere_plane
from fecheck.scene import load_scene

R = 31.8


@pytest.mark.parametrize("force", [1e-6, 0.1, 400.0, 1e4])
def test_ef_contact_radius_matches_the_closed_form_area(force):
    # independent reference: the model's closed-form EF answer, area = πa²
    scene = load_scene()
    k = laws.ef_stiffness(20.0, 0.3, 6.0)
    area = ef_sphere_plane(force, R, k)["area_mm2"]
    assert expected_contact_radius_mm(scene, force, R) == pytest.approx(
        math.sqrt(area / math.pi), rel=1e-9)


def test_hertz_contact_radius_gives_back_the_load():
    # P = 4/3 E* √R d^{3/2} with a = √(R d)
    scene = load_scene(overrides=["contact.law='hertz'"])
    a = expected_contact_radius_mm(scene, 400.0, R)
    e_star = laws.hertz_modulus(20.0, 0.3)
    assert 4.0 / 3.0 * e_star * math.sqrt(R) * (a * a / R) ** 1.5 == pytest.approx(400.0)


def test_the_hertz_closed_forms_on_hand_computed_numbers():
    # R 4 mm, E* 0.75 MPa, d 1 mm: P = 4/3·0.75·√4·1 = 2 N, a = √(4·1) = 2 mm,
    # p0 = 3·2/(2π·2²) = 3/(4π); back from P = 2 N: a = (3·2·4/(4·0.75))^(1/3) = 2, d = a²/R = 1
    assert cf.hertz_load(1.0, 4.0, 0.75) == pytest.approx(2.0, rel=1e-15)
    assert cf.hertz_radius_at_depth(1.0, 4.0) == 2.0
    assert cf.hertz_peak_pressure(2.0, 2.0) == pytest.approx(3 / (4 * math.pi), rel=1e-15)
    assert cf.hertz_contact_radius(2.0, 4.0, 0.75) == pytest.approx(2.0, rel=1e-15)
    assert cf.hertz_approach(2.0, 4.0, 0.75) == pytest.approx(1.0, rel=1e-15)
    # 1/E* = (1 − 0.5²)/3 + (1 − 0²)/4 = 1/4 + 1/4: E* = 2 MPa; rigid indenter: 4 MPa
    assert cf.hertz_effective_modulus(3.0, 0.5, 4.0, 0.0) == pytest.approx(2.0, rel=1e-15)
    assert cf.hertz_effective_modulus(3.0, 0.5) == pytest.approx(4.0, rel=1e-15)


def test_baseline_plateau_mesh_keeps_its_defaults():
    assert plateau_mesh_sizes(load_scene(), R) == {
        "radius": 14.0, "size": 2.0, "refine_size": 0.8, "refine_radius": 9.0}


@pytest.mark.parametrize("force", ["1e-6", "0.1", "5"])
def test_small_loads_refine_to_eight_elements_across_the_contact(force):
    scene = load_scene(overrides=[f"load.force_N={force}", "gravity=false"])
    sizes = plateau_mesh_sizes(scene, R)
    a = expected_contact_radius_mm(scene, 0.5 * float(force), R)
    assert a / sizes["refine_size"] >= ELEMENTS_PER_CONTACT_RADIUS
    a_full = expected_contact_radius_mm(scene, float(force), R)
    assert a_full < sizes["refine_radius"] <= 9.0       # the refined zone covers the contact


def test_large_loads_widen_the_disc_unless_the_scene_sets_it():
    scene = load_scene(overrides=["load.force_N=10000"])
    a = expected_contact_radius_mm(scene, 10000.0 + 2.0 * 9.81, R)
    assert plateau_mesh_sizes(scene, R)["radius"] >= DISC_MARGIN * a > 14.0
    set_by_user = load_scene(overrides=["load.force_N=10000", "mesh.plateau_radius_mm=12",
                                        "mesh.plateau_refine_mm=0.5"])
    sizes = plateau_mesh_sizes(set_by_user, R)
    assert (sizes["radius"], sizes["refine_size"]) == (12.0, 0.5)
