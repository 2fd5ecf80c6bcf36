"""The FE of the knee with menisci (`fecheck.fe.knee.knee_menisci`) on coarse meshes: balance and
penetration summed here from the pairs' forces and gaps, the knee without menisci against
the layers pressed by `fecheck.fe.solve.press` (the joint contact solver, another code path), the
horn springs' stiffness against the ligaments file, and the refusals before any work."""

from __future__ import annotations

import json

import numpy as np
import pytest
from menisci_helpers import assert_balanced

from fecheck.errors import FecheckError
from fecheck.fe.bodies.meniscus_solid import DONAHUE_HORN_N_PER_MM, meniscus_solid
from fecheck.fe.bodies.pose import FramePose
from fecheck.fe.knee import knee_menisci, meniscus_body
from fecheck.scene import load_scene, with_values
from fecheck.scene.packaged import data_dir

COARSE = ["fe.cartilage=series", "fe.prepare=on", "fe.size_mm=2.0"]
"""The one-layer series model on tibial sheets remeshed at 2 mm (11k dofs per layer
instead of 100k); tests/fe/test_knee_menisci_two_layer.py takes two deformable layers."""
MENISCUS_MM = 2.5


@pytest.fixture(scope="module")
def coarse():
    """(scene, EF run, tibial layers) of the packaged knee with menisci, coarse."""
    from fecheck.fe.bodies.scene_bodies import scene_bodies
    from fecheck.fe.bodies.settings import FESettings
    from fecheck.fe.solve.press import build_layers
    from fecheck.model.menisci import run_menisci

    scene = load_scene("femur_tibia_menisci", COARSE)
    plain = with_values(scene, menisci__dir="")
    layers = build_layers(scene_bodies(plain), scene["contact.youngs_MPa"],
                          scene["contact.poisson"], FESettings.from_scene(plain), lambda m: None)
    return scene, run_menisci(scene), layers


@pytest.fixture(scope="module")
def intact(coarse):
    scene, ef, layers = coarse
    return knee_menisci.knee_menisci_fe(scene, meniscus_size_mm=MENISCUS_MM, ef=ef,
                                        layers=layers)


def _on(record, direction: np.ndarray) -> float:
    return float(record.force_N @ (record.normals @ direction))


def test_femur_and_menisci_balance_and_nothing_penetrates(intact):
    # Forces, moments, complementarity and penetration (`menisci_helpers.assert_balanced`)
    # of the series model; the load is the scene's less the tibia's weight.
    r = intact
    assert r.load_N == pytest.approx(800.0 - 2.65207 * 9.81, rel=1e-3)
    assert_balanced(r)
    # the femur turns free in the tibia's abduction; the turn from the EF pose is small
    # (the EF balanced the same moment with its rigid-layer contact): measured -0.075 deg
    # at these meshes
    assert r.moment_balance_Nmm.shape == (1,)
    assert 1e-3 < abs(r.turn_deg[0]) < 0.5


def test_the_turn_is_balanced_against_the_scenes_own_moment(coarse):
    # The moment femur_turns asks of the femur is the load's and the weight's moment on
    # the tibia about its origin along its abduction axis, reversed, summed here by hand:
    # 800 N up at the ankle point and the weight down at the centre of mass.
    from fecheck.statics.frames import rot_x
    from fecheck.statics.newton import body_pose

    scene, ef, _ = coarse
    q = np.asarray(ef.menisci["poses"]["tibia"]["q"])
    rot, t = body_pose(q)
    axis = rot_x(q[3])[:, 1]
    weight = 2.65207 * 9.81
    moment = (np.cross(np.array([-1.757, -4.2, -381.0]) - t, [0.0, 0.0, 800.0])
              + np.cross(rot @ [-1.757, 5.85, -150.861], [0.0, 0.0, -weight]))
    axes, moments = knee_menisci.femur_turns(scene, q)
    np.testing.assert_allclose(axes, [rot.T @ axis], atol=1e-15)
    assert moments[0] == pytest.approx(-axis @ moment, rel=1e-6)


