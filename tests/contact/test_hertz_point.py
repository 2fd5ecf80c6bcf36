"""Smooth Hertz: the closed-form sphere-plane point contact and `laws.hertz_point`.

Issues 3 and 4: Hertz from the deepest vertex of a meshed plateau is not smooth in the
pose and Newton stalled at load points x = 0.9 and 2.9 mm; the closed-form maximum depth
d = R − n·(c − p) is smooth.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from gjk_reference import BoxShape, SphereShape, gjk_epa

from fecheck import laws
from fecheck.contact.convex import SpherePlanePair
from fecheck.model.assembly import applied_load, plateau_normals
from fecheck.model.run import run_scene
from fecheck.model.sphere_plane import build_compartments
from fecheck.scene import load_scene
from fecheck.scene.constants import GRAVITY_MPS2
from fecheck.statics.frames import rotation
from fecheck.statics.newton import pose
from fecheck.statics.rigid import solve_rigid
from geometry.plateau import plane_patch

SCENES = Path(__file__).resolve().parents[2] / "validation" / "scenes"
E_STAR = laws.hertz_modulus(20.0, 0.3)
R = 25.5
CENTRE = np.array([-25.0, 1.0, 25.5])
PLANE_POINT = np.array([-25.0, 1.0, 0.0])
NORMAL = np.array([0.1, -0.05, 1.0]) / np.linalg.norm([0.1, -0.05, 1.0])
I3, O3 = np.eye(3), np.zeros(3)
# an imposed tibia pose: tilted, shifted up into the sphere by ~1.5 mm
SLAVE = (rotation(0.02, -0.03, 0.05), np.array([0.4, -0.3, 1.5]))
LOAD_POINTS_MM = (0.9, 2.9, 7.9, 12.9, 14.9)        # thesis Fig. 5.8: 7.9 ± 7 mm


def _pair(mesh=None) -> SpherePlanePair:
    return SpherePlanePair(CENTRE, R, PLANE_POINT, NORMAL, mesh=mesh)


def _moved(xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The slave pose after the small world motion ξ = (v, ω): x → exp([ω]) x + v."""
    from scipy.spatial.transform import Rotation

    rot = Rotation.from_rotvec(xi[3:]).as_matrix()
    return rot @ SLAVE[0], rot @ SLAVE[1] + xi[:3]


def test_depth_is_the_epa_penetration_of_the_sphere_into_the_plateau():
    # independent reference: GJK/EPA between the sphere and a 200 mm box whose top face
    # is the tilted plateau plane at the imposed pose (EPA stops at 1e-9 relative)
    rot, t = SLAVE
    half = np.array([100.0, 100.0, 10.0])
    e1 = np.cross([0.0, 1.0, 0.0], NORMAL)
    e1 /= np.linalg.norm(e1)
    frame = np.column_stack([e1, np.cross(NORMAL, e1), NORMAL])
    box = BoxShape(rot @ (PLANE_POINT - half[2] * NORMAL) + t, half, rot @ frame)
    ref = gjk_epa(SphereShape(CENTRE, R), box)
    got = _pair().evaluate(SLAVE, (I3, O3))
    assert ref.overlap and ref.depth > 0.5
    assert got.depth_mm == pytest.approx(ref.depth, rel=1e-8)
    assert np.allclose(got.direction, ref.normal, atol=1e-8)       # pushes the plateau away


