"""Two deformable cartilage layers in the FE (``fe.cartilage = "two-layer"``): the
femoral layer's give joins the joint contact solve.

References: Hertz for two elastic bodies (1/E* = (1-ν₁²)/E₁ + (1-ν₂²)/E₂, Johnson 1985
§4.2) for a large sphere with a thick bonded layer on a thick block; the mirror symmetry
of two equal layers (each takes half of the approach); the scene's load and weight.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from conftest import require_knee_data

from fecheck.errors import FecheckError
from fecheck.fe.bodies.indenter import MeshIndenter
from fecheck.fe.bodies.pose import FramePose
from fecheck.fe.bodies.solid import layer_solid
from fecheck.fe.knee import crosscheck
from fecheck.fe.knee.crosscheck import cross_check
from fecheck.fe.pressure.recovery import zero_contour_area
from fecheck.fe.solve.joint import ContactLayer, FemoralLayer, JointContact
from fecheck.model.assembly import applied_load, free_indices
from fecheck.reference.closed_forms import (
    hertz_contact_radius,
    hertz_effective_modulus,
    hertz_peak_pressure,
)
from fecheck.scene import load_scene
from fecheck.statics.newton import pose, twist_basis
from geometry.mesh import TriMesh
from geometry.plateau import plane_patch

E, NU = 20.0, 0.3
SCENES = Path(__file__).resolve().parents[2] / "validation" / "scenes"
UP = np.array([0.0, 0.0, 1.0])


def _cap(radius_mm: float, disc_mm: float, size: float, refine: float, refine_radius: float,
         down: bool, turn_deg: float = 0.0) -> TriMesh:
    """A spherical cap of `radius_mm` over a disc of `disc_mm` touching the origin: bulging
    up with normals up, or (`down`) its mirror image bulging down with normals down,
    turned `turn_deg` about z (so two caps' meshes do not match)."""
    disc = plane_patch((0.0, 0.0, 0.0), UP, radius=disc_mm, size=size,
                       refine_point=(0.0, 0.0, 0.0), refine_size=refine,
                       refine_radius=refine_radius)
    p = disc.points.copy()
    r2 = p[:, 0] ** 2 + p[:, 1] ** 2
    sag = radius_mm - np.sqrt(radius_mm ** 2 - r2) if math.isfinite(radius_mm) else 0 * r2
    p[:, 2] = sag if down else -sag
    faces = disc.faces[:, ::-1] if down else disc.faces
    c, s = math.cos(math.radians(turn_deg)), math.sin(math.radians(turn_deg))
    return TriMesh(p @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]).T, faces)


def _joint(tibial: TriMesh, h_t: float, femoral: TriMesh, h_f: float, *, levels: int = 2,
           grading: float = 1.6, margin: float = 1.0, femoral_radius: float = math.inf):
    """The tibial layer's candidates (gap under `margin` mm) condensed against the femoral
    layer, both deformable, the femoral vertices of the faces the candidates hit (within
    `femoral_radius` mm of the z axis) condensed: (tibial solid, femoral solid, joint)."""
    tib = layer_solid(tibial, h_t, E, NU, layers=levels, ratio=grading)
    fem = layer_solid(femoral, h_f, E, NU, layers=levels, ratio=grading)
    indenter = MeshIndenter(femoral)
    gap, face, _ = indenter.hits(tibial.points, tib.normals)
    cand = np.flatnonzero(gap.gap_mm < margin)
    hit = np.unique(femoral.faces[face[cand]])
    hit = hit[np.linalg.norm(femoral.points[hit, :2], axis=1) < femoral_radius]
    femur = FemoralLayer("femur", fem, hit)
    return tib, fem, JointContact([ContactLayer("tibia", tib, indenter, cand, femur)])


def _push(joint: JointContact, force: float, direction: np.ndarray = UP):
    """The tibial layer pushed along `direction` with `force` (N): (solution, contact)."""
    sol = joint.solve(lambda q: FramePose(np.eye(3), q[0] * direction),
                      lambda q: np.concatenate([direction, np.zeros(3)])[:, None],
                      lambda q: np.array([force]), np.zeros(1))
    return sol, sol.layers[0]


def _press(tibial: TriMesh, h_t: float, femoral: TriMesh, h_f: float, force: float, *,
           direction: np.ndarray = UP, **joint):
    """`_joint` then `_push`: (tibial solid, femoral solid, solution, contact)."""
    tib, fem, jc = _joint(tibial, h_t, femoral, h_f, **joint)
    return tib, fem, *_push(jc, force, direction)


@pytest.fixture(scope="module")
def mirrored_caps():
    """Two equal layers, mirror images (R 30 mm caps over 9 mm discs, 3 mm thick, meshes
    turned 17 deg apart), condensed once on the candidates within 1.5 mm of touching:
    (tibial surface, femoral surface, tibial solid, femoral solid, joint). The condensation
    is exact on any candidate set holding the contact, so the tests below share it."""
    tibial = _cap(30.0, 9.0, 0.6, 0.4, 4.0, down=False)
    femoral = _cap(30.0, 9.0, 0.6, 0.4, 4.0, down=True, turn_deg=17.0)
    return (tibial, femoral, *_joint(tibial, 3.0, femoral, 3.0, margin=1.5))


