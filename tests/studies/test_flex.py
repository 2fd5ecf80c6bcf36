"""Driven flexion (`fecheck flex`): the fitted axis, the base-rotated body coordinates, the
ParaView time series, continuity through a range and the command line."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from fecheck.statics.ligaments import SpringLigament
from fecheck.statics.newton import Body, Problem, _System, body_pose, on_body, point_force
from fecheck.studies import flex
from geometry.icosphere import icosphere
from geometry.mesh import TriMesh

MEDIAL_C, LATERAL_C = np.array([-22.0, 4.5, 26.5]), np.array([21.5, 1.5, 27.5])


def _two_condyles() -> TriMesh:
    """Two whole spheres (R 27 and 25 mm) standing for the condyles, one mesh."""
    a = icosphere(27.0, 4, MEDIAL_C, method="trimesh", cache=False)
    b = icosphere(25.0, 4, LATERAL_C, method="trimesh", cache=False)
    return TriMesh(np.vstack([a.points, b.points]), np.vstack([a.faces, b.faces + a.n_points]))


def test_the_axis_of_two_sphere_condyles_is_the_line_through_their_centres():
    # Known axis: through MEDIAL_C and LATERAL_C. The fit uses face centroids, which sit
    # inside the sphere by about R·(1 - cos) of a face's angular size (level 4: ~0.03 mm,
    # the same on every face), so the centres come back to 0.01 mm and the direction to
    # 1e-4; the radius a little short of R.
    axis = flex.condyle_axis(_two_condyles())
    e = (LATERAL_C - MEDIAL_C) / np.linalg.norm(LATERAL_C - MEDIAL_C)
    assert np.allclose(axis.direction, e, atol=1e-4)
    assert np.allclose(axis.point, (MEDIAL_C + LATERAL_C) / 2, atol=0.01)
    assert np.allclose(axis.spheres["x<0"][0], MEDIAL_C, atol=0.01)
    assert axis.spheres["x<0"][1] == pytest.approx(27.0, abs=0.05)


def test_the_scene_keys_give_the_axis_turned_towards_plus_x():
    from fecheck.errors import FecheckError
    from fecheck.scene import load_scene

    scene = load_scene("femur_tibia_ligaments", ["flexion.axis_point_mm=[1.0, 2.0, 25.0]",
                                                 "flexion.axis_dir=[-3.0, 0.0, 4.0]"])
    axis = flex.scene_axis(scene)
    assert axis.point.tolist() == [1.0, 2.0, 25.0]
    assert np.allclose(axis.direction, [0.6, 0.0, -0.8]) and "flexion.axis" in axis.source
    with pytest.raises(FecheckError, match="set both flexion.axis_point_mm"):
        flex.scene_axis(load_scene("femur_tibia_ligaments", ["flexion.axis_dir=[1, 0, 0]"]))
    with pytest.raises(FecheckError, match=r"is 84.29° from the medio-lateral x axis, more "
                       r"than the 78.46° allowed"):
        flex.given_axis([0.0, 0.0, 0.0], [0.1, 1.0, 0.0])


def test_a_base_rotation_turns_the_flexion_angle_about_its_first_axis():
    # R = Q·Rx(θ)·Qᵀ is the rotation by θ about Q e_x (scipy's rotation vector).
    e = np.array([0.95, -0.2, 0.24]) / np.linalg.norm([0.95, -0.2, 0.24])
    q_rot = flex.axis_rotation(e)
    assert np.allclose(q_rot @ [1.0, 0.0, 0.0], e) and np.linalg.det(q_rot) == pytest.approx(1)
    rot, _ = body_pose(np.array([0.0, 0.0, 0.0, 0.7, 0.0, 0.0]), q_rot)
    assert np.allclose(rot, Rotation.from_rotvec(0.7 * e).as_matrix(), atol=1e-12)


def test_base_rotated_coordinates_keep_an_exact_newton_tangent():
    # A body with a base rotation, every coordinate free, under a Blankevoort spring to
    # the world and a constant force at a body point: the Jacobian of the residual
    # against central differences (smooth parts: h = 1e-5 gives truncation ~1e-10 of
    # the largest entry; a missing or unrotated axis term is of order 1e-1).
    q_rot = flex.axis_rotation(np.array([0.9, -0.3, 0.3]))
    spring = SpringLigament(np.array([10.0, 5.0, 40.0]), np.array([-4.0, 8.0, -20.0]), 50.0,
                            2000.0, 0.06)
    force_at = np.array([3.0, -2.0, -300.0])

    def parts(rot, t):
        return [spring(rot, t), point_force(rot @ force_at + t, np.array([5.0, 20.0, 100.0]))]

    q0 = np.array([0.5, -0.4, 0.8, 0.4, 0.1, -0.2])
    system = _System(Problem((Body("tibia", q0, tuple(range(6)), base=q_rot),),
                             on_body(parts)))
    z = system.z_of([q0])
    res, jac = system(z)
    assert spring.tension(np.linalg.norm(spring.femur_point - spring.tibia_point)) >= 0
    cols = []
    for j in range(6):
        dz = np.zeros(6)
        dz[j] = 1e-5
        cols.append((system(z + dz)[0] - system(z - dz)[0]) / 2e-5)
    fd = np.column_stack(cols)
    assert np.abs(fd - jac).max() <= 1e-6 * np.abs(fd).max()


def _toy_run(angles) -> flex.FlexRun:
    """A FlexRun of two small sheets turned about x by each angle (no solve)."""
    sheet = TriMesh(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]),
                    np.array([[0, 1, 2], [1, 3, 2]]))
    axis = flex.FlexionAxis(np.zeros(3), np.array([1.0, 0.0, 0.0]), "given")
    points = []
    for a in angles:
        rot = Rotation.from_rotvec([-math.radians(a), 0, 0]).as_matrix()
        comp = {"force_N": 1.0, "axial_force_N": 1.0, "area_mm2": 1.0,
                "max_pressure_MPa": a, "cop_x_mm": 0.5, "cop_y_mm": 0.5}
        points.append(flex.FlexPoint(a, 0.0, 0.0, np.zeros(3), {"medial": comp,
                                     "lateral": comp}, {"ACLam1": 1.0}, rot, np.zeros(3),
                                     {"medial": np.full(2, a), "lateral": np.full(2, -a)},
                                     1, 0.0))
    return flex.FlexRun(axis, points, 0.0, {"medial": sheet, "lateral": sheet})


def test_the_pvd_reads_back_as_a_time_series_with_one_step_per_angle(tmp_path):
    pv = pytest.importorskip("pyvista")
    from fecheck.studies.flex_outputs import write_vtk_series

    angles = [0.0, 15.0, 30.0, 90.0]
    pvd = write_vtk_series(_toy_run(angles), tmp_path / "vtk")
    reader = pv.get_reader(str(pvd))
    assert reader.time_values == pytest.approx(angles)
    for a in angles:
        reader.set_active_time_value(a)
        mesh = reader.read()[0]
        assert mesh.n_cells == 4
        assert np.allclose(mesh.cell_data["pressure_MPa"], [a, a, -a, -a])
        # the point (0, 1, 0) turned by -a about x: (0, cos a, -sin a)
        assert np.allclose(mesh.points[2], [0.0, math.cos(math.radians(a)),
                                            -math.sin(math.radians(a))], atol=1e-6)


def _bundled_run(angles) -> flex.FlexRun:
    """`_toy_run` with a femur sheet and two bundles from the femur to tibial points."""
    run = _toy_run(angles)
    run.femur = {"articular surface": run.slaves["medial"]}
    run.bundles = (("A", "B"), np.array([[0.0, 0.0, 5.0], [1.0, 0.0, 5.0]]),
                   np.array([[0.0, 1.0, 0.0], [1.0, 1.0, 0.0]]))
    for p in run.points:
        p.ligaments = {"A": 10.0 + p.flexion_deg, "B": 2.0}
    return run


def test_the_pvd_has_the_femur_and_a_line_per_bundle_within_the_size_estimate(tmp_path):
    # The bundle B runs from its femoral point (1, 0, 5) to its tibial point (1, 1, 0)
    # turned by -a about x: (1, cos a, -sin a). The estimate bounds the files from above
    # (uncompressed sizes; measured here about 3 times the written bytes).
    pv = pytest.importorskip("pyvista")
    from fecheck.studies.flex_outputs import vtk_size_bytes, write_vtk_series

    angles = [0.0, 30.0]
    run = _bundled_run(angles)
    pvd = write_vtk_series(run, tmp_path / "vtk")
    reader = pv.get_reader(str(pvd))
    for a in angles:
        reader.set_active_time_value(a)
        tibia, femur, lines = reader.read()
        assert femur.n_cells == 2 and np.allclose(femur.points, run.slaves["medial"].points)
        assert lines.n_cells == 2 and np.allclose(lines.cell_data["tension_N"], [10 + a, 2])
        b = lines.get_cell(1).points
        c, s = math.cos(math.radians(a)), math.sin(math.radians(a))
        assert np.allclose(b, [[1.0, 0.0, 5.0], [1.0, c, -s]], atol=1e-6)
        assert np.allclose(lines.cell_data["length_mm"][1], np.linalg.norm(b[1] - b[0]))
    written = sum(f.stat().st_size for f in (tmp_path / "vtk").iterdir())
    assert written <= vtk_size_bytes(run)


def test_a_vtk_series_over_the_cap_is_refused_unless_forced(monkeypatch):
    from fecheck.errors import FecheckError
    from fecheck.studies import flex_outputs

    run = _bundled_run([0.0, 30.0])
    monkeypatch.setattr(flex_outputs, "VTK_CAP_BYTES", 1000.0)
    with pytest.raises(FecheckError, match="--vtk would write about .* --force"):
        flex_outputs.check_vtk_size(run, None, force=False)
    assert flex_outputs.check_vtk_size(run, None, force=True) > 1000


def test_the_table_states_the_signs_and_has_a_row_per_angle():
    from fecheck.studies.flex_outputs import table_text

    run = _toy_run([0.0, 15.0])
    run.points[1].abduction_deg, run.points[1].internal_deg = 1.25, -2.5
    lines = table_text(run).splitlines()
    assert "add° adduction (+ varus" in lines[0] and "(+ internal" in lines[0]
    assert lines[1].split()[:3] == ["flex°", "add°", "int°"]
    assert [line.split()[:3] for line in lines[2:]] == [["0", "0.00", "0.00"],
                                                        ["15", "1.25", "-2.50"]]


@pytest.fixture(scope="module")
def knee_range():
    """The scanned knee with bundles, decimated, 20-26° in 1° steps."""
    from fecheck.scene import load_scene

    scene = load_scene("femur_tibia_ligaments", ["scanned.decimate_faces=3000"])
    axis = flex.scene_axis(scene)
    return axis, flex.run_flex(scene, np.arange(20.0, 27.0), axis)


def test_the_driven_angle_is_turned_about_the_axis_and_the_others_solved(knee_range):
    # Qᵀ·R·Q decomposed as Rx·Ry·Rz (scipy intrinsic XYZ): the first angle is the driven
    # -φ to round-off, the other two the reported abduction and internal rotation.
    axis, run = knee_range
    q_rot = flex.axis_rotation(axis.direction)
    assert run.stopped is None and len(run.points) == 7
    for p in run.points:
        x, y, z = Rotation.from_matrix(q_rot.T @ p.rot @ q_rot).as_euler("XYZ")
        assert x == pytest.approx(-math.radians(p.flexion_deg), abs=1e-12)
        assert (math.degrees(y), math.degrees(z)) == pytest.approx(
            (p.abduction_deg, p.internal_deg), abs=1e-9)


def test_neighbouring_angles_do_not_jump(knee_range):
    # 1° apart on this range the contact stays on the same condyle region: measured steps
    # are at most 0.05° (rotations), 0.10 mm (translations of the tibial point at the axis
    # point), 0.17 mm (centres of pressure) and 0.9 % (compartment forces) per degree; the
    # bounds are 3-4 times those. A jump of the contact (the scanned knee's full range has
    # one at 6-8°: 2.1° and 4 mm per degree) or the hinge's own arc reported as a
    # translation (26.5 mm · 1° = 0.46 mm) exceeds them.
    _, run = knee_range
    rows = [p.row() for p in run.points]
    for key, bound in (("internal_deg", 0.2), ("abduction_deg", 0.2), ("ap_mm", 0.3),
                       ("ml_mm", 0.3), ("si_mm", 0.3), ("medial_cop_y_mm", 0.5),
                       ("lateral_cop_y_mm", 0.5)):
        steps = np.abs(np.diff([r[key] for r in rows]))
        assert steps.max() < bound, key
    for c in ("medial", "lateral"):
        force = np.array([r[f"{c}_force_N"] for r in rows])
        assert np.abs(np.diff(force)).max() < 0.03 * force.mean()


def test_each_angle_starts_from_the_last_equilibrium_turned_about_the_axis(monkeypatch):
    # The start of angle i+1: the last equilibrium's rotation turned by the 1° step about
    # the axis (scipy rotation vector), the tibial point at the axis point left where the
    # last equilibrium put it.
    import fecheck.model.equilibrium as equilibrium
    from fecheck.scene import load_scene
    from fecheck.statics.newton import body_pose

    real, starts = equilibrium.solve_equilibrium, []

    def recorded(scene, comps, springs, constraints, warm, flexion, **kwargs):
        starts.append((warm, flexion))
        return real(scene, comps, springs, constraints, warm, flexion, **kwargs)

    monkeypatch.setattr(equilibrium, "solve_equilibrium", recorded)
    scene = load_scene("femur_tibia_ligaments", ["scanned.decimate_faces=3000"])
    axis = flex.scene_axis(scene)
    run = flex.run_flex(scene, [20.0, 21.0, 22.0], axis)
    c, step = axis.point, Rotation.from_rotvec(-math.radians(1.0) * axis.direction)
    assert starts[0][0] is None
    for last, (warm, (theta, base)) in zip(run.points, starts[1:], strict=False):
        rot, t = body_pose(np.array([*warm[:3], theta, *warm[3:]]), base)
        assert np.allclose(rot, step.as_matrix() @ last.rot, atol=1e-12)
        assert np.allclose(rot @ c + t, last.rot @ c + last.t, atol=1e-9)


KNEE = ["femur_tibia_ligaments", "--set", "scanned.decimate_faces=3000"]


def _main(argv):
    from fecheck.cli import main

    return main(["flex", *KNEE, *argv])


def test_cli_writes_one_row_per_angle_and_progress_on_stderr(tmp_path, capsys):
    import json

    code = _main(["--angles", "0:2:1", "--csv", "-", "--json", str(tmp_path / "f.json"),
                  "--vtk", str(tmp_path / "vtk")])
    out, err = capsys.readouterr()
    assert code == 0
    assert {p.name for p in (tmp_path / "vtk").iterdir()} == {
        "flex.pvd", "femur.vtu", *(f"{k}_{i:03d}.vtu" for k in ("flex", "ligaments")
                                   for i in range(3))}
    assert "writing the VTK series" in err and "at most" in err
    lines = out.strip().splitlines()
    assert lines[0].startswith("flexion_deg,abduction_deg,internal_deg,ml_mm,ap_mm,si_mm,"
                               "adduction_deg,internal_rotation_deg")
    assert "per angle: flex° knee flexion" in err     # the table, off the CSV's stdout
    assert [float(line.split(",")[0]) for line in lines[1:]] == [0.0, 1.0, 2.0]
    assert "flex [3/3] 2°" in err and "flexion axis: point" in err
    doc = json.loads((tmp_path / "f.json").read_text())
    assert [a["flexion_deg"] for a in doc["angles"]] == [0.0, 1.0, 2.0]
    assert "varus" in doc["signs"]["adduction_deg"]
    assert all(a["adduction_deg"] == a["abduction_deg"] for a in doc["angles"])  # right knee
    assert len(doc["angles"][0]["ligaments_N"]) == 55


def test_cli_refuses_bad_angles_before_building_anything(monkeypatch, capsys):
    import fecheck.model.scanned as scanned

    def never(scene):
        raise AssertionError("built")

    monkeypatch.setattr(scanned, "build_compartments", never)
    assert _main(["--angles", "30:10:1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--angles '30:10:1'" in err[0]


def test_ctrl_c_keeps_the_finished_angles(tmp_path, monkeypatch, capsys):
    import fecheck.model.equilibrium as equilibrium

    real, calls = equilibrium.solve_equilibrium, []

    def interrupted(*args, **kwargs):
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(equilibrium, "solve_equilibrium", interrupted)
    assert _main(["--angles", "0:4:1", "--csv", str(tmp_path / "f.csv")]) == 130
    rows = (tmp_path / "f.csv").read_text().strip().splitlines()
    assert len(rows) == 3                              # header and the angles 0° and 1°
    assert "interrupted at flexion 2°" in capsys.readouterr().err


def test_past_the_cartilage_stops_with_one_line_naming_the_angle(tmp_path, capsys):
    # decimated knee: 140° solves with the lateral contact 4.3 mm from the posterior edge
    # of the femoral cartilage; 145° is not reached in one step, and in 1° steps 144° finds
    # no equilibrium
    assert _main(["--angles", "140,145", "--csv", str(tmp_path / "f.csv")]) == 1
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("fecheck: error: flexion 145° (approached from 140° in 1° steps): "
                          "flexion 144°: no equilibrium")
    assert "the femoral cartilage runs out there" in err
    assert len((tmp_path / "f.csv").read_text().strip().splitlines()) == 2


@pytest.fixture(scope="module")
def knee_fe():
    """The decimated knee flexed 20-21°, with the FE cross-check at 21°."""
    from fecheck.scene import load_scene

    scene = load_scene("femur_tibia_ligaments", ["scanned.decimate_faces=3000"])
    axis = flex.scene_axis(scene)
    return scene, axis, flex.run_flex(scene, [20.0, 21.0], axis, fe_at=[21.0])


def test_fe_at_an_angle_holds_its_flexion_and_balances_the_free_dofs(knee_fe):
    # Independent of the twist basis: with x, y, z free the FE contact forces, load,
    # gravity and ligaments sum to no force, and with θy, θz free their moment lies along
    # n = Q·Rx(-φ)·(cos θy, 0, -sin θy) (normal to the two free rotation axes Q·Rx·e_y and
    # Q·Rx·Ry·e_z). Bounds: 1e-8 of the 800 N load, moments over 100 mm lever. An FE
    # driven about world x at the scene's 0° instead does not settle (its active set
    # fails after 200 iterations); the reported balance must agree (measured 2e-12).
    from fecheck.model.assembly import applied_load
    from fecheck.model.run import ligament_springs
    from fecheck.statics.newton import pose

    scene, axis, run = knee_fe
    assert [r["flexion_deg"] for r in run.fe] == [21.0]
    row = run.fe[0]
    check = row["check"]
    p = check.pose["fe"]
    q = np.array([p["x_mm"], p["y_mm"], p["z_mm"], math.radians(p["abduction_deg"]),
                  math.radians(p["internal_deg"])])
    q_rot, phi = flex.axis_rotation(axis.direction), math.radians(21.0)
    rot, t = pose(q, -phi, q_rot)
    x, _, _ = Rotation.from_matrix(q_rot.T @ rot @ q_rot).as_euler("XYZ")
    assert x == pytest.approx(-phi, abs=1e-12)
    total = sum(part(rot, t)[0] for part in [applied_load(scene), *ligament_springs(scene)])
    for chk in check.compartments.values():
        xs = chk.layer.surface.points @ rot.T + t
        f = -chk.fe_force_N[:, None] * (chk.layer.solid.normals @ rot.T)
        total = total + np.concatenate([f.sum(axis=0), np.cross(xs, f).sum(axis=0)])
    load = scene["load.force_N"]
    n = q_rot @ Rotation.from_rotvec([-phi, 0, 0]).as_matrix() @ [
        math.cos(q[3]), 0.0, -math.sin(q[3])]
    moment = total[3:] - (total[3:] @ n) * n
    assert np.abs(total[:3]).max() < 1e-8 * load
    assert np.abs(moment).max() < 1e-8 * load * 100.0
    assert row["balance"] < 1e-8


def test_fe_at_an_angle_compares_on_the_flexed_poses_tibial_faces(knee_fe):
    # FE and EF of the same flexed knee under the same load: measured at 21° the FE's
    # split is within 0.0015 of the EF's and the centres of pressure within 0.2 mm (EF
    # areas 24-25 % larger, EF p_max 14-21 % higher); bounds 0.02 and 1 mm. The EF's
    # centres read in a frame flexed about world x at 0° instead of the axis land 2.1
    # (lateral) and 3.9 mm (medial) from the FE's.
    from fecheck.studies.flex_outputs import json_text

    _, _, run = knee_fe
    row = run.fe[0]
    for c in ("medial", "lateral"):
        assert row[f"{c}_fe_split"] == pytest.approx(row[f"{c}_ef_split"], abs=0.02)
        assert row[f"{c}_cop_distance_mm"] < 1.0
        assert 0.0 < row[f"{c}_fe_p_max_MPa"] and 0.0 < row[f"{c}_fe_area_mm2"]
    assert row["medial_fe_split"] + row["lateral_fe_split"] == pytest.approx(1.0, abs=1e-12)
    import json

    doc = json.loads(json_text(run))
    assert doc["fe"][0]["flexion_deg"] == 21.0 and "check" not in doc["fe"][0]
    assert doc["fe"][0]["lateral_cop_distance_mm"] == row["lateral_cop_distance_mm"]


def test_fe_at_settles_where_the_internal_rotation_is_soft_under_a_tibial_axis_load():
    # 800 N along the tibial axis at 26°, near the steep passage of the internal rotation
    # (the decimated knee's rotational stiffness vanishes at 26.6°): without the contact
    # forces' own change with the pose in the FE's tangent, the pose updates wander (steps
    # 0.05-0.65 mm) until the active set fails; with it they converge, quadratically at
    # the end (measured: 7 updates; 19 with the 5 mm trust region, which shortens the
    # first rotation steps of up to 0.13 rad). Bound: 25 updates (of 30), balance 1e-8.
    from fecheck.scene import load_scene

    scene = load_scene("femur_tibia_ligaments", ["scanned.decimate_faces=1500",
                                                 "load.frame='tibia'"])
    axis, updates = flex.scene_axis(scene), []
    run = flex.run_flex(scene, [26.0], axis, fe_at=[26.0],
                        fe_log=lambda m: updates.append(m) if "pose update" in m else None)
    assert run.stopped is None and len(run.fe) == 1
    assert run.fe[0]["balance"] < 1e-8 and len(updates) <= 25
    assert all(run.fe[0][f"{c}_fe_area_mm2"] > 0 for c in ("medial", "lateral"))


def test_fe_at_settles_past_the_snap_under_a_tibial_axis_load():
    # 30°, 800 N along the tibial axis, decimated to 3,000 faces (19.6° of internal
    # rotation, past the snap): the first update's tangent (follower load and bundles) has
    # symmetric eigenvalues down to -3.1e4 N·mm and an antisymmetric part of 3.6e3, and the
    # block active set cycled on it, as did the one-change-per-solve fallback (1,533
    # changes); with its symmetric part that step settles and the pose converges in 5
    # updates (measured balance 5e-16, FE internal rotation 18.84° against the EF's 19.61°).
    from fecheck.scene import load_scene

    scene = load_scene("femur_tibia_ligaments", ["scanned.decimate_faces=3000",
                                                 "load.frame='tibia'"])
    run = flex.run_flex(scene, [20.0, 30.0], flex.scene_axis(scene), fe_at=[30.0])
    assert run.stopped is None and run.fe[0]["balance"] < 1e-8
    assert all(run.fe[0][f"{c}_fe_area_mm2"] > 0 for c in ("medial", "lateral"))


def test_cli_refuses_an_fe_angle_outside_the_sweep_before_building_anything(monkeypatch,
                                                                            capsys):
    import fecheck.model.scanned as scanned
    import fecheck.scene as scene_module

    def never(*args, **kwargs):
        raise AssertionError("built")

    monkeypatch.setattr(scanned, "build_compartments", never)
    monkeypatch.setattr(scene_module, "load_scene", never)
    assert _main(["--angles", "0:60:2", "--fe-at", "0,30,45"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--fe-at '0,30,45': 45° not among the --angles" in err[0]


def test_the_one_at_a_time_active_set_solves_the_block_updates_complementarity():
    # A rigid plate pushed down onto 30 springs of a symmetric positive definite
    # compliance, one translation unknown: the complementarity has one solution, which the
    # block (Hintermüller-Ito-Kunisch) update finds; the one-change-per-solve fallback
    # must find the same forces (round-off ~1e-12 of the load), from every candidate in
    # contact (releases needed) and from the deepest alone (additions needed).
    from fecheck.fe.contact.active_set import active_set, one_at_a_time

    rng = np.random.default_rng(3)
    a = rng.normal(size=(30, 30))
    C = 0.01 * (a @ a.T / 30 + np.eye(30))
    g0 = rng.uniform(0.0, 0.3, 30)
    J = G = np.ones((30, 1))
    Q, dQ = np.array([-100.0]), np.zeros((1, 1))
    deepest = np.zeros(30, dtype=bool)
    deepest[np.argmin(g0)] = True
    lam_b, dq_b, set_b, _ = active_set(C, g0, J, G, Q, dQ, deepest.copy(), 200, "")
    assert 1 < set_b.sum() < 30
    for start in (np.ones(30, dtype=bool), deepest):
        lam_o, dq_o, set_o, _ = one_at_a_time(C, g0, J, G, Q, dQ, start.copy(), 600)
        assert np.array_equal(set_o, set_b)
        assert np.allclose(lam_o, lam_b, rtol=0, atol=1e-9) and dq_o == pytest.approx(dq_b)
        assert lam_o.sum() == pytest.approx(100.0, rel=1e-12)


def test_an_angle_whose_fe_fails_gets_its_reason_and_the_others_go_on(tmp_path, monkeypatch,
                                                                       capsys):
    # the FE at 0° fails (made to raise as a pose update loop that does not settle does);
    # 1° still gets its full FE row, the table and JSON carry 0°'s one-line reason, the
    # sweep's angles are all written, and the exit code is 1 naming the failed angle
    import json

    from fecheck.errors import FecheckError

    real = flex.fe_row
    reason = "the FE joint equilibrium did not settle in 30 pose updates"

    def failing_at_0(scene, point, *args, **kwargs):
        if point.flexion_deg == 0.0:
            raise FecheckError(reason)
        return real(scene, point, *args, **kwargs)

    monkeypatch.setattr(flex, "fe_row", failing_at_0)
    path = tmp_path / "f.json"
    code = _main(["--set=scanned.decimate_faces=1500", "--set=fe.layers=1", "--angles",
                  "0:1:1", "--fe-at", "0,1", "--json", str(path)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1
    assert f"0° FE failed: {reason}" in [line.strip() for line in err]
    assert "the FE failed at 0°" in err[-1] and "1°" not in err[-1].split("(")[0]
    doc = json.loads(path.read_text())
    assert [a["flexion_deg"] for a in doc["angles"]] == [0.0, 1.0]
    failed, good = doc["fe"]
    assert failed == {"flexion_deg": 0.0, "fe_error": reason}
    assert good["flexion_deg"] == 1.0 and "fe_error" not in good
    assert good["balance"] < 1e-8
    assert all(good[f"{c}_fe_area_mm2"] > 0 for c in ("medial", "lateral"))