def test_force_radius_and_peak_pressure_follow_the_hertz_closed_forms():
    # Hertz: a = (3PR/(4E*))^(1/3), p0 = 3P/(2πa²), d = a²/R; eq. 4.4:
    # P = 4/3·E*·√R·d^{3/2}, along minus the plateau normal through the sphere centre
    about = np.array([3.0, -2.0, -40.0])
    contact = _pair().evaluate(SLAVE, (I3, O3))
    res = laws.hertz_point(contact, R, E_STAR, about)
    d = contact.depth_mm
    p = 4.0 / 3.0 * E_STAR * math.sqrt(R) * d**1.5
    a = (3 * p * R / (4 * E_STAR)) ** (1 / 3)
    n_world = SLAVE[0] @ NORMAL
    assert np.allclose(res.force, -p * n_world, rtol=0, atol=1e-10 * p)
    assert np.allclose(res.moment, np.cross(CENTRE - about, res.force), rtol=0,
                       atol=1e-10 * p * 100)
    assert res.contact_radius_mm == pytest.approx(a, rel=1e-12)
    assert a * a / R == pytest.approx(d, rel=1e-12)
    assert res.max_pressure == pytest.approx(3 * p / (2 * math.pi * a * a), rel=1e-12)
    assert res.area == pytest.approx(math.pi * a * a, rel=1e-12)
    assert res.mean_pressure == pytest.approx(p / (math.pi * a * a), rel=1e-12)
    assert res.max_depth == d


@pytest.mark.parametrize("about", [(0.0, 0.0, 0.0), (3.0, -2.0, -40.0)])
def test_tangent_matches_central_differences(about):
    # h = 1e-6: truncation ~h²·|F''| ≈ 1e-12 relative, round-off ~1e-16/h ≈ 1e-10,
    # so 1e-6 relative leaves four orders of margin
    about = np.asarray(about)
    pair = _pair()

    def wrench(slave_pose):
        r = laws.hertz_point(pair.evaluate(slave_pose, (I3, O3)), R, E_STAR, about)
        return np.concatenate([r.force, r.moment])

    tangent = laws.hertz_point(pair.evaluate(SLAVE, (I3, O3)), R, E_STAR, about).tangent
    h = 1e-6
    fd = np.column_stack([(wrench(_moved(h * e)) - wrench(_moved(-h * e))) / (2 * h)
                          for e in np.eye(6)])
    assert np.abs(fd - tangent).max() <= 1e-6 * np.abs(fd).max()


def test_separated_pair_gives_no_force_and_zero_face_pressure():
    plate = plane_patch(PLANE_POINT, NORMAL, radius=10.0, size=2.0)
    contact = _pair(plate).evaluate((I3, np.array([0.0, 0.0, -2.0])), (I3, O3))
    res = laws.hertz_point(contact, R, E_STAR)
    assert contact.depth_mm < 0
    assert not res.force.any() and not res.tangent.any() and res.area == 0.0
    assert not res.face_pressure().any() and len(res.face_pressure()) == plate.n_faces


def test_face_pressure_is_lazy_and_integrates_to_the_force():
    # the solve never touches the plateau mesh; asked for, the Hertz distribution
    # p0·√(1 − r²/a²) sampled at 0.5 mm face centroids integrates to P (measured within
    # 0.02 % at 0.5 mm, 0.12 % at 0.8 mm: the square-root edge at r = a is the coarsest
    # part of the centroid rule), hence 0.2 %
    plate = plane_patch(PLANE_POINT, NORMAL, radius=12.0, size=0.5)
    built = []

    def mesh():
        built.append(1)
        return plate

    pair = _pair(mesh)
    for dz in np.linspace(1.0, 1.5, 5):
        res = laws.hertz_point(pair.evaluate((I3, np.array([0.0, 0.0, dz])), (I3, O3)),
                               R, E_STAR)
    assert not built
    fp = res.face_pressure()
    assert len(built) == 1
    assert fp.max() <= res.max_pressure
    assert float(fp @ plate.face_areas) == pytest.approx(np.linalg.norm(res.force), rel=2e-3)


# ----------------------------------------------------------------------- statics
def _hertz_run(x_mm: float, *extra: str):
    return run_scene(load_scene(SCENES / "hertz.toml",
                                [f"load.point_mm=[{x_mm}, 12.8, -380.0]", *extra]))