def test_equal_layers_split_the_approach_equally(mirrored_caps):
    """Two equal layers, mirror images (R 30 mm caps, 3 mm thick, meshes turned 17 deg
    apart): at the touch point each layer gives half of the approach."""
    tibial, femoral, tib, fem, joint = mirrored_caps
    sol, lc = _push(joint, 40.0)
    approach = float(sol.q[0])
    centre_t = int(np.argmin(np.linalg.norm(tibial.points, axis=1)))
    centre_f = int(np.argmin(np.linalg.norm(femoral.points, axis=1)))
    tibial_give = -(tib.normal_rows @ lc.u)[centre_t]              # down, into its bone
    femoral_give = -(fem.normal_rows @ lc.femoral_u)[centre_f]     # up, into its bone
    assert approach > 0.05
    assert lc.active[centre_t]
    assert tibial_give / approach == pytest.approx(0.5, abs=0.01)
    assert femoral_give / approach == pytest.approx(0.5, abs=0.01)
    # the contact forces balance the load, none pulls, no vertex penetrates
    assert lc.force_N @ tib.normals[:, 2] == pytest.approx(40.0, rel=1e-10)
    assert lc.force_N.min() >= 0.0
    assert lc.gap_mm.min() >= -1e-9


def test_the_pairing_follows_the_pose(mirrored_caps):
    """The tibial layer pushed along a line 30 deg off the axis slides 0.2 mm across the
    femoral mesh on its way to equilibrium: re-paired at the solution's pose, every
    vertex in contact has zero gap there (1e-9 mm), none penetrates, and the contact
    forces carry the load along that line."""
    _, _, tib, _, joint = mirrored_caps
    d = np.array([math.sin(math.radians(30.0)), 0.0, math.cos(math.radians(30.0))])
    sol, lc = _push(joint, 40.0, d)
    assert sol.q[0] * d[0] > 0.2
    assert np.abs(lc.gap_mm[lc.active]).max() < 1e-9
    assert lc.gap_mm.min() > -1e-9
    assert lc.force_N @ tib.normals @ d == pytest.approx(40.0, rel=1e-10)


def test_a_contact_beyond_the_condensed_femoral_vertices_is_refused():
    """Femoral vertices condensed only within 1 mm of the axis, under a contact about 3 mm
    wide: refused, naming the vertex, instead of a contact with no femoral give there."""
    tibial = _cap(30.0, 9.0, 0.6, 0.4, 4.0, down=False)
    femoral = _cap(30.0, 9.0, 0.6, 0.4, 4.0, down=True, turn_deg=17.0)
    with pytest.raises(FecheckError, match=r"tibial vertex at \(.*\) mm .*condensed"):
        _press(tibial, 3.0, femoral, 3.0, 40.0, femoral_radius=1.0)


def test_a_sphere_with_a_thick_layer_on_a_thick_block_matches_two_body_hertz():
    """A sphere of R 200 mm carrying a 60 mm layer pressed with 2 N on a 60 mm block, both
    of E 20 MPa, ν 0.3, bonded at their bases: Hertz with the combined modulus
    E* = E / (2 (1 - ν²)) (contact radius 3.0 mm, 0.05 of either thickness) within 3 %
    on p_max and the contact radius (measured +0.3 % and +0.8 % with 0.6 mm faces within
    4 mm of the axis and 4 layers graded 4.0, 43k dofs; +0.1 % and +1.2 % with 0.5 mm faces
    within 5 mm and 5 layers graded 3.0, 85k dofs; Hertz with the block alone deforming,
    E* = E / (1 - ν²), is 26 % off on the radius). The two surfaces are meshed alike (each
    block vertex meets a sphere vertex): on meshes turned 11 deg apart (the 85k-dof mesh)
    the radius stays within 0.3 % but the node-to-surface vertex p_max is 3.6 % high."""
    radius, force = 200.0, 2.0
    tibial = _cap(math.inf, 80.0, 16.0, 0.6, 4.0, down=False)
    femoral = _cap(radius, 80.0, 16.0, 0.6, 4.0, down=True)
    tib, _, _, lc = _press(tibial, 60.0, femoral, 60.0, force, levels=4, grading=4.0,
                           margin=0.1)
    a_ref = hertz_contact_radius(force, radius, hertz_effective_modulus(E, NU, E, NU))
    pressure = lc.force_N / tib.tributary_mm2
    area = zero_contour_area(tibial.points, tibial.faces, pressure, lc.active)
    assert math.sqrt(area / math.pi) == pytest.approx(a_ref, rel=0.03)
    assert pressure.max() == pytest.approx(hertz_peak_pressure(force, a_ref), rel=0.03)


