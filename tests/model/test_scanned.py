"""The shipped scanned knee's data (landmarks, bundles), decimation and open-sheet contact."""

import json
from pathlib import Path

import numpy as np
import pytest
import tomllib
from conftest import REPO, require_knee_data

from fecheck.errors import FecheckError
from fecheck.scene import lenhart
from fecheck.statics.ligaments import SpringLigament
from geometry.decimate import decimate
from geometry.mesh import TriMesh

SCENES = REPO / "validation" / "scenes"


def test_landmarks_are_the_data_sets_condyle_spheres():
    knee = require_knee_data()
    fits = json.loads((knee / "fits.json").read_text())["fits"]
    lm = lenhart.landmarks()
    for c in ("medial", "lateral"):
        ref = fits[f"femoral_condyle_{c}_sphere"]
        np.testing.assert_allclose(lm.condyle_center[c], ref["centre_mm"])
        # contact point = lowest sphere point, whose z fits.json gives independently
        assert lm.contact_point[c][2] == pytest.approx(ref["lowest_point_z_mm"], abs=1e-3)


def test_bundle_springs_reproduce_the_models_forces_at_rest():
    knee = require_knee_data()
    data = {b["name"]: b for b in json.loads((knee / "ligaments.json").read_text())}
    bundles = lenhart.bundles()
    assert len(bundles) == 55
    checked = 0
    for b in bundles:
        ref = data[b.name]
        if ref["wrap"] and ref["wrap"]["wraps_at_rest"]:
            continue                              # our paths are straight lines
        spring = SpringLigament(b.femur_point, b.tibia_point, b.slack_length_mm,
                                b.stiffness_N, b.transition_strain)
        # OpenSim's spring force at rest, printed to 1e-3 N (points to 1e-4 mm)
        assert spring.tension(b.rest_length_mm) == pytest.approx(
            ref["spring_force_N_at_rest"], abs=0.02)
        checked += 1
    assert checked > 30


def test_the_vectorised_bundles_are_the_sum_of_the_single_springs_with_an_exact_tangent():
    # The 55 bundles at a flexed pose (slack, toe and linear springs all present): the
    # SpringSet's wrench and tangent equal the sum of the single springs' `point_force`
    # to 1e-12 of the largest entry (only the summation order differs), and its tangent
    # matches central differences of its wrench over the twist (h = 1e-6 mm/rad:
    # truncation ~1e-9 of the largest entry; a dropped [x]x term is of order 1).
    from scipy.spatial.transform import Rotation

    from fecheck.statics.ligaments import SpringSet

    require_knee_data()
    springs = [SpringLigament(b.femur_point, b.tibia_point, b.slack_length_mm,
                              b.stiffness_N, b.transition_strain) for b in lenhart.bundles()]
    rot = Rotation.from_rotvec([-0.35, 0.03, -0.05]).as_matrix()
    t = np.array([0.4, -6.0, -1.0])
    bundles = SpringSet.of(springs)
    strain = (bundles.lengths(rot, t) - bundles.slack_mm) / bundles.slack_mm
    assert (strain < 0).sum() and (strain > bundles.transition_strain).sum() \
        and ((strain > 0) & (strain < bundles.transition_strain)).sum()
    w, dw = SpringSet.of(springs)(rot, t)
    ref = [s(rot, t) for s in springs]
    w_ref, dw_ref = sum(r[0] for r in ref), sum(r[1] for r in ref)
    assert np.abs(w - w_ref).max() <= 1e-12 * np.abs(w_ref).max()
    assert np.abs(dw - dw_ref).max() <= 1e-12 * np.abs(dw_ref).max()
    fd = np.zeros((6, 6))
    for j in range(6):
        xi = np.zeros(6)
        xi[j] = 1e-6
        plus = Rotation.from_rotvec(xi[3:]).as_matrix()
        minus = Rotation.from_rotvec(-xi[3:]).as_matrix()
        fd[:, j] = (SpringSet.of(springs)(plus @ rot, plus @ t + xi[:3])[0]
                    - SpringSet.of(springs)(minus @ rot, minus @ t - xi[:3])[0]) / 2e-6
    assert np.abs(fd - dw).max() <= 1e-6 * np.abs(dw).max()