def _contact_force_sum(scene, result) -> np.ndarray:
    """Σ compartment forces on the tibia (N): magnitude along minus the plateau normal."""
    rot, _ = pose(np.array(result.pose.q))
    normals = plateau_normals(scene)
    return sum(-res.force_N * (rot @ normals[c]) for c, res in result.compartments.items())


@pytest.mark.parametrize("plateau", ["transverse", "inclined"])
@pytest.mark.parametrize("x_mm", LOAD_POINTS_MM)
def test_load_sweep_converges_and_matches_rigid_statics_at_the_solved_pose(x_mm, plateau):
    # The Hertz resultant acts along the plateau normal through the condyle centre, the
    # line of the rigid model's ball reaction: rigid statics at the solved pose gives the
    # same split (to the Newton tolerance, 1e-8 of 800 N), and with gravity the
    # compartment forces balance the load.
    scene = load_scene(SCENES / "hertz.toml", [f"load.point_mm=[{x_mm}, 12.8, -380.0]",
                                               f"plateau.kind='{plateau}'"])
    r = run_scene(scene)
    assert r.converged and r.iterations <= 15
    q = np.array(r.pose.q)
    rot, t = pose(q)
    applied, _ = applied_load(scene)(rot, t)
    rigid = solve_rigid(scene.knee, plateau_normals(scene), applied, q, (2, 3))
    for c, res in r.compartments.items():
        assert res.force_N == pytest.approx(rigid.contact_force_N[c], abs=1e-4)
    # z is free (x, y are driven, their reactions are not reported): vertical balance
    weight = 2.0 * GRAVITY_MPS2
    assert _contact_force_sum(scene, r)[2] + 800.0 - weight == pytest.approx(0.0, abs=1e-6)


@pytest.mark.parametrize("x_mm", LOAD_POINTS_MM)
def test_load_sweep_with_ligament_rods_converges(x_mm):
    # thesis Fig. 5.9: the ACL, PCL and MCL as rods, all five DOFs free
    scene = load_scene(SCENES / "hertz.toml", [
        f"load.point_mm=[{x_mm}, 12.8, -380.0]", "ligaments.model='rod'",
        "dofs.free=['x', 'y', 'z', 'abduction', 'internal']"])
    r = run_scene(scene)
    assert r.converged and r.iterations <= 15
    assert r.residual_norm < 1e-8 * 800.0


def test_compartment_results_report_hertz_values_and_face_pressures():
    # d = a²/R and p0 = 1.5·p_mean (Hertz), the pressure drawn on the plateau faces
    r = _hertz_run(7.9)
    knee = load_scene(SCENES / "hertz.toml").knee
    for c, res in r.compartments.items():
        a = math.sqrt(res.area_mm2 / math.pi)
        assert res.max_depth_mm == pytest.approx(a * a / knee.radius_mm(c), rel=1e-12)
        assert res.max_pressure_MPa == pytest.approx(1.5 * res.mean_pressure_MPa, rel=1e-12)
        assert res.face_pressure_MPa.shape == (len(res.slave_faces),)
        assert 0 < res.n_contact_faces == np.count_nonzero(res.face_pressure_MPa)
        assert res.face_pressure_MPa.max() <= res.max_pressure_MPa
    assert all("closed form sphere-plane" in d for d in r.record.detection.values())


@pytest.mark.parametrize("overrides", [("contact.detection='bvh'",),
                                       ("contact.master='plateau'", "contact.area='whole-face'")])
def test_deepest_vertex_hertz_is_kept_for_meshes_and_says_it_is_not_smooth(overrides):
    # mesh detection and the thesis's whole-face counting need the meshed path
    scene = load_scene(SCENES / "hertz.toml", [*overrides, "mesh.sphere_subdivisions=2"])
    comps = build_compartments(scene)
    assert all("not smooth" in c.describe() for c in comps)
    assert not any(isinstance(c.pair, SpherePlanePair) for c in comps)