def _free_residual(scene, check) -> np.ndarray:
    """Generalised force on the scene's free DOFs at the FE pose: load, gravity and the FE
    contact forces on the tibia (N, N·mm); zero at equilibrium."""
    p = check.pose["fe"]
    q = np.array([p["x_mm"], p["y_mm"], p["z_mm"], math.radians(p["abduction_deg"]),
                  math.radians(p["internal_deg"])])
    theta = math.radians(scene["dofs.flexion_deg"])
    rot, t = pose(q, theta)
    total = applied_load(scene)(rot, t)[0]
    for chk in check.compartments.values():
        x = chk.layer.surface.points @ rot.T + t
        f = -chk.fe_force_N[:, None] * (chk.layer.solid.normals @ rot.T)
        total = total + np.concatenate([f.sum(axis=0), np.cross(x, f).sum(axis=0)])
    return (twist_basis(q, theta).T @ total)[list(free_indices(scene))]


def test_the_scanned_knee_two_layer_fe_balances_and_does_not_penetrate():
    """The scanned knee (decimated to 1,500 tibial faces) with both cartilages deformable:
    the free DOFs balance to 1e-8 of the load, no vertex penetrates beyond 1e-6 mm, and
    the femoral layer gives (its surface moves toward its bone under the contact)."""
    require_knee_data()
    scene = load_scene(SCENES / "femur_tibia.toml",
                       ["scanned.decimate_faces=1500", "fe.cartilage='two-layer'"])
    check = cross_check(scene, log=None)
    assert check.geometry["deformable_layers"] == 2
    assert check.geometry["cartilage"] == "two-layer"
    assert any("two deformable layers" in note for note in check.notes)
    residual = _free_residual(scene, check)
    assert np.abs(residual).max() < 1e-8 * scene["load.force_N"]
    for chk in check.compartments.values():
        assert chk.max_penetration_mm <= 1e-6
        assert chk.fe_force_N.min() >= 0.0 and chk.fe.area_mm2 > 0


@pytest.mark.parametrize("name, overrides, message", [
    ("baseline.toml", [], "model.kind = 'femur-tibia'"),
    ("femur_tibia.toml", ["fe.prepare='on'"], "fe.prepare"),
])
def test_scenes_the_two_layer_fe_does_not_model_are_refused_before_the_ef_run(
        monkeypatch, name, overrides, message):
    def no_ef_run(*args, **kwargs):
        raise AssertionError("the EF run started before the refusal")

    monkeypatch.setattr(crosscheck, "_ef_run", no_ef_run)
    scene = load_scene(SCENES / name, [*overrides, "fe.cartilage='two-layer'"])
    with pytest.raises(FecheckError, match=message):
        crosscheck.cross_check(scene, log=None)


def _pleated_sheet(pleat_x_mm: float):
    """A flat 24 x 24 mm femoral sheet (1 mm grid, 2 mm thick) with a pleat along y at
    x = `pleat_x_mm`: that row of vertices pushed 1.6 mm back under its neighbour, so the
    faces beside it invert when extruded."""
    from fecheck.fe.knee.femoral import FemoralSheet

    n = 25
    x, y = np.meshgrid(np.linspace(-12.0, 12.0, n), np.linspace(-12.0, 12.0, n))
    points = np.column_stack([x.ravel(), y.ravel(), np.zeros(n * n)])
    a = (np.arange(n - 1)[:, None] * n + np.arange(n - 1)).ravel()
    faces = np.concatenate([np.column_stack([a, a + 1, a + n + 1]),
                            np.column_stack([a, a + n + 1, a + n])])
    row = np.isclose(points[:, 0], pleat_x_mm)
    points[row] += [-1.6, 0.0, -0.6]
    return FemoralSheet(TriMesh(points, faces), np.full(n * n, 2.0), "uniform", E, NU)


def test_a_fold_of_the_femoral_sheet_away_from_the_contact_is_left_out():
    # The femoral layer ends 0.5 mm before the nearest face that inverts (measured 5.6 mm
    # from the contact for a pleat at x = 7 mm: the layer ends at 5.1 mm, the pleat out),
    # and refuses, naming the place, when that face lies nearer the contact than
    # MIN_CROP_MM + 0.5 mm (3.6 mm for a pleat at x = 5 mm).
    from fecheck.fe.bodies.settings import FESettings
    from fecheck.fe.knee.femoral import MIN_CROP_MM, TRIM_MM, femoral_layer

    settings = FESettings.from_scene(load_scene(SCENES / "femur_tibia.toml"))
    said = []
    hits = np.array([[0.0, y, 0.0] for y in np.linspace(-3.0, 3.0, 7)])
    layer = femoral_layer(_pleated_sheet(7.0), "medial", hits, np.zeros(7, dtype=int),
                          settings, said.append)
    assert any("invert in extrusion" in line for line in said)
    centroids = layer.solid.surface.face_centroids
    reach = np.linalg.norm(centroids[:, None, :2] - hits[None, :, :2], axis=2).min(axis=1)
    assert MIN_CROP_MM < reach.max() <= 5.6 - TRIM_MM
    assert centroids[:, 0].max() < 5.4                  # every face short of the pleat
    with pytest.raises(FecheckError, match=r"faces invert, e\.g\. at \(3\.6, .*3\.6 mm from"):
        femoral_layer(_pleated_sheet(5.0), "medial", hits, np.zeros(7, dtype=int), settings,
                      said.append)
