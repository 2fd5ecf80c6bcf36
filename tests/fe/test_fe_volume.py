"""The FE of a closed tibial solid (`fecheck.fe.bodies.volume`, ``geometry.tibia_solid``).

References: Hertz (a rigid sphere on an elastic half-space) for a sphere pressed into a
thick cylinder, base fixed, walls free (contact radius / thickness 0.17: the
axisymmetric FE of the same finite cylinder sits within 0.3 % of Hertz, so 3 % is the
3D mesh's error, not the geometry's); the same solid pressed as one compartment and as
two (exact to round-off: one stiffness, coupled); the load of the scene (equilibrium);
the generated insert's own top faces.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from fecheck.cli import main
from fecheck.fe.bodies import volume
from fecheck.fe.bodies.indenter import SphereIndenter
from fecheck.fe.bodies.pose import FramePose
from fecheck.fe.bodies.volume import TibiaSolid, solid_layers
from fecheck.fe.pressure.recovery import zero_contour_area
from fecheck.fe.solve.joint import ContactLayer, JointContact
from fecheck.reference.closed_forms import hertz_sphere_on_plane
from fecheck.scene import load_scene, surfaces
from fecheck.scene.tibia_solid import up_facing
from geometry.synthetic.implant import LOAD_N, cylinder_solid, insert_solid, write_implant

R, E, NU, F = 25.5, 20.0, 0.3, 18.0          # contact radius 2.50 mm by Hertz
UP = np.array([0.0, 0.0, 1.0])


def _press(layers: dict, force: float):
    """The solid's compartments pushed up (+z) into the sphere with `force` (N)."""
    sphere = SphereIndenter(np.array([0.0, 0.0, R]), R)
    contact = []
    for name, solid in layers.items():
        gap = sphere.gap(solid.surface.points, solid.normals).gap_mm
        contact.append(ContactLayer(name, solid, sphere, np.flatnonzero(gap < 0.3)))
    joint = JointContact(contact)
    return joint.solve(lambda q: FramePose(np.eye(3), q[0] * UP),
                       lambda q: np.concatenate([UP, np.zeros(3)])[:, None],
                       lambda q: np.array([force]), np.zeros(1))


@pytest.fixture(scope="module")
def cylinder():
    surface = cylinder_solid(15.0, 15.0, 0.45, 3.75, 4.0)
    return TibiaSolid(surface, {"top": up_facing(surface)}, "cylinder")


def test_sphere_into_a_thick_solid_cylinder_matches_hertz(cylinder):
    layers = solid_layers(cylinder, E, NU, base_deg=45.0)
    solid = layers["top"]
    contact = _press(layers, F).layers[0]
    p = contact.force_N / solid.tributary_mm2
    area = zero_contour_area(solid.surface.points, solid.surface.faces, p, contact.active)
    hertz = hertz_sphere_on_plane(F, R, E, NU)
    assert contact.force_N.sum() == pytest.approx(F, rel=1e-9)
    assert math.sqrt(area / hertz.area_mm2) == pytest.approx(1.0, abs=0.03)
    assert p.max() == pytest.approx(hertz.max_pressure_MPa, rel=0.03)


def test_one_solid_under_two_compartments_is_coupled_exactly():
    # the top split at x = 0 into two compartments of one solid: the contact straddles
    # the seam, and the coupled answer is the one-compartment answer
    coarse = cylinder_solid(15.0, 15.0, 0.9, 3.75, 4.0)
    top = up_facing(coarse)
    left = coarse.face_centroids[top, 0] < 0
    split = TibiaSolid(coarse, {"a": top[left], "b": top[~left]}, "cylinder")
    whole = _press(solid_layers(TibiaSolid(coarse, {"top": top}, "cylinder"), E, NU), F)
    halves = _press(solid_layers(split, E, NU), F)
    assert halves.q[0] == pytest.approx(whole.q[0], rel=1e-8)
    forces = [c.force_N.sum() for c in halves.layers]
    assert min(forces) > 0.3 * F and sum(forces) == pytest.approx(F, rel=1e-9)