def test_compartment_loads_are_the_pairs_forces(intact):
    # Per compartment the cartilage and meniscus loads are the pairs' forces along the
    # tibial axis (meniscus: its tibial contact plus what its horn springs hand the tibia:
    # as much as they hold the meniscus up by), and the share is the meniscus's part.
    r = intact
    z = np.array([0.0, 0.0, 1.0])
    for side, fe in r.fe.items():
        assert fe.cartilage_N == pytest.approx(_on(r.pairs[f"{side} femur-tibia"], z),
                                               rel=1e-12)
        through = _on(r.pairs[f"{side} meniscus-tibia"], z) + r.spring_force_N[side][2]
        assert fe.meniscus_N == pytest.approx(through, rel=1e-12)
        assert fe.share == pytest.approx(through / (through + fe.cartilage_N), rel=1e-12)
        assert fe.area_mm2 > 0 and fe.p_max_MPa > 0


def test_without_menisci_it_is_the_pressed_layers(coarse):
    # With both menisci removed (menisci.sides = []) and the femur's rotation held, the FE
    # is the tibial layers pressed by the rigid femur along the tibial z axis under the
    # same load: `fecheck.fe.solve.press`'s joint solver (re-linearised in the pose, its own
    # condensation) on the same layers gives the same force at every vertex.
    from fecheck.fe.bodies.pose import FramePose
    from fecheck.fe.bodies.settings import FESettings
    from fecheck.fe.solve.press import push_drive, solve_pressed
    from fecheck.model.menisci import run_menisci
    from fecheck.statics.newton import body_pose

    scene, _, layers = coarse
    bare = load_scene("femur_tibia_menisci", [*COARSE, "menisci.sides=[]"])
    ef = run_menisci(bare)
    r = knee_menisci.knee_menisci_fe(bare, ef=ef, layers=layers, hold_rotation=True)
    assert set(r.pairs) == {"medial femur-tibia", "lateral femur-tibia"}
    X_WT = FramePose(*body_pose(np.asarray(ef.menisci["poses"]["tibia"]["q"])))
    sol, _, _, worst = solve_pressed(layers, push_drive(X_WT, np.array([0.0, 0.0, -r.load_N])),
                                     0.5, FESettings.from_scene(bare), lambda m: None)
    assert worst <= 1e-6
    for lay, ref in zip(layers, sol.layers, strict=True):
        mine = np.zeros(lay.surface.n_points)
        p = r.pairs[f"{lay.body.name} femur-tibia"]
        mine[p.nodes] = p.force_N
        assert np.abs(mine - ref.force_N).max() <= 1e-7 * ref.force_N.max()
    for c in ("medial", "lateral"):
        assert r.fe[c].meniscus_N == 0.0 and r.fe[c].share == 0.0


def test_without_menisci_the_turning_femur_is_the_joint_solve(coarse):
    # Free in abduction, the femur takes the pose `fecheck.fe.solve.press`'s joint solver finds
    # for the tibia free in z and abduction under the scene's load and weight (Newton on
    # the pose, the load re-evaluated there): the same force at every vertex to 1e-4 of
    # the peak (measured 3.4e-5: the joint solver moves the tibia's weight with its
    # 0.006 deg turn, about 0.4 N mm of the 8e3 N mm each condyle's force turns about;
    # the held femur is off by 4.8e-3) and the femur's turn is the tibia's, reversed.
    from fecheck.fe.bodies.settings import FESettings
    from fecheck.fe.solve.press import joint_drive, solve_pressed
    from fecheck.model.menisci import run_menisci
    from fecheck.statics.newton import TIBIA_COORDINATES

    _, _, layers = coarse
    bare = load_scene("femur_tibia_menisci", [*COARSE, "menisci.sides=[]"])
    ef = run_menisci(bare)
    q = np.asarray(ef.menisci["poses"]["tibia"]["q"])
    r = knee_menisci.knee_menisci_fe(bare, ef=ef, layers=layers)
    drive = joint_drive(bare, q[list(TIBIA_COORDINATES)], [])
    sol, _, _, worst = solve_pressed(layers, drive, 0.5, FESettings.from_scene(bare),
                                     lambda m: None)
    assert worst <= 1e-6
    for lay, ref in zip(layers, sol.layers, strict=True):
        mine = np.zeros(lay.surface.n_points)
        p = r.pairs[f"{lay.body.name} femur-tibia"]
        mine[p.nodes] = p.force_N
        assert np.abs(mine - ref.force_N).max() <= 1e-4 * ref.force_N.max()
    turned = np.degrees(drive.full(sol.q)[3] - q[4])
    assert r.turn_deg[0] == pytest.approx(-turned, rel=0.02)