def test_scene_landmarks_and_plateaus_come_from_the_scanned_knee():
    require_knee_data()
    table = lenhart.knee_landmarks_table()
    from fecheck.studies.thesis import knee_fits

    plateau = knee_fits.plateau_values()
    for path in sorted(SCENES.glob("*.toml")):
        data = tomllib.loads(path.read_text())
        if data.get("model", {}).get("kind") not in ("sphere-tibia", "femur-tibia") and \
                data.get("scanned", {}).get("ligaments", "none") == "none":
            continue
        if "landmarks" not in data["knee"]:            # mesh on mesh: none read
            assert data["model"]["kind"] == "femur-tibia"
            continue
        lm = data["knee"]["landmarks"]
        for group, values in table.items():
            for key, v in values.items():
                np.testing.assert_allclose(lm[group][key], v, atol=1e-9, err_msg=path.name)
        kind = data.get("plateau", {}).get("kind")
        for c in ("medial", "lateral"):
            if kind == "inclined":
                np.testing.assert_allclose(data["plateau"][f"{c}_angles_deg"],
                                           plateau[c]["angles_deg"], atol=1e-9)
            if kind == "polynomial":
                np.testing.assert_allclose(data["plateau"][f"{c}_coefficients"],
                                           plateau[c]["coefficients"], rtol=1e-8)


def test_decimation_keeps_the_sheet_close_and_its_orientation():
    require_knee_data()
    sheet = lenhart.mesh("tibia_cartilage_medial")
    small = decimate(sheet, 1000)
    assert 900 <= small.n_faces <= 1000
    # every new vertex stays near the old surface: well within a new edge length
    from geometry.distance import closest_distance

    dist, _ = closest_distance(small.points, sheet)
    cell = np.sqrt(sheet.area / small.n_faces * 2)     # ~ edge length of the new mesh
    assert dist.max() < np.sqrt(3) * cell
    # winding kept: new faces agree with the closest old face's normal (n_z > 0 sheet)
    assert (small.face_normals[:, 2] > 0).mean() > 0.99
    assert small.area == pytest.approx(sheet.area, rel=0.05)


def test_decimate_keeps_small_meshes_and_rejects_tiny_targets():
    from geometry.icosphere import icosphere

    ball = icosphere(10.0, 2, method="trimesh", cache=False)
    assert decimate(ball, 10_000) is ball
    with pytest.raises(FecheckError, match="at least 4"):
        decimate(ball, 3)


def test_open_femoral_sheet_master_gives_the_data_sets_rest_overlap_without_hole_filling():
    """Closest-face-normal sign on the OPEN femoral cartilage: tibial vertices penetrate by
    at most 0.409 mm, 341 of 4453 (README rest-pose check, an independent computation)."""
    from fecheck.contact.mesh_master import MeshMaster
    from geometry.mesh import is_closed

    require_knee_data()
    femur = lenhart.mesh("femur_cartilage")
    tibia = np.vstack([lenhart.mesh(f"tibia_cartilage_{c}").points for c in ("medial",
                                                                            "lateral")])
    assert not is_closed(femur)
    depth = MeshMaster(femur).depth_values(tibia)
    assert -depth.max() == pytest.approx(-0.409, abs=1e-3)
    assert (depth > 0).sum() == 341