def test_the_up_facing_part_of_the_insert_is_its_top(tmp_path):
    solid, top = insert_solid(fine_mm=2.0, coarse_mm=4.0)
    assert np.array_equal(np.sort(up_facing(solid)), np.sort(top))


@pytest.fixture(scope="module")
def implant(tmp_path_factory):
    return write_implant(tmp_path_factory.mktemp("implant"))


def _fe_json(scene, name: str, *overrides: str) -> dict:
    """`fecheck fe` of `scene` (exit 0) and its JSON."""
    out = scene.parent / f"{name}.json"
    assert main(["fe", str(scene), "--json", str(out),
                 *[a for o in overrides for a in ("--set", o)]]) == 0
    return json.loads(out.read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def solid_check(implant):
    return _fe_json(implant, "solid")


def test_the_implant_pair_runs_through_fe_with_the_insert_as_a_solid(implant, solid_check):
    check = solid_check
    geometry = check["fe_geometry"]
    assert geometry["tibial_surface"] == "solid:insert.stl"
    assert geometry["thickness_source"] == "solid"
    assert any("geometry.tibia_solid" in note for note in check["notes"])
    # z free only, no gravity: the FE contact forces on the tibia balance the load
    fz = sum(c["fe"]["force_vector_N"][2] for c in check["compartments"].values())
    assert fz == pytest.approx(-LOAD_N, rel=1e-9)
    for c in check["compartments"].values():
        assert c["min_contact_force_N"] >= 0.0 and c["max_penetration_mm"] <= 1e-6
        assert c["fe"]["area_mm2"] > 0
    # one solid for both compartments: its dofs counted once
    scene = load_scene(implant)
    tets = volume.tetrahedralize(surfaces.surface(scene, "tibia_solid", ""), "insert")
    assert geometry["elements"] == len(tets.tets)


@pytest.mark.slow
def test_a_layer_of_the_solids_thickness_map_is_good_enough_on_the_implant(implant,
                                                                          solid_check):
    # the crosscheck's note: within 2.1 % (p_max, area) and 0.1 mm (centre of pressure)
    layer = _fe_json(implant, "layer", "fe.body='layer'")
    assert layer["fe_geometry"]["thickness_source"] == "solid-distance"
    for c, chk in layer["compartments"].items():
        fe, ref = chk["fe"], solid_check["compartments"][c]["fe"]
        assert fe["max_pressure_MPa"] == pytest.approx(ref["max_pressure_MPa"], rel=0.025)
        assert fe["area_mm2"] == pytest.approx(ref["area_mm2"], rel=0.025)
        assert abs(fe["center_of_pressure_mm"][1] - ref["center_of_pressure_mm"][1]) < 0.1


@pytest.mark.parametrize("value, message", [
    ("missing.stl", "geometry.tibia_solid = 'missing.stl': file not found"),
    ("insert_top.stl", "geometry.tibia_solid must be a closed surface"),
])
def test_a_missing_or_open_solid_is_refused_before_any_mesh(implant, capsys, monkeypatch,
                                                             value, message):
    def never(*args, **kwargs):
        raise AssertionError("the volume was meshed")

    monkeypatch.setattr(volume, "tetrahedralize", never)
    assert main(["fe", str(implant), "--set", f"geometry.tibia_solid='{value}'"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]


def test_without_a_sheet_the_ef_uses_the_solids_up_facing_part(implant):
    scene = load_scene(implant, ["geometry.tibia=''"])
    sheets = surfaces.tibial_compartments(scene)
    top = surfaces.surface(load_scene(implant), "tibia", "")
    assert sum(s.n_faces for s in sheets.values()) == top.n_faces
    assert sum(s.area for s in sheets.values()) == pytest.approx(top.area, rel=1e-12)
    # split by geometry.tibia_split = 'sagittal' at x = 0 (face centroids): medial at -x
    assert (sheets["medial"].face_centroids[:, 0].max() < 0.0
            <= sheets["lateral"].face_centroids[:, 0].min())