def test_horn_springs_hold_a_rigid_shift_with_the_roots_stiffness():
    # A rigid unit translation of the meniscus strains nothing: its energy is the horn
    # springs' alone, uᵀ K u = Σ over horns of k_horn, with k_horn the sum of the horn's
    # root bundles' k / l0 read here from meniscal_ligaments.json (or Donahue's 2000 N/mm).
    folder = data_dir("fecheck:knee/smith2019_menisci", "menisci.dir")
    items = json.loads((folder / "meniscal_ligaments.json").read_text())["ligaments"]
    expected = {}
    for horn, group in (("anterior", "AHORN"), ("posterior", "PHORN")):
        expected[horn] = sum(it["parameters"]["linear_stiffness"]["value"]
                             / (1000.0 * it["parameters"]["slack_length"]["value"])
                             for it in items if it["meniscus"] == "medial" and it["group"] == group)
    solid = meniscus_solid("fecheck:knee/smith2019_menisci", "medial", MENISCUS_MM)
    horns = meniscus_body.horn_stiffness(solid, "data")
    assert horns == pytest.approx(expected, rel=1e-12)
    assert meniscus_body.horn_stiffness(solid, "donahue") == {
        "anterior": DONAHUE_HORN_N_PER_MM, "posterior": DONAHUE_HORN_N_PER_MM}
    basis, K = meniscus_body.meniscus_stiffness(solid, solid.mesh.points, solid.fibre, horns)
    for d in np.eye(3):
        u = np.zeros(basis.N)
        for c in range(3):
            u[basis.nodal_dofs[c]] = u[basis.edge_dofs[c]] = d[c]
        assert u @ K @ u == pytest.approx(sum(expected.values()), rel=1e-8)
    with pytest.raises(FecheckError, match="horn root stiffness 'ligaments'"):
        meniscus_body.horn_stiffness(solid, "ligaments")


def test_refused_before_any_work(monkeypatch):
    # A scene without menisci, or with two cartilage layers on remeshed sheets (the
    # femoral layer is extruded from the sheet as read), is refused on one line before
    # the EF run.
    import fecheck.model.menisci as model

    def never(*args, **kwargs):
        raise AssertionError("the EF ran before the refusal")

    monkeypatch.setattr(model, "run_menisci", never)
    with pytest.raises(FecheckError, match="needs a scene with menisci.dir"):
        knee_menisci.knee_menisci_fe(load_scene("femur_tibia"))
    with pytest.raises(FecheckError, match="meshes the sheets as read"):
        knee_menisci.knee_menisci_fe(load_scene("femur_tibia_menisci",
                                                ["fe.cartilage=two-layer", "fe.prepare=on"]))


def test_element_stress_of_uniaxial_fibre_stress_and_shear_is_the_closed_form():
    # On P2 tetrahedra of a box with every fibre along one oblique unit d: the field
    # u = ε0 [(d·x) d − ν_tp (x − (d·x) d)] is uniaxial stress along the fibres,
    # σ = E_t ε0 d⊗d; the simple shear u = γ (d·x) e (e ⟂ d) is σ = G_t γ (d⊗e + e⊗d).
    from skfem import Basis, ElementTetP2, ElementVector, MeshTet

    from fecheck.fe.material.anisotropy import MENISCUS as M

    mesh = MeshTet.init_tensor(*(np.linspace(0.0, 2.0, 4),) * 3)
    basis = Basis(mesh, ElementVector(ElementTetP2()), intorder=2)
    d = np.array([1.0, 2.0, 2.0]) / 3.0
    e = np.array([2.0, -1.0, 0.0]) / np.sqrt(5.0)
    fibre = np.tile(d, (mesh.t.shape[1], 1))
    mid = mesh.p[:, mesh.edges].mean(axis=1)

    def nodal(f):
        u = np.zeros(basis.N)
        for c in range(3):
            u[basis.nodal_dofs[c]] = f(mesh.p.T)[:, c]
            u[basis.edge_dofs[c]] = f(mid.T)[:, c]
        return u

    eps0, gamma = 0.01, 0.02

    def uniaxial(x):
        a = (x @ d)[:, None] * d
        return eps0 * (a - M.nu_tp * (x - a))

    sigma = meniscus_body.element_stress(basis, nodal(uniaxial), fibre)
    assert np.abs(sigma - M.E_t * eps0 * np.outer(d, d)).max() <= 1e-9 * M.E_t * eps0
    sigma = meniscus_body.element_stress(basis, nodal(lambda x: gamma * (x @ d)[:, None] * e),
                                        fibre)
    expected = M.G_t * gamma * (np.outer(d, e) + np.outer(e, d))
    assert np.abs(sigma - expected).max() <= 1e-9 * M.G_t * gamma


