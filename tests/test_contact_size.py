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
