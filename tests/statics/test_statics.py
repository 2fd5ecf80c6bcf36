"""Newton statics: exact tangents, the baseline acceptance, convergence of every scene."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from fecheck import laws
from fecheck.errors import FecheckError
from fecheck.model.assembly import ContactModel, applied_load, plateau_normals
from fecheck.model.notes import MIN_CONTACT_FACES
from fecheck.model.run import run_scene
from fecheck.model.sphere_plane import build_compartments
from fecheck.reference.closed_forms import ef_sphere_plane
from fecheck.scene import load_scene
from fecheck.statics.ligaments import rod_constraint, spring_wrench
from fecheck.statics.newton import (
    Problem,
    _System,
    constraint_on_body,
    geometric_tangent,
    on_body,
    point_force,
    pose,
    solve,
    tibia_body,
    twist_basis,
)
from fecheck.statics.rigid import solve_rigid

SCENES = Path(__file__).resolve().parents[2] / "validation" / "scenes"
SHIPPED = ["baseline", "rigid", "rigid_ligaments", "hertz", "volumetric", "ligaments",
           "springs", "equal_force", "additional_left"]
RIGID_SPLIT = {"medial": 323.71, "lateral": 456.67}      # thesis Table 5.1
LOAD_N = 800.0


def _generalised(q, wrench_fn):
    rot, t = pose(q)
    return twist_basis(q).T @ wrench_fn(rot, t)[0]


def _fd_jacobian(fun, q, h=1e-6):
    cols = []
    for j in range(len(q)):
        e = np.zeros(len(q))
        e[j] = h
        cols.append((fun(q + e) - fun(q - e)) / (2 * h))
    return np.column_stack(cols)


def _analytic(q, wrench_fn):
    rot, t = pose(q)
    w, dw = wrench_fn(rot, t)
    b = twist_basis(q)
    return b.T @ dw @ b + geometric_tangent(q, w)


def test_generalised_tangent_of_point_loads_and_springs_matches_fd():
    # a constant force on a tibia point, plus a stretched Blankevoort spring, at a
    # rotated, translated pose: checks B(q), ∂B/∂q and the point-force tangent
    x_body = np.array([7.9, 12.8, -380.0])
    spring = spring_wrench(np.array([-38.0, 13.8, 11.2]), np.array([-3.0, -1.0, -64.6]),
                           84.8, 8000.0, 0.08, 0.06)

    def wrench(rot, t):
        w1, d1 = point_force(rot @ x_body + t, np.array([30.0, -20.0, 800.0]))
        w2, d2 = spring(rot, t)
        return w1 + w2, d1 + d2

    q = np.array([1.0, -2.0, 0.5, 0.2, -0.3])
    fd = _fd_jacobian(lambda qq: _generalised(qq, wrench), q)
    assert np.abs(fd - _analytic(q, wrench)).max() <= 1e-6 * np.abs(fd).max()


def test_rod_constraint_gradient_is_minus_its_unit_wrench():
    con = rod_constraint(np.array([17.0, 31.4, 20.4]), np.zeros(3), 41.12)
    q = np.array([0.5, 0.2, -0.4, 0.1, 0.05])

    def g(qq):
        return np.array([con(*pose(qq))[0]])

    rot, t = pose(q)
    _, w, _ = con(rot, t)
    fd = _fd_jacobian(g, q)[0]
    assert np.allclose(fd, -(twist_basis(q).T @ w), rtol=0, atol=1e-8)


LIGAMENTS = ("ACL", "PCL", "MCL")


def _rods(names=LIGAMENTS):
    knee = load_scene().knee
    return [rod_constraint(knee.femur_attachment[n], knee.tibia_attachment[n],
                           knee.ligament_length_mm(n)) for n in names]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rod_tangent_matches_fd_at_random_poses(seed):
    # The generalised tangent of each rod's unit wrench (dw/dξ through B, plus B's own
    # dependence on q) against central differences of B(q)ᵀ·w at a random pose within
    # ±3 mm and ±10°. With h = 1e-5 the truncation error is ~h²/L² ≈ 1e-13 (L ≈ 30 mm,
    # the rod length) and the rounding ~1e-16·|w|/h ≈ 1e-9 of a tangent of order 1:
    # 1e-6 of the largest entry (measured <= 6e-10) no missing or flipped term stays under.
    rng = np.random.default_rng(seed)
    q = np.concatenate([rng.uniform(-3.0, 3.0, 3), np.radians(rng.uniform(-10.0, 10.0, 2))])
    for con in _rods():
        def unit(rot, t, con=con):
            _, w, dw = con(rot, t)
            return w, dw

        fd = _fd_jacobian(lambda qq, unit=unit: _generalised(qq, unit), q, h=1e-5)
        assert np.abs(fd - _analytic(q, unit)).max() <= 1e-6 * np.abs(fd).max()


def test_newton_jacobian_with_rod_multipliers_matches_fd():
    # The augmented system (equilibrium rows with λ·w_rod, constraint rows g) of two
    # rods in tension and a tilted point load, against central differences in the
    # scaled pose and the multipliers, at an off-equilibrium rotated pose.
    x_body = np.array([7.9, 12.8, -30.0])

    def wrench(rot, t):
        return [point_force(rot @ x_body + t, np.array([30.0, -20.0, 200.0]))]

    q = np.array([0.8, -1.2, 0.5, math.radians(4.0), math.radians(-7.0)])
    rods = [constraint_on_body(c) for c in _rods(("ACL", "MCL"))]
    system = _System(Problem((tibia_body(q, (0, 1, 2, 3, 4)),), on_body(wrench), rods))
    z = np.concatenate([q * system.sq, [300.0, 150.0]])
    _, jac = system(z)
    fd = _fd_jacobian(lambda zz: system(zz)[0], z, h=1e-5)
    assert np.abs(fd - jac).max() <= 1e-6 * np.abs(fd).max()


@pytest.mark.parametrize("master, law", [("condyle", "ef"), ("plateau", "ef"),
                                         ("condyle", "hertz"), ("plateau", "blankevoort")])
def test_assembled_jacobian_through_contact_pairs_matches_fd(master, law):
    # issue 8: the full tangent (contact laws + pair evaluation + load + gravity) of the
    # Newton system against central differences, at an off-equilibrium pose in contact
    scene = load_scene(overrides=[f"contact.master='{master}'", f"contact.law='{law}'",
                                  "mesh.sphere_subdivisions=4",
                                  "dofs.free=['x', 'y', 'z', 'abduction', 'internal']"])
    contact = ContactModel(build_compartments(scene))
    load = applied_load(scene)

    def wrench(rot, t):
        return contact(rot, t) + [load(rot, t)]

    q = np.array([0.2, -0.3, 1.1, math.radians(0.3), math.radians(0.5)])
    system = _System(Problem((tibia_body(q, (0, 1, 2, 3, 4)),), on_body(wrench)))
    z = q * system.sq
    _, jac = system(z)
    fd = _fd_jacobian(lambda zz: system(zz)[0], z, h=1e-6)
    assert np.abs(fd - jac).max() <= 1e-5 * np.abs(fd).max()


@pytest.fixture(scope="module")
def baseline():
    return run_scene(load_scene(SCENES / "baseline.toml"))


def test_baseline_converges_quickly_to_the_load_tolerance(baseline):
    assert baseline.converged
    assert baseline.iterations <= 15
    assert baseline.residual_norm < 1e-8 * LOAD_N


def test_baseline_matches_the_exact_ef_values_of_design_5(baseline):
    # Exact EF at the rigid split: medial d 0.955, A 150.1, p_max 4.28; lateral d 1.015,
    # A 199.5, p_max 4.55 (2-3 printed digits); here against the closed form evaluated at
    # the solved forces, to 1 % as required, and to the printed values to their digits.
    knee = load_scene().knee
    printed = {"medial": (0.955, 150.1, 4.28), "lateral": (1.015, 199.5, 4.55)}
    for c, res in baseline.compartments.items():
        ref = ef_sphere_plane(res.force_N, knee.radius_mm(c), 4.487179487179487)
        assert res.max_depth_mm == pytest.approx(ref["max_depth_mm"], rel=0.01)
        assert res.area_mm2 == pytest.approx(ref["area_mm2"], rel=0.01)
        assert res.max_pressure_MPa == pytest.approx(ref["max_pressure_MPa"], rel=0.01)
        # the printed values hold at the rigid split, 0.5 N away: 0.5 % covers both
        d, a, p = printed[c]
        assert res.max_depth_mm == pytest.approx(d, rel=0.005)
        assert res.area_mm2 == pytest.approx(a, rel=0.005)
        assert res.max_pressure_MPa == pytest.approx(p, rel=0.005)
        assert max(abs(v) for v in baseline.exact[c]["deviation_percent"].values()) < 1.0


def test_baseline_forces_equal_rigid_statics_at_the_solved_pose(baseline):
    # The EF resultant on a plane acts along its normal through the sphere centre, the
    # line of the rigid model's reaction: the rigid statics at the EF pose must give the
    # same split (to the Newton tolerance); vs the reference-pose rigid split (Table 5.1)
    # the 0.07° tilt of the solved tibia moves 0.49 N (contact points shift r·θ ≈ 0.03 mm).
    scene = load_scene(SCENES / "baseline.toml")
    q = np.array(baseline.pose.q)
    rot, t = pose(q)
    applied, _ = applied_load(scene)(rot, t)
    sol = solve_rigid(scene.knee, plateau_normals(scene), applied, q, (2, 3))
    for c, res in baseline.compartments.items():
        assert res.force_N == pytest.approx(sol.contact_force_N[c], abs=0.01)
        assert res.force_N == pytest.approx(RIGID_SPLIT[c], abs=0.5)


def test_load_at_3_95_mm_equalises_the_ef_compartment_forces_within_one_percent():
    # 3.95 mm is the midpoint of the contact points (Fig. 5.2's "4 mm"). Each compartment
    # carries its equal share (half the contact load) within 1 %: measured 387.7 / 392.7 N,
    # 0.63 % either side of 390.2 N. Their difference (1.26 % of the share) has two
    # physical parts: the tibia's weight at x = 0 (rigid split 388.6 / 391.8 N, 0.8 %)
    # and the EF tibia's 0.12° tilt, which moves the contact points by r·θ on condyles of
    # different radii (25.5 vs 31.8 mm): 0.45 %.
    r = run_scene(load_scene(SCENES / "baseline.toml", ["load.point_mm=[3.95, 12.8, -380.0]"]))
    f_m, f_l = r.compartments["medial"].force_N, r.compartments["lateral"].force_N
    share = (f_m + f_l) / 2
    assert abs(f_m - share) < 0.01 * share and abs(f_l - share) < 0.01 * share
    assert abs(f_m - f_l) < 0.015 * share


def test_whole_face_counting_shows_the_thesis_bias():
    # Thesis Table 5.3 (whole faces, ≈5000 faces): medial d 0.8 / lateral 0.85 mm,
    # A 168.9 / 219.2 mm² vs exact 0.955 / 1.015 mm, 150.1 / 199.5 mm². Same 5,120-face
    # icospheres in both modes: whole faces give d 0.81 / 0.84 mm (-15 / -17 %) and
    # A 154 / 219 mm² (+2.5 / +10 %), the thesis's bias.
    runs = {mode: run_scene(load_scene(SCENES / "baseline.toml", [
        "contact.master='plateau'", f"contact.area='{mode}'"])) for mode in
        ("clipped", "whole-face")}
    for c in ("medial", "lateral"):
        exact, biased = runs["clipped"].compartments[c], runs["whole-face"].compartments[c]
        assert biased.area_mm2 > 1.02 * exact.area_mm2
        assert biased.max_depth_mm < 0.88 * exact.max_depth_mm
        assert biased.max_depth_mm == pytest.approx({"medial": 0.8, "lateral": 0.85}[c],
                                                    abs=0.015)
        assert biased.force_N == pytest.approx(exact.force_N, abs=1.0)
    assert any("bias" in n for n in runs["whole-face"].notes)


@pytest.mark.parametrize("gap", [0.0, 5.0])
@pytest.mark.parametrize("name", SHIPPED)
def test_every_shipped_scene_converges_from_touching_and_from_a_gap(name, gap):
    r = run_scene(load_scene(SCENES / f"{name}.toml", [f"solver.start_gap_mm={gap}"]))
    assert r.converged
    assert r.residual_norm < 1e-8 * LOAD_N
    total = sum(c.force_N for c in r.compartments.values())
    assert total > 0.5 * LOAD_N


def test_deep_overlap_start_converges_to_the_same_equilibrium(baseline):
    r = run_scene(load_scene(SCENES / "baseline.toml", ["dofs.z_mm=4.0"]))
    assert r.converged
    assert r.pose["z_mm"] == pytest.approx(baseline.pose["z_mm"], abs=1e-8)


def test_free_dof_without_stiffness_is_reported():
    with pytest.raises(FecheckError, match=r"DOFs x have no stiffness.*dofs.free = \['z', "
                                           r"'abduction'\]"):
        run_scene(load_scene(SCENES / "baseline.toml", ["dofs.free=['x', 'z', 'abduction']"]))


def test_micro_newton_load_rocks_onto_both_plateaus_and_converges():
    # At 1e-6 N the first contact is one compartment only (rocking about it has no
    # stiffness) and the motion that balances it is ~µm: the safeguard must find it rather
    # than call z/abduction unresisted. Checked by statics alone (mesh resolution does not
    # enter): both compartments touch and their vertical forces carry the load.
    r = run_scene(load_scene(SCENES / "baseline.toml", ["load.force_N=1e-6", "gravity=false"]))
    assert r.converged
    med, lat = r.compartments["medial"].force_N, r.compartments["lateral"].force_N
    assert med > 0 and lat > 0
    # the residual tolerance is 1e-8 · max(1 N, load) = 1e-8 N here (model.force_scale)
    assert med + lat == pytest.approx(1e-6, abs=2e-8)


@pytest.mark.parametrize("law", ["ef", "blankevoort"])
def test_layer_crushed_through_is_an_error_naming_what_to_change(law):
    # E = 0.1 MPa: even half the 800 N load needs an exact EF depth beyond h = 6 mm;
    # Blankevoort's log law, continued linearly beyond 0.9 h, passes h too (8.4 mm)
    k = laws.ef_stiffness(0.1, 0.3, 6.0)
    assert ef_sphere_plane(400.0, 31.8, k)["max_depth_mm"] > 6.0
    with pytest.raises(FecheckError, match=r"crushed through.*contact.thickness_mm = 6 mm.*"
                                           r"contact.youngs_MPa.*load.force_N"):
        run_scene(load_scene(SCENES / "baseline.toml",
                             [f"contact.law='{law}'", "contact.youngs_MPa=0.1"]))


@pytest.mark.parametrize("load", ["0.1", "10000"])
def test_plateau_mesh_sized_from_the_load_matches_the_exact_ef_answer(load):
    # 0.1 N: a ~0.8 mm contact (was 13.6% off on the 0.8 mm default mesh); 10 kN: a
    # ~17 mm contact (was cut by the 14 mm disc, 11% off). 3% is ~the 800 N baseline's
    # discretisation error (0.2%) with room for the coarser grading at the rim.
    r = run_scene(load_scene(SCENES / "baseline.toml", [f"load.force_N={load}",
                                                        "gravity=false"]))
    assert r.converged
    for c, ref in r.exact.items():
        dev = ref["deviation_percent"]
        assert abs(dev["area_mm2"]) < 3.0 and abs(dev["max_pressure_MPa"]) < 3.0, c


def test_contact_cut_by_the_plateau_rim_is_an_error_naming_the_key():
    with pytest.raises(FecheckError, match=r"medial: the contact reaches the rim .*radius 14 mm"):
        # all the load medial: the tibia tilts ~20° and the contact slides ~11 mm, past the
        # default 14 mm disc (sized for the load, not the slide): was 7% off, silently
        run_scene(load_scene(SCENES / "baseline.toml", ["load.point_mm=[-30, 12.8, -380]"]))
    wider = run_scene(load_scene(SCENES / "baseline.toml", ["load.point_mm=[-30, 12.8, -380]",
                                                            "mesh.plateau_radius_mm=18"]))
    dev = wider.exact["medial"]["deviation_percent"]       # the named fix works (3% as above)
    assert abs(dev["area_mm2"]) < 3.0 and abs(dev["max_pressure_MPa"]) < 3.0
    with pytest.raises(FecheckError, match=r"rim of the meshed plateau disc \(radius 10 mm\)"
                                           r".*raise mesh.plateau_radius_mm"):
        run_scene(load_scene(SCENES / "baseline.toml", ["load.force_N=10000",
                                                        "mesh.plateau_radius_mm=10"]))


def test_contact_on_few_faces_gets_a_note():
    r = run_scene(load_scene(SCENES / "baseline.toml", ["mesh.plateau_refine_mm=12",
                                                        "mesh.plateau_size_mm=12"]))
    faces = {c: v.n_contact_faces for c, v in r.compartments.items()}
    assert all(n < MIN_CONTACT_FACES for n in faces.values())
    for c, n in faces.items():
        assert any(f"{c}: the contact spans only {n} faces" in note and
                   "mesh.plateau_refine_mm" in note for note in r.notes)


def test_rods_on_too_few_dofs_are_reported():
    with pytest.raises(FecheckError, match="over-constrain"):
        run_scene(load_scene(SCENES / "ligaments.toml", ["dofs.free=['z', 'abduction']"]))


def test_equal_force_constraint_holds_in_the_contact_model():
    # EF model with springs: the constraint |F_m| = |F_l| with a Lagrange multiplier
    r = run_scene(load_scene(SCENES / "springs.toml", ["constraints.equal_forces=true"]))
    assert r.converged
    assert r.compartments["medial"].force_N == pytest.approx(
        r.compartments["lateral"].force_N, abs=1e-6)
    assert r.record.equal_forces_multiplier is not None


def test_negative_stiffness_start_reaches_the_stable_equilibrium_not_the_saddle():
    # A tibia on a dome (contact stiffness -a, load b along y) held by a spring slack
    # within |y| < s: E(y) = -a y²/2 - b y + k max(|y| - s, 0)²/2. The start y = 0 lies
    # on the dome; plain Newton jumps to the unstable root y = -b/a (its residual is
    # zero too). The stable root on the load's side solves a y + b = k (y - s).
    a, b, k, s = 10.0, 1.0, 100.0, 2.0

    def dome(t):
        return point_force(t, np.array([0.0, a * t[1] + b, 0.0]), np.diag([0.0, a, 0.0]))

    def spring(t):
        slack = max(abs(t[1]) - s, 0.0)
        return point_force(t, np.array([0.0, -k * math.copysign(slack, t[1]), 0.0]),
                           np.diag([0.0, -k if slack > 0 else 0.0, 0.0]))

    def wrench(rot, t):
        return [dome(t), spring(t)]

    sol = solve(Problem((tibia_body(np.zeros(5), (1,)),), on_body(wrench), tolerance=1e-10))
    assert sol.converged
    assert sol.q[0][1] == pytest.approx((b + k * s) / (k - a), abs=1e-9)