def test_outline_is_the_edges_of_one_face():
    # Two triangles on a unit square: its four sides, not the shared diagonal.
    points = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    segments = knee_menisci.outline(points, np.array([[0, 1, 2], [0, 2, 3]]))
    lengths = np.linalg.norm(segments[:, 1] - segments[:, 0], axis=1)
    assert np.sort(lengths) == pytest.approx([1.0, 1.0, 1.0, 1.0], abs=1e-15)


def test_coronary_springs_add_their_k_over_l0_to_a_rigid_shift():
    # With the coronary ligaments a rigid unit shift stores Σ k_horn + Σ k/l0 of the
    # meniscus's COR bundles, read here from meniscal_ligaments.json.
    folder = data_dir("fecheck:knee/smith2019_menisci", "menisci.dir")
    items = json.loads((folder / "meniscal_ligaments.json").read_text())["ligaments"]
    cor = sum(it["parameters"]["linear_stiffness"]["value"]
              / (1000.0 * it["parameters"]["slack_length"]["value"])
              for it in items if it["meniscus"] == "lateral" and it["group"] == "COR")
    solid = meniscus_solid("fecheck:knee/smith2019_menisci", "lateral", MENISCUS_MM)
    horns = meniscus_body.horn_stiffness(solid, "data")
    extra = meniscus_body.coronary_springs(solid, folder)
    assert len(extra[0]) == 3
    basis, K = meniscus_body.meniscus_stiffness(solid, solid.mesh.points, solid.fibre, horns,
                                               extra=extra)
    u = np.zeros(basis.N)
    u[basis.nodal_dofs[1]] = u[basis.edge_dofs[1]] = 1.0
    assert u @ K @ u == pytest.approx(sum(horns.values()) + cor, rel=1e-8)


def test_report_pressure_compression_and_near_areas(coarse, intact):
    # The tibial pressure map times the tributary areas is the femur's and the meniscus's
    # contact forces on the layer; the deepest compression under the femur is the deepest
    # rigid overlap of the femur with the undeformed layer at its final place and turn
    # (the gap closes there); the superior area near the femur grows with the distance and holds
    # the pressed area.
    from fecheck.statics.newton import body_pose

    scene, ef, layers = coarse
    r = intact
    q = np.asarray(ef.menisci["poses"]["tibia"]["q"])
    X_WT = FramePose(*body_pose(q), "W", "T")
    turn = np.radians(r.turn_deg) @ knee_menisci.femur_turns(scene, q)[0]
    for lay in layers:
        c = lay.body.name
        force = np.zeros(lay.surface.n_points)
        for kind in ("femur-tibia", "meniscus-tibia"):
            p = r.pairs[f"{c} {kind}"]
            np.add.at(force, p.nodes, p.force_N)
        assert r.pressure_MPa[c] * lay.solid.tributary_mm2 == pytest.approx(force, abs=1e-12)
        ft = r.pairs[f"{c} femur-tibia"]
        pressed = ft.nodes[ft.force_N > 0]
        rigid = knee_menisci._femur_gap(lay.indenter, lay.surface.points[pressed],
                                        lay.solid.normals[pressed], X_WT, r.approach_mm,
                                        turn)
        assert r.fe[c].compression_mm == pytest.approx(-rigid.min(), abs=1e-9)
        m = r.menisci[c]
        near = [m.near_mm2[d] for d in knee_menisci.NEAR_MM]
        assert 0 < m.contact_mm2 <= near[0] <= near[1] <= near[2]


