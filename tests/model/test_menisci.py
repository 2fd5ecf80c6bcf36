"""The scanned knee with menisci (issue 28): free rigid menisci between the cartilages, at
smith2019's femur pose, against statics computed here from the contact interfaces and
springs, and the pose composition and interface stiffness by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest
from contact_helpers import box

from fecheck.contact.pair import ContactPair
from fecheck.errors import FecheckError
from fecheck.laws.fused import linear_law
from fecheck.model import menisci
from fecheck.model.run import run_scene
from fecheck.scene import load_scene
from fecheck.scene.constants import GRAVITY_MPS2
from fecheck.statics.frames import rot_y
from fecheck.statics.interfaces import Interface
from fecheck.statics.newton import Body, Problem, body_pose, point_force, solve
from fecheck.statics.root_spring import RootSpring
from geometry.plateau import plane_patch

LOAD_N = 800.0
TIBIA_KG = 2.65207          # femur_tibia_menisci.toml [tibia]


@pytest.fixture(scope="module")
def intact():
    """(scene, problem, interfaces, springs, solution) of the packaged scene."""
    scene = load_scene("femur_tibia_menisci")
    problem, interfaces, springs, _, _, _ = menisci.build_problem(scene)
    return scene, problem, interfaces, springs, solve(problem)


@pytest.fixture(scope="module")
def results():
    """The run of the intact knee and of the knee without its medial meniscus."""
    return (run_scene(load_scene("femur_tibia_menisci")),
            run_scene(load_scene("femur_tibia_menisci", ["menisci.sides=['lateral']"])))


def _forces_on(body: int, interfaces, springs, poses) -> np.ndarray:
    """Σ of the contact and spring forces (3,) on `body`, N, summed here from each
    interface's wrench on its slave (minus it on its master) and each spring's ends."""
    total = np.zeros(3)
    for i in interfaces:
        w = i.wrench_on_slave(poses)[:3]
        total += w * (i.slave == body) - w * (i.master == body)
    for s in springs.values():
        if isinstance(s, RootSpring):                          # a root: on the meniscus
            f = s.force(poses)
            total += f * (s.meniscus == body) - f * (s.tibia == body)
            continue
        x_a, x_b = s.ends(poses)
        pull = s.tension(poses) * (x_a - x_b) / np.linalg.norm(x_a - x_b)   # on end b
        total += pull * (s.body_b == body) - pull * (s.body_a == body)
    return total


def test_tibia_and_menisci_balance_at_800_N(intact):
    # Each meniscus (all six DOFs free) carries no net force: femur, tibia and its
    # ligaments balance to 1e-8 of the load; the tibia (z free) balances the 800 N and its
    # weight along z. Forces are summed here from the interfaces and springs (not the
    # solver's sum); the solver stops at 1e-8 of the load in its scaled norm.
    scene, problem, interfaces, springs, sol = intact
    assert sol.converged
    poses = [body_pose(q) for q in sol.q]
    for body in (2, 3):                                      # medial, lateral meniscus
        assert np.abs(_forces_on(body, interfaces, springs, poses)).max() <= 1e-8 * LOAD_N
    on_tibia = _forces_on(menisci.TIBIA, interfaces, springs, poses)
    assert on_tibia[2] + LOAD_N - TIBIA_KG * GRAVITY_MPS2 == pytest.approx(0.0,
                                                                          abs=1e-8 * LOAD_N)
    assert max(menisci.balance(problem, sol.q).values()) <= 1e-8 * LOAD_N
    assert all(i.max_depth_mm > 0 for i in interfaces)       # every interface in contact


def test_meniscal_share_splits_each_compartments_load(intact, results):
    # Per compartment the meniscus and cartilage-cartilage loads into the tibia are both
    # compressive and the share is their ratio; the four loads are the contact and root
    # spring forces on the tibia (summed here from the interfaces and springs) along its
    # axis a; the contact's z component balances the load less the tibia's weight plus
    # the springs' z pull on the tibia (computed here), to 1e-8 of the load (x and y of
    # the tibia are held).
    _, _, interfaces, springs, sol = intact
    rows = results[0].menisci["compartments"]
    poses = [body_pose(q) for q in sol.q]
    lig = _forces_on(menisci.TIBIA, [], springs, poses)
    lig_z = lig[2]
    contact = _forces_on(menisci.TIBIA, interfaces, {}, poses)
    carried = sum(r["meniscus_N"] + r["cartilage_N"] for r in rows.values())
    axis = poses[menisci.TIBIA][0][:, 2]
    assert abs(axis[2] - 1.0) < 1e-4                           # axial ≈ z: ~0.3° tilt
    # the menisci's loads count their root springs to the tibia (the only springs here)
    assert carried == pytest.approx(-(contact + lig) @ axis, rel=1e-12)
    assert -contact[2] == pytest.approx(LOAD_N - TIBIA_KG * GRAVITY_MPS2 + lig_z,
                                        abs=1e-8 * LOAD_N)
    for r in rows.values():
        assert r["meniscus_N"] > 0 and r["cartilage_N"] > 0
        assert 0 < r["meniscal_share"] < 1
        assert r["meniscal_share"] == pytest.approx(
            r["meniscus_N"] / (r["meniscus_N"] + r["cartilage_N"]), rel=1e-12)
        # the meniscus passes the femur's load on to the tibia, by contact and through its
        # root springs (the meniscus balances: to 1e-8 of the load)
        assert r["femur_on_meniscus_N"] == pytest.approx(r["meniscus_N"], abs=1e-8 * LOAD_N)
        assert r["meniscus_N"] == pytest.approx(
            r["meniscus_contact_N"] + r["meniscus_springs_N"], rel=1e-12)


def test_removing_the_medial_meniscus_loads_the_medial_cartilage_more(results):
    # A medial meniscectomy: the medial compartment's whole load goes through the
    # cartilages, so its cartilage force rises above the intact knee's; nothing passes a
    # removed meniscus, and the lateral meniscus still carries load.
    whole, removed = (r.menisci["compartments"] for r in results)
    assert removed["medial"]["meniscus_N"] == 0.0 and removed["medial"]["meniscal_share"] == 0
    assert removed["medial"]["cartilage_N"] > whole["medial"]["cartilage_N"] + 10.0
    assert removed["lateral"]["meniscus_N"] > 0
    assert "medial meniscus" not in results[1].menisci["poses"]
    assert results[1].converged


def test_tibia_starts_at_the_inverse_of_G_composed_with_the_scene_pose():
    # The femur at G = [Ry(θ), t_G] relative to a tibia at the scene's start pose S is the
    # femur at identity with the tibia at G⁻¹·S: check G·T_start = S as 4×4 matrices.
    scene = load_scene("femur_tibia_menisci", ["dofs.x_mm=0.7", "dofs.y_mm=-1.2",
                                               "dofs.abduction_deg=2", "dofs.internal_deg=3"])
    theta, t_g = menisci.femur_pose(menisci.menisci_dir(scene))
    assert math.degrees(theta) == pytest.approx(1.0, abs=1e-4)  # README: rotated 1° about y
    np.testing.assert_allclose(t_g, [-0.336609, -2.0, 2.972278], atol=1e-6)
    q = menisci.start_coordinates(scene, theta, t_g)

    def matrix(rot, t):
        out = np.eye(4)
        out[:3, :3], out[:3, 3] = rot, t
        return out

    g = matrix(rot_y(theta), t_g)
    s_rot = rot_y(math.radians(2.0)) @ np.array([[math.cos(math.radians(3)),
                                                  -math.sin(math.radians(3)), 0],
                                                 [math.sin(math.radians(3)),
                                                  math.cos(math.radians(3)), 0], [0, 0, 1]])
    s = matrix(s_rot, [0.7, -1.2, -scene["solver.start_gap_mm"]])
    np.testing.assert_allclose(g @ matrix(*body_pose(q)), s, atol=1e-12)


def test_meniscus_interface_stiffness_is_smith2019s_lumped_layer():
    # smith2019's lumped model (OpenSim-JAM Smith2018ArticularContactForce): mean E
    # (1 + 20)/2 = 10.5 MPa, mean ν (0.45 + 0.3)/2 = 0.375, summed h 3 + 6/2 = 6 mm:
    # k = 0.625·10.5/(1.375·0.25·6) = 6.5625/2.0625 = 3.181818 N/mm³.
    law = menisci.meniscus_law(load_scene("femur_tibia_menisci"))
    assert law.params[0] == pytest.approx(3.181818, rel=1e-6)


def test_meniscus_interface_stiffness_in_series_on_request():
    # 1 MPa, ν 0.45, 3 mm meniscus: k = (1-ν)E/((1+ν)(1-2ν)h) = 0.55/(1.45·0.1·3)
    # = 1.264368 N/mm³; one cartilage layer 20 MPa, ν 0.3, 6/2 mm: 14/(1.3·0.4·3)
    # = 8.974359 N/mm³; in series 1/(1/1.264368 + 1/8.974359) = 1.108233 N/mm³.
    law = menisci.meniscus_law(load_scene("femur_tibia_menisci", ["menisci.layers=series"]))
    assert law.params[0] == pytest.approx(1.108233, rel=1e-6)


K_MEN, K_CART, P_N = 1.1, 9.0, 300.0       # N/mm³, N/mm³, N
MEN = 2                                      # the reduced case's meniscus body


def _disc(x: float, y: float, z: float, normal_z: float):
    return plane_patch((x, y, z), (0.0, 0.0, normal_z), radius=4.0, size=1.0)


def test_reduced_knee_share_meets_the_hand_statics():
    # A flat "knee": the tibia (z free) pushed up by 300 N; medially a cartilage disc under
    # a femoral block (gap 0.1 mm) and a meniscus block (z free) between a femoral disc
    # (0.02 mm into its top at z_m = 0) and a tibial disc; laterally a cartilage disc
    # under a block 0.2 mm above. Cartilage sheets are the slaves and blocks (closed) the
    # masters, as in the knee. Flat faces with a uniform depth: F = k·A·d exactly, so with
    # z_t, z_m the tibia's and meniscus's rise: meniscus k_m A (z_m + 0.02) = k_m A (z_t -
    # z_m), tibia k_m A (z_t - z_m) + k_c A (z_t - 0.1) + k_c A (z_t - 0.2) = P; the
    # shares follow. Tolerance: rounding (measured ~1e-12) and the solver's 1e-8.
    femur, tibia = 0, 1
    pairs = {
        "medial": (ContactPair(_disc(-20, 15, 0.0, 1.0), box((-30, 8, 0.1), (-10, 22, 5))),
                   K_CART, tibia, femur),
        "lateral": (ContactPair(_disc(20, 0, 0.0, 1.0), box((10, -7, 0.2), (30, 7, 5))),
                    K_CART, tibia, femur),
        "medial femur-meniscus": (ContactPair(_disc(-20, -15, 1.98, -1.0),
                                              box((-30, -22, 0.0), (-10, -8, 2.0))),
                                  K_MEN, femur, MEN),
        "medial meniscus-tibia": (ContactPair(_disc(-20, -15, 0.0, 1.0),
                                              box((-30, -22, 0.0), (-10, -8, 2.0))),
                                  K_MEN, tibia, MEN),
    }
    interfaces = [Interface(n, pair, linear_law(k), s, m) for n, (pair, k, s, m) in
                  pairs.items()]
    # a start with every interface touching: the system is linear from there
    bodies = (Body("femur", np.zeros(6), ()), Body("tibia", np.array([0, 0, 0.25, 0, 0, 0]),
                                                   (2,)),
              Body("meniscus", np.array([0, 0, 0.1, 0, 0, 0]), (2,)))

    def wrench(poses):
        push = point_force(poses[tibia][1], np.array([0.0, 0.0, P_N]))
        return [i(poses) for i in interfaces] + [((tibia,), *push)]

    sol = solve(Problem(bodies, wrench, force_scale_N=P_N,
                        touching=lambda: any(i.max_depth_mm > 0 for i in interfaces)))
    assert sol.converged
    area = {n: float(pair.slave.face_areas.sum()) for n, (pair, *_) in pairs.items()}
    a_ft, a_tm = area["medial femur-meniscus"], area["medial meniscus-tibia"]
    a_cm, a_cl = area["medial"], area["lateral"]
    # unknowns (z_t, z_m): the two balances above, linear
    mat = np.array([[-K_MEN * a_tm, K_MEN * (a_ft + a_tm)],
                    [K_MEN * a_tm + K_CART * (a_cm + a_cl), -K_MEN * a_tm]])
    rhs = np.array([-0.02 * K_MEN * a_ft, P_N + K_CART * (0.1 * a_cm + 0.2 * a_cl)])
    z_t, z_m = np.linalg.solve(mat, rhs)
    assert z_t > 0.2 and z_t > z_m > -0.02                     # every interface touches
    assert sol.q[tibia][2] == pytest.approx(z_t, abs=1e-9)
    assert sol.q[MEN][2] == pytest.approx(z_m, abs=1e-9)
    rows = menisci._shares(interfaces, [body_pose(q) for q in sol.q], ("medial",))
    f_men, f_cm = K_MEN * a_tm * (z_t - z_m), K_CART * a_cm * (z_t - 0.1)
    assert rows["medial"]["meniscus_N"] == pytest.approx(f_men, rel=1e-8)
    assert rows["medial"]["femur_on_meniscus_N"] == pytest.approx(f_men, rel=1e-8)
    assert rows["medial"]["cartilage_N"] == pytest.approx(f_cm, rel=1e-8)
    assert rows["medial"]["meniscal_share"] == pytest.approx(f_men / (f_men + f_cm), rel=1e-8)
    assert rows["lateral"]["meniscal_share"] == 0.0
    # the meniscus on the tibial disc: uniform depth z_t - z_m over the whole disc, so
    # p_max = k_m (z_t - z_m) and the contact area is the disc's
    maps = menisci._maps(interfaces, [body_pose(q) for q in sol.q],
                         {"medial": box((-30, -22, 0.0), (-10, -8, 2.0))})
    assert maps["medial"]["max_pressure_MPa"] == pytest.approx(K_MEN * (z_t - z_m), rel=1e-8)
    assert maps["medial"]["area_mm2"] == pytest.approx(a_tm, rel=1e-9)
    assert rows["lateral"]["cartilage_N"] == pytest.approx(K_CART * a_cl * (z_t - 0.2),
                                                           rel=1e-8)


def test_footprint_outline_is_the_bottom_edge_of_a_turned_box():
    # A 4 x 2 x 1 mm box turned 30° about z and moved by (5, -3, 7): its footprint's edge is
    # the bottom rectangle at z = 7 + 0 (the box spans z 0..1), corners (±2, ±1) turned:
    # x half-extent 2cos30 + 1sin30 = 2.232051, y half-extent 2sin30 + 1cos30 = 1.866025.
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    seg = menisci.footprint_outline(box((-2, -1, 0), (2, 1, 1)), rot, np.array([5, -3, 7.0]))
    pts = seg.reshape(-1, 3)
    np.testing.assert_allclose(pts[:, 2], 7.0, atol=1e-12)
    np.testing.assert_allclose([pts[:, 0].min(), pts[:, 0].max(), pts[:, 1].min(),
                                pts[:, 1].max()],
                               [5 - 2.232051, 5 + 2.232051, -3 - 1.866025, -3 + 1.866025],
                               atol=1e-6)
    # the four sides' lengths: 2 x 4 + 2 x 2 mm
    assert np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1).sum() == pytest.approx(12.0)


def test_pressure_map_draws_each_meniscus_footprint_where_it_sits(results):
    # Both maps (cartilage and meniscus pressure) draw each meniscus's footprint edge; the
    # drawn lines span the x-y bounds of the meniscus volume's vertices at its solved pose
    # (computed here from the reported pose). The extreme vertices of the shipped volume
    # lie on the silhouette; the fit (vertical only: the same x-y) may turn a rim face
    # next to one upward, so the drawn edge passes near it: measured 7.5e-3 mm; 0.01 mm.
    from fecheck.io.plots import pressure_map_figure

    intact = results[0]
    folder = menisci.menisci_dir(load_scene("femur_tibia_menisci"))
    fig = pressure_map_figure(intact)
    try:
        drawn = [np.asarray(line.points) for line in fig.lines]
    finally:
        fig.plotter.close()
    assert len(drawn) == 4                              # two maps, two menisci
    for k, side in enumerate(("medial", "lateral")):
        rot, t = body_pose(np.array(intact.menisci["poses"][f"{side} meniscus"]["q"]))
        pts = menisci.read_volume(folder, side).points @ rot.T + t
        want = [pts[:, 0].min(), pts[:, 0].max(), pts[:, 1].min(), pts[:, 1].max()]
        for line in (drawn[k], drawn[2 + k]):
            got = [line[:, 0].min(), line[:, 0].max(), line[:, 1].min(), line[:, 1].max()]
            np.testing.assert_allclose(got, want, atol=0.01)


def test_fe_and_flex_refuse_the_menisci_they_do_not_model(monkeypatch):
    """The FE cross-check (and calibrate, which runs it) and `fecheck flex` have no
    meniscus bodies: a scene with menisci is refused before any solve, never answered as
    the knee without them."""
    from fecheck.fe.knee import crosscheck
    from fecheck.studies import flex

    def no_ef_run(*args, **kwargs):
        raise AssertionError("the EF run started before the refusal")

    monkeypatch.setattr(crosscheck, "_ef_run", no_ef_run)
    scene = load_scene("femur_tibia_menisci")
    with pytest.raises(FecheckError, match=r"does not model menisci.*menisci.dir = ''"):
        crosscheck.cross_check(scene, log=None)
    with pytest.raises(FecheckError, match=r"flex does not carry the menisci.*menisci.dir"):
        flex.check_kind(scene)
    flex.check_kind(load_scene("femur_tibia_menisci", ["menisci.dir=''"]))


@pytest.mark.parametrize("load_n", [200.0, 2000.0])
def test_packaged_knee_balances_at_200_and_2000_N(load_n):
    # These loads did not converge while the meniscus interfaces' depth depended on the
    # calls before (side-of-normal sign, closest-face walk). Forces at the run's poses are
    # summed here by interfaces and springs built afresh (no evaluation history): each
    # meniscus carries no net force and the tibia balances load and weight along z, to
    # 1e-8 of the load.
    scene = load_scene("femur_tibia_menisci", [f"load.force_N={load_n}"])
    result = run_scene(scene)
    assert result.converged
    problem, interfaces, springs, _, _, _ = menisci.build_problem(scene)
    q = [np.asarray(result.menisci["poses"][b.name]["q"]) if b.free else b.q_start
         for b in problem.bodies]
    poses = [body_pose(qb) for qb in q]
    for body in (2, 3):                                      # medial, lateral meniscus
        assert np.abs(_forces_on(body, interfaces, springs, poses)).max() <= 1e-8 * load_n
    on_tibia = _forces_on(menisci.TIBIA, interfaces, springs, poses)
    assert on_tibia[2] + load_n - TIBIA_KG * GRAVITY_MPS2 == pytest.approx(
        0.0, abs=1e-8 * load_n)
    assert all(i.max_depth_mm < 2.0 for i in interfaces)    # no spurious deep points


def test_winding_sign_depth_does_not_depend_on_the_call_before():
    # A 2 mm thin closed box (a meniscus's rim in small): a flat patch 0.9 mm below its
    # top, then moved 0.2 mm down, is 1.1 mm below the top and 0.9 mm above the bottom;
    # the depth is the distance to the nearest face, 0.9 mm, as a fresh pair finds it
    # (a walk from the last call's closest face, the top, stops there: 1.1 mm).
    master = box((-20.0, -20.0, -1.0), (20.0, 20.0, 1.0))
    patch = plane_patch((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), radius=2.0, size=0.5,
                        cache=False)
    eye, world = np.eye(3), (np.eye(3), np.zeros(3))

    def pair():
        return ContactPair(patch, master, method="bvh", mesh_sign="winding")

    warm = pair()
    assert warm.evaluate((eye, np.array([0.0, 0.0, 0.1])), world).max_depth == (
        pytest.approx(0.9, abs=1e-9))
    moved = (eye, np.array([0.0, 0.0, -0.1]))
    assert warm.evaluate(moved, world).max_depth == pytest.approx(0.9, abs=1e-9)
    assert pair().evaluate(moved, world).max_depth == pytest.approx(0.9, abs=1e-9)