def test_ray_parity_fails_on_the_open_sheet_where_the_normal_sign_does_not():
    """Points 1 mm on the bone side of each face are inside, 1 mm off it outside; ray parity
    (thesis Algorithm 3, trimesh `contains`) misses many inside points of an open sheet."""
    import trimesh

    from fecheck.contact.mesh_master import MeshMaster

    require_knee_data()
    femur = decimate(lenhart.mesh("femur_cartilage"), 3000)
    c, n = femur.face_centroids, femur.face_normals
    inside, outside = c - n, c + n
    master = MeshMaster(femur)
    assert np.all(master.depth_values(inside) > 0)
    assert np.all(master.depth_values(outside) < 0)
    parity = trimesh.Trimesh(femur.points, femur.faces, process=False).contains(inside)
    assert parity.mean() < 0.8                    # measured 0.55: rays escape through the hole


def test_missing_data_in_a_scene_is_a_one_line_error(tmp_path):
    from fecheck.model.run import run_scene
    from fecheck.scene import load_scene

    scene = load_scene(SCENES / "femur_tibia.toml", [f"geometry.dir='{tmp_path}'"])
    with pytest.raises(FecheckError, match=r"geometry.tibia = .*file not found at .*geometry.dir"):
        run_scene(scene)


def test_default_folder_is_the_one_packaged_with_fecheck():
    assert lenhart.DEFAULT_DIR == Path(REPO) / "fecheck" / "data" / "knee" / "lenhart2015"


def test_knee_fits_follow_the_thesis_trends(tmp_path):
    """Thesis §2.2.3 on the scanned knee: outlier removal and a free plane lower the plane
    error; the polynomial errors fall with the degree (Tables 2.1, 2.4, 2.5)."""
    require_knee_data()
    from fecheck.studies.thesis import knee_fits

    assert knee_fits.main(["--quick", "--out", str(tmp_path)]) == 0
    t21 = knee_fits.table_2_1()
    for side in ("medial", "lateral"):
        w, wo = (next(r for r in t21 if r["side"] == side and r["case"] == case)
                 for case in ("with outliers", "without outliers"))
        assert wo["me_free_mm"] < w["me_free_mm"] < w["me_transverse_mm"]
        assert wo["inliers"] < wo["points"]
    for rows in (knee_fits.table_2_4(3), knee_fits.table_2_5(3)):
        for side in ("medial", "lateral"):
            me = [r["mean_error_mm"] for r in rows
                  if r["side"] == side and r["degree"] != "sphere"]
            # nested least-squares bases: the RMS error cannot rise; the mean |error|
            # (eq. 2.1, 2.3) need not, but falls here as in the thesis
            assert np.all(np.diff(me) < 0)
    # the degree-0 spherical polynomial about the fitted centre is the sphere (radius = mean r)
    t25 = knee_fits.table_2_5(0)
    for side in ("medial", "lateral"):
        sphere, deg0 = (r for r in t25 if r["side"] == side)
        assert deg0["mean_error_mm"] == pytest.approx(sphere["mean_error_mm"], rel=0.05)
    assert (tmp_path / "knee_fits_table_2_4.csv").is_file()


@pytest.mark.parametrize("scale, units, message", [
    (1e-3, "mm", "looks like metres - set geometry.units = 'm'"),
    (1.0, "m", "looks like millimetres - set geometry.units = 'mm'"),
    (1e4, "mm", "check its unit")])
def test_a_surface_not_in_its_declared_unit_is_refused_with_its_extent(tmp_path, scale, units,
                                                                      message):
    # a 50 mm ball written in metres (0.05 across) read as mm, in mm read as metres, or
    # in tenths of micrometres
    from fecheck.scene.surfaces import read_surface
    from geometry.icosphere import icosphere
    from geometry.io import save_mesh

    ball = icosphere(25.0, 2, (0.0, 0.0, 0.0), method="trimesh", cache=False)
    save_mesh(TriMesh(ball.points * scale, ball.faces), tmp_path / "femur.stl")
    with pytest.raises(FecheckError, match=message):
        read_surface(tmp_path / "femur.stl", units)
    save_mesh(TriMesh(ball.points / 1000.0, ball.faces), tmp_path / "metres.obj")
    read = read_surface(tmp_path / "metres.obj", "m")
    np.testing.assert_allclose(read.points, ball.points, atol=1e-5)