def test_raising_the_superior_surface_raises_the_share(coarse, intact):
    # The wedge 0.25 mm thicker (the femur-meniscus gaps 0.25 mm less) makes the femur
    # meet the meniscus sooner: more of the load through each meniscus, balance and
    # penetration still exact.
    scene, ef, layers = coarse
    lifted = knee_menisci.knee_menisci_fe(scene, meniscus_size_mm=MENISCUS_MM, ef=ef,
                                          layers=layers, lift_mm=0.25)
    for c in ("medial", "lateral"):
        assert lifted.fe[c].share > intact.fe[c].share + 0.02
        assert lifted.menisci[c].contact_mm2 > intact.menisci[c].contact_mm2
        up = lifted.pairs[f"{c} femur-meniscus"]
        assert up.gap_mm.min() >= -1e-6
    assert abs(lifted.balance_N) <= 1e-8 * lifted.load_N
    assert lifted.max_penetration_mm <= 1e-6


@pytest.mark.parametrize("opening", ["opening +x", "opening -x"])
def test_report_of_a_turned_torus_in_uniform_horizontal_strain(opening):
    # A torus segment (centreline radius 15 mm, 16-gon section of circumradius 2.5 mm)
    # turned 30 deg about z and moved, as a placed meniscus, under u = ε (x − c)_horizontal
    # about its turned axis c: the strain ε (I − e_z e_z) is the same in every element's
    # fibre frame, so the hoop stress is uniform, σ_θθ = (S⁻¹ (ε, 0, ε))_θ with the
    # compliance S in (r, z, θ) written from E_p, E_t, ν_p, ν_tp; the hoop force through
    # each section is σ_θθ times the 16-gon's area, within 1 % (the sections' tilt and
    # the fitted fibres' spread, as in tests/fe/test_meniscus_solid.py); each element moves
    # out by ε times its centroid's distance from the axis (to 1e-3), whichever way the
    # arc runs (the opening facing +x or -x).
    from types import SimpleNamespace

    import scipy.sparse as sp
    from skfem import Basis, ElementTetP2, ElementVector, MeshTet
    from test_meniscus_solid import CENTRE, POLYGON_AREA, torus_solid

    from fecheck.fe.material.anisotropy import MENISCUS as M

    solid = torus_solid(opening)
    a = np.radians(30.0)
    Q = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    shift = np.array([3.0, -2.0, 0.5])
    points = solid.mesh.points @ Q.T + shift
    centre = Q @ CENTRE + shift
    mesh = MeshTet(np.ascontiguousarray(points.T), np.ascontiguousarray(solid.mesh.tets.T))
    basis = Basis(mesh, ElementVector(ElementTetP2()), intorder=2)
    eps = 1e-3
    mid = mesh.p[:, mesh.edges].mean(axis=1).T
    u = np.zeros(basis.N)
    for c in range(2):
        u[basis.nodal_dofs[c]] = eps * (points[:, c] - centre[c])
        u[basis.edge_dofs[c]] = eps * (mid[:, c] - centre[c])
    m = SimpleNamespace(solid=solid, points=points, basis=basis, tie=sp.identity(basis.N),
                        rotation=Q, superior=np.zeros(0, dtype=int), material=M,
                        horn_N_per_mm={})
    report = knee_menisci.meniscus_report(m, u, np.zeros(0), None)
    S = np.array([[1 / M.E_p, -M.nu_p / M.E_p, -M.nu_tp / M.E_t],
                  [-M.nu_p / M.E_p, 1 / M.E_p, -M.nu_tp / M.E_t],
                  [-M.nu_tp / M.E_t, -M.nu_tp / M.E_t, 1 / M.E_t]])
    hoop = np.linalg.solve(S, [eps, 0.0, eps])[2]
    assert report.hoop.force_N == pytest.approx(hoop * POLYGON_AREA * np.ones(5), rel=0.01)
    centroids = points[solid.mesh.tets].mean(axis=1)
    body = (solid.arc >= 0.25) & (solid.arc <= 0.75)
    vol = np.abs(solid.mesh.tet_volumes)[body]
    rho = np.linalg.norm((centroids - centre)[body, :2], axis=1)
    assert report.radial_mm == pytest.approx(eps * (vol @ rho) / vol.sum(), rel=1e-3)
    assert report.contact_mm2 == 0.0


def test_region_loads_sum_to_the_compartment_load(coarse, intact):
    # Per compartment the tibial contact regions split the pairs' forces: the
    # cartilage-cartilage region is the femur-tibia pair's axial force, the three meniscus
    # regions (anterior horn, body, posterior horn) sum to the meniscus-tibia pair's, and
    # with the horn springs they make the compartment's load (statics, summed here from the
    # pair records); the compartment's p_max is its regions' largest. Each region's load is
    # that of the tibial vertices it labels, and under the meniscus the anterior horn's
    # vertices lie anterior (+y) of the body's, the body's anterior of the posterior horn's.
    r = intact
    z = np.array([0.0, 0.0, 1.0])
    layers = {lay.body.name: lay for lay in coarse[2]}
    for side, fe in r.fe.items():
        regions = fe.regions
        label = r.tibial_region[side]
        axial = np.zeros(len(label))
        for kind in ("femur-tibia", "meniscus-tibia"):
            p = r.pairs[f"{side} {kind}"]
            np.add.at(axial, p.nodes, p.force_N * p.normals[:, 2])
        y = layers[side].surface.points[:, 1]
        centre = {}
        for k, name in knee_menisci.REGION_NAMES.items():
            assert regions[name].load_N == pytest.approx(axial[label == k].sum(), rel=1e-12,
                                                         abs=1e-12)
            centre[k] = y[label == k].mean()
        assert centre[1] > centre[2] > centre[3]
        assert list(regions) == list(knee_menisci.REGION_NAMES.values())
        assert regions["cartilage"].load_N == pytest.approx(
            _on(r.pairs[f"{side} femur-tibia"], z), rel=1e-12)
        under = sum(regions[k].load_N for k in ("anterior horn", "body", "posterior horn"))
        assert under == pytest.approx(_on(r.pairs[f"{side} meniscus-tibia"], z), rel=1e-9)
        total = sum(g.load_N for g in regions.values()) + fe.springs_N
        assert total == pytest.approx(fe.meniscus_N + fe.cartilage_N, rel=1e-12)
        assert max(g.p_max_MPa for g in regions.values()) == fe.p_max_MPa
        # the fitted menisci take a good part of the contact area (the cartilage region's
        # was over half of it with the shipped menisci, under half now: 119 of 324 mm²)
        assert 0.0 < regions["cartilage"].area_mm2 < fe.area_mm2
        assert all(0.0 <= g.area_mm2 <= fe.area_mm2 for g in regions.values())


def test_cli_fe_runs_a_menisci_scene_and_writes_its_json(intact, monkeypatch, tmp_path,
                                                         capsys):
    # `fecheck fe` on a scene with menisci runs the FE with menisci (here its answer is the
    # coarse run's, the solver replaced), the meniscus tetrahedra 1.25 x fe.size_mm, asks
    # for the knee without menisci beside it, prints the compartment and region tables and
    # writes a JSON of finite numbers that are the run's; a flag it does not take is
    # refused in one line before any work.
    from dataclasses import replace

    from fecheck.cli import main

    sizes = []

    def solved(scene, *, meniscus_size_mm, log=None, without=False, **kwargs):
        sizes.append(meniscus_size_mm)
        assert without
        bare = {c: replace(fe, share=0.0, p_max_MPa=2 * fe.p_max_MPa)
                for c, fe in intact.fe.items()}
        return replace(intact, without_menisci=bare)

    monkeypatch.setattr(knee_menisci, "knee_menisci_fe", solved)
    path = tmp_path / "fe.json"
    assert main(["fe", "femur_tibia_menisci", "--set", "fe.size_mm=2.0",
                 "--json", str(path), "--plot", str(tmp_path / "plot"),
                 "--vtk", str(tmp_path / "vtk")]) == 0
    assert sizes == [2.5]
    out = capsys.readouterr().out
    assert "Donahue 2002" in out and "posterior horn" in out and "balance:" in out
    assert out.count("FE no menisci") == 2
    assert out.count("meniscus load path: femur -> meniscus") == 2
    assert out.count("meniscus hoop force N at arc") == 2
    # --plot draws the pressure map; --vtk writes the tibial layers' and the menisci's
    # superior surfaces with the run's pressures (the femur's on a meniscus: its contact
    # forces over the vertex tributary areas, so they sum back to the pair's force)
    import meshio

    assert (tmp_path / "plot" / "menisci_pressure.png").stat().st_size > 10000
    for side in intact.fe:
        tib = meshio.read(tmp_path / "vtk" / f"tibia_{side}.vtu")
        assert np.array_equal(tib.point_data["pressure_MPa"], intact.pressure_MPa[side])
        men = meshio.read(tmp_path / "vtk" / f"meniscus_{side}_superior.vtu")
        tri = men.points[men.cells_dict["triangle"]]
        area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]),
                                    axis=1)
        tributary = np.bincount(men.cells_dict["triangle"].ravel(), np.repeat(area / 3, 3),
                                minlength=len(men.points))
        pressed = intact.pairs[f"{side} femur-meniscus"].force_N.sum()
        assert men.point_data["pressure_MPa"] @ tributary == pytest.approx(pressed, rel=1e-9)

    def no_nan(text):
        raise AssertionError(f"{text} in the JSON")

    data = json.loads(path.read_text(encoding="utf-8"), parse_constant=no_nan)
    assert data["load_N"] == intact.load_N
    for side, fe in intact.fe.items():
        got = data["compartments"][side]
        assert got["fe"]["share"] == fe.share
        assert got["fe"]["regions"]["body"]["load_N"] == fe.regions["body"].load_N
        assert got["fe_without_menisci"]["p_max_MPa"] == 2 * fe.p_max_MPa
        assert got["published_share"] in (0.5, 0.7)
        assert got["donahue_2002"]["area_mm2"] > 0
    assert data["max_penetration_mm"] == intact.max_penetration_mm
    assert main(["fe", "femur_tibia_menisci", "--mode", "compartment"]) == 2
    assert sizes == [2.5]
    err = capsys.readouterr().err.strip()
    assert "--mode compartment" in err and "\n" not in err


def test_a_ray_grazing_the_meniscus_rim_still_places_it():
    # One inferior triangle (x, y >= 0, x + y <= 1) over two tibial vertices: one straight
    # under it, one 0.02 mm higher with its normal tilted 45 deg toward the rim. With the
    # first touching, the tilted ray meets the triangle at x + y = 0.985 overlapping by
    # 0.02·√2 mm; raised that much the ray meets x + y = 1.013, off the rim: the placement
    # flips between the two. It rests at the raised one, where nothing overlaps and the
    # least gap is the straight vertex's 0.02·√2 mm (by hand), 1 - 0.02·√2 mm lower.
    from types import SimpleNamespace

    tri = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]])
    solid = SimpleNamespace(side="medial", mesh=SimpleNamespace(points=tri),
                            fibre=np.array([[1.0, 0.0, 0.0]]),
                            faces=lambda label: np.array([[0, 1, 2]]))
    layer = np.array([[0.2, 0.2, 0.0], [0.955, 0.05, 0.02]])
    normals = np.array([[0.0, 0.0, 1.0], [np.sqrt(0.5), 0.0, np.sqrt(0.5)]])
    points, _, rise = meniscus_body.place_meniscus(solid, np.zeros(6), np.zeros(6), layer,
                                                  normals)
    overlap = 0.02 * np.sqrt(2.0)
    assert points[0, 2] == pytest.approx(overlap, abs=1e-12)
    assert rise == pytest.approx(overlap - 1.0, abs=1e-12)
    face, _, gap = meniscus_body.inferior_rays(points, np.array([[0, 1, 2]]), layer, normals)
    assert face[1] < 0 and gap[0] == pytest.approx(overlap, abs=1e-12)
