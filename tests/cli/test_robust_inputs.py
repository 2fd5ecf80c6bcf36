"""Inputs a tester and real data tried: each answered before any work by one line naming
the cause and the fix (exit 2), never a traceback, an exhausted memory or minutes of
silence. Sizes are counted before anything is made (angles, sweep points, faces)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from fecheck.cli import main, negative_value_hint
from fecheck.errors import FecheckError
from fecheck.studies.flex import MAX_ANGLES, given_axis, parse_angles
from fecheck.studies.sweep import MAX_POINTS, parse_values


def _error(capsys) -> str:
    """The one error line of a refused command (no traceback)."""
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.startswith("fecheck")]
    assert lines, err
    return lines[-1]


# ------------------------------------------------------------------ sizes before work
def test_flex_angles_are_counted_before_any_is_made():
    """0:160:1e-7 would be 1.6e9 angles (13 GB for the array alone, killed at 23 GB): it is
    refused with the step that fits (the count is in the message: it was worked out, not
    made); the cap's own edge is exact."""
    with pytest.raises(FecheckError, match=r"1,600,000,001 angles.*STEP >= 0\.081"):
        parse_angles("0:160:1e-7")
    # 0.081 is the proposed step: it must fit, and 0.08 (2,001 angles) must not
    assert len(parse_angles("0:160:0.081")) == math.floor(160 / 0.081) + 1 <= MAX_ANGLES
    with pytest.raises(FecheckError, match="2,001 angles"):
        parse_angles("0:160:0.08")
    assert len(parse_angles("-30:160:0.1")) == 1901          # 0.1° over the whole range fits


@pytest.mark.parametrize("text", ["0:inf:10", "-inf:0:1", "0:10:inf", "nan", "0,nan,10",
                                  "0:nan:1"])
def test_flex_angles_that_are_not_finite_are_refused(text):
    with pytest.raises(FecheckError, match="--angles"):
        parse_angles(text)


def test_flex_nan_axis_point_is_refused_before_the_scene(capsys):
    assert main(["flex", "femur_tibia_ligaments", "--axis-point", "nan,0,0",
                 "--axis-dir", "1,0,0", "--angles", "0:0:1"]) == 2
    assert "--axis-point 'nan,0,0': give three finite numbers" in _error(capsys)


def test_a_flexion_axis_refusal_prints_its_angle_and_limit_apart():
    """78.47° from x is past the limit acos(0.2) = 78.46°: the message must not print
    both as "78°"."""
    a = math.radians(78.47)
    with pytest.raises(FecheckError, match=r"78\.47° .* more than the 78\.46° allowed"):
        given_axis([0.0, 0.0, 0.0], [math.cos(a), math.sin(a), 0.0])
    a = math.radians(78.45)
    assert given_axis([0.0, 0.0, 0.0], [math.cos(a), math.sin(a), 0.0]).direction[0] > 0


def test_sweep_points_are_counted_before_any_is_made(capsys):
    """10:20:100000000 took 4 GB and 300 s of silence: refused by its count (exit 2)."""
    assert main(["sweep", "baseline", "--param", "contact.youngs_MPa",
                 "--values", "10:20:100000000"]) == 2
    assert f"100,000,000 points, more than the {MAX_POINTS:,}" in _error(capsys)
    assert len(parse_values(f"0:1:{MAX_POINTS}")) == MAX_POINTS
    with pytest.raises(FecheckError, match="values listed"):
        parse_values(",".join(["1"] * (MAX_POINTS + 1)))
    with pytest.raises(FecheckError, match="finite"):
        parse_values("10:inf:3")


# ------------------------------------------------------------------ one-line errors
@pytest.mark.parametrize("argv, option", [
    (["flex", "femur_tibia_ligaments", "--angles", "-10:0:5"], "--angles=-10:0:5"),
    (["flex", "femur_tibia_ligaments", "--axis-point", "-0.48,0,0", "--axis-dir", "1,0,0"],
     "--axis-point=-0.48,0,0"),
    (["sweep", "--param", "load.point_mm[0]", "--values", "-1:1:3"], "--values=-1:1:3"),
])
def test_a_negative_value_read_as_an_option_gets_the_equals_hint(argv, option, capsys):
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    assert f"write {option}" in capsys.readouterr().err


def test_the_equals_hint_is_only_given_before_a_negative_value():
    assert negative_value_hint("argument --set: expected one argument", ["run", "--set"]) == ""
    assert negative_value_hint("argument --angles: expected one argument",
                               ["flex", "--angles", "--json", "x"]) == ""
    assert negative_value_hint("argument -o/--output: expected one argument",
                               ["--output", "-1.toml"]).endswith("write --output=-1.toml")


def test_a_calibration_file_without_a_compartment_names_it(tmp_path, capsys):
    path = tmp_path / "cal.json"
    path.write_text(json.dumps({"version": 1, "compartments": {"medial": {"C": 5.0,
                                                                          "n": 1.0}}}))
    assert main(["run", "scanned-knee", "--set", "contact.law=ef-calibrated",
                 "--set", f"contact.calibration='{path}'",
                 "--set", "scanned.decimate_faces=1500"]) == 2
    line = _error(capsys)
    assert "holds no lateral compartment (it has medial)" in line
    assert "fecheck calibrate" in line


def test_a_menisci_dir_without_its_files_names_them(capsys):
    assert main(["run", "femur_tibia_menisci", "--set",
                 "menisci.dir='fecheck:knee/lenhart2015'"]) == 2
    line = _error(capsys)
    assert "holds no menisci.json, meniscal_ligaments.json" in line
    assert "fecheck:knee/smith2019_menisci" in line


@pytest.mark.parametrize("argv", [
    lambda d: ["knee", "import", "--femur", str(d), "--tibia", str(d), "-o", str(d / "k.toml")],
    lambda d: ["run", "scanned-knee", "--set", f"geometry.tibia='{d}'"],
    lambda d: ["run", "scanned-knee", "--set", "contact.law=ef-calibrated",
               "--set", f"contact.calibration='{d}'"],
])
def test_a_directory_given_for_a_file_says_so(argv, tmp_path, capsys):
    folder = tmp_path / "meshes"
    folder.mkdir()
    assert main(argv(folder)) == 2
    line = _error(capsys)
    assert f"{folder} is a directory" in line and "not found" not in line


def test_a_tibia_solid_without_a_sheet_meshes_its_up_facing_part(tmp_path):
    """The README's configuration: geometry.tibia_solid and no geometry.tibia. The FE's
    bodies are the solid's, and its articular faces are those the sheet of the same
    implant names (the sheet is the solid's top: `geometry.synthetic.implant`)."""
    from fecheck.fe.bodies.scene_bodies import scene_bodies
    from fecheck.scene import load_scene
    from geometry.synthetic.implant import write_implant

    with_sheet = write_implant(tmp_path, fine_mm=1.5)
    text = with_sheet.read_text(encoding="utf-8")
    without = tmp_path / "solid_only.toml"
    without.write_text(text.replace('tibia = "insert_top.stl"\n', ""), encoding="utf-8")
    assert "insert_top" not in without.read_text(encoding="utf-8")
    ref = {b.name: b for b in scene_bodies(load_scene(with_sheet))}
    for body in scene_bodies(load_scene(without)):
        assert body.tibial_surface == "solid:insert.stl"
        area = body.solid.surface.face_areas
        faces, expected = body.solid.articular[body.name], ref[body.name].solid.articular[body.name]
        # the up-facing part may take a few rim faces the sheet leaves out: areas within 5 %
        assert area[faces].sum() == pytest.approx(area[expected].sum(), rel=0.05)
        assert len(np.intersect1d(faces, expected)) >= 0.95 * len(expected)


# ------------------------------------------------------------------ wrong or unclear numbers
def test_the_linear_ef_is_refused_past_poisson_049(capsys):
    """At ν 0.4999 the EF's p_max is 29x the converged FE's (baseline medial: 150 against
    5.25 MPa); at 0.49 it is 2.9x and still answered, with the table's warning."""
    assert main(["run", "scanned-knee", "--set", "contact.poisson=0.4999",
                 "--set", "scanned.decimate_faces=1500"]) == 2
    line = _error(capsys)
    assert "contact.poisson = 0.4999" in line
    assert "contact.law = 'ef-calibrated'" in line and "fecheck fe" in line
    assert main(["run", "--set", "contact.poisson=0.49"]) == 0


def test_the_ef_poisson_limit_is_where_the_ef_leaves_the_fe():
    """The refusal's threshold against the closed forms: the EF cap's p_max (k d with
    F = k π d² (R - d/3)) at ν 0.49 over the converged mixed FE's 5.19 MPa (baseline
    medial, tests/fe/test_fe_mixed.py) is near 3, and grows past 25 by 0.4999."""
    from fecheck.laws.materials import column_stiffness
    from fecheck.model.plausibility import EF_POISSON_MAX
    from fecheck.reference.closed_forms import ef_cap_depth

    def ef_p_max(nu):
        k = column_stiffness(20.0, nu, 6.0)
        return k * ef_cap_depth(323.71, 25.5, k)

    assert EF_POISSON_MAX == 0.49
    assert 2.5 < ef_p_max(0.49) / 5.18935 < 3.5
    assert ef_p_max(0.4999) / 5.25497 > 25


def test_a_load_the_menisci_solve_cannot_carry_exits_2_with_its_cause(capsys):
    assert main(["run", "femur_tibia_menisci", "--set", "load.force_N=1e9",
                 "--set", "scanned.decimate_faces=1500"]) == 2
    line = _error(capsys)
    assert ("no headway" in line or "no equilibrium found" in line) and "load.force_N" in line
    assert "max_iterations" not in line


def test_a_stiff_meniscus_is_named_in_the_no_stiffness_error():
    """On the decimated scanned knee 1,000 MPa solves and 10,000 MPa stops with meniscus
    DOFs that nothing resists (measured by hand: 46 s to that error at 1e5 MPa, too long
    for this suite); the note names the modulus from 10 times the cartilage's."""
    from fecheck.model.menisci import _stiff_note
    from fecheck.scene import load_scene

    note = _stiff_note(load_scene("femur_tibia_menisci", ["menisci.youngs_MPa=1e5"]))
    assert "menisci.youngs_MPa = 100000 is 5e+03 times" in note
    assert "lower menisci.youngs_MPa" in note
    assert _stiff_note(load_scene("femur_tibia_menisci", ["menisci.youngs_MPa=100"])) == ""


def test_the_shared_free_key_advice_keeps_what_every_body_keeps():
    """Two bodies on one key, one loose in y and z, the other in x and y: only the DOFs
    neither needs driven stay free (here none of x, y, z)."""
    from fecheck.statics.newton import Body, Problem, _no_stiffness_message

    bodies = (Body("a", np.zeros(6), (0, 1, 2), "menisci.free", "start"),
              Body("b", np.zeros(6), (0, 1, 2), "menisci.free", "start"))
    problem = Problem(bodies, lambda q: [], (), 1.0)
    null = np.zeros((6, 1))
    null[[1, 2, 3, 4], 0] = 1.0                    # a: y, z loose; b: x, y loose
    text = _no_stiffness_message(problem, null)
    assert "menisci.free = []" in text and text.count("menisci.free =") == 1


def test_menisci_held_in_z_and_a_lumped_modulus_are_warned(capsys):
    """1e-9 MPa and 1 MPa give nearly the same lumped interface (the mean with the 20 MPa
    cartilage: 10.0 against 10.5 MPa, -4.8 % stiffness), so the share barely moves."""
    from fecheck.model.menisci import meniscus_stiffness
    from fecheck.scene import load_scene

    scene = load_scene("femur_tibia_menisci", ["menisci.youngs_MPa=1e-9"])
    assert meniscus_stiffness(scene) / meniscus_stiffness(scene, 1.0) == pytest.approx(
        10.0 / 10.5, rel=1e-6)
    assert main(["run", "femur_tibia_menisci", "--set", "menisci.youngs_MPa=1e-9",
                 "--set", "menisci.free=[]", "--set", "scanned.decimate_faces=1500"]) == 0
    err = capsys.readouterr().err
    assert "-4.8 % from the 1 MPa default's" in err and "menisci.layers = 'series'" in err
    assert "menisci.free = [] holds each meniscus's z" in err


# ------------------------------------------------------------------ faces before reading
@pytest.fixture
def small_knee(tmp_path):
    """The tibia of tests/studies/test_knee_import.py's synthetic knee (two dishes, 1,936 faces)
    and the file of one of its femoral caps (968 faces)."""
    from test_knee_import import CENTRES, _merge, femur_cap, tibia_patch, write

    return {"femur": write(tmp_path / "data", "femur.stl", femur_cap("medial")),
            "tibia": _merge([tibia_patch(c) for c in CENTRES])}


@pytest.mark.parametrize("ext, options", [("stl", {}), ("stl", {"binary": False}),
                                          ("obj", {}), ("ply", {}), ("off", {})])
def test_face_count_reads_the_count_without_loading_the_mesh(small_knee, tmp_path, ext,
                                                             options):
    import meshio

    from geometry.io import face_count

    mesh = small_knee["tibia"]
    path = tmp_path / f"tibia.{ext}"
    meshio.write(path, meshio.Mesh(mesh.points, [("triangle", mesh.faces.astype(np.int32))]),
                 **options)
    assert face_count(path) == mesh.n_faces == 1936


def test_knee_import_refuses_a_file_past_the_face_cap_before_reading_it(small_knee, tmp_path,
                                                                       monkeypatch, capsys):
    """With the cap lowered under the tibia's 1,936 faces the import stops before any file
    is read (a 2-million-face sheet took 73-92 s and 18 GB, then a MemoryError)."""
    import fecheck.scene.surfaces
    import fecheck.studies.knee_import as knee_import
    from geometry.io import save_mesh

    def no_read(*args, **kwargs):
        raise AssertionError("a file was read")

    tibia = str(save_mesh(small_knee["tibia"], tmp_path / "data" / "tibia.stl"))
    monkeypatch.setattr(knee_import, "MAX_FACES", 1900)
    monkeypatch.setattr(fecheck.scene.surfaces, "read_surface", no_read)
    assert main(["knee", "import", "--femur", small_knee["femur"], "--tibia", tibia,
                 "-o", str(tmp_path / "k.toml")]) == 2
    line = _error(capsys)
    assert "--tibia" in line and "1,936 faces, more than the 1,900" in line
    assert "decimate it to at most 1,900 faces" in line


def test_knee_import_counts_the_faces_of_a_format_without_a_header_count_once_read(
        small_knee, tmp_path, monkeypatch, capsys):
    import fecheck.studies.knee_import as knee_import
    from geometry.io import face_count, save_mesh

    tibia = save_mesh(small_knee["tibia"], tmp_path / "data" / "tibia.vtu")
    assert face_count(tibia) is None
    monkeypatch.setattr(knee_import, "MAX_FACES", 1900)
    assert main(["knee", "import", "--femur", small_knee["femur"], "--tibia", str(tibia),
                 "-o", str(tmp_path / "k.toml")]) == 2
    assert "1,936 faces, more than the 1,900" in _error(capsys)


def test_fe_auto_prepares_sheets_too_large_as_read_before_the_ef(monkeypatch, capsys):
    """The full-size scanned sheets make 97k + 100k layer dofs as read and 48k + 46k
    prepared at fe.size_mm 1 mm (exact counts, `fecheck.fe.bodies.budget`). Under a cap between
    the two totals, 'auto' prepares both (decided from the counts, so the EF run is not
    wasted on a refusal after it) and the estimate fits; 'off' is refused before the EF."""
    import fecheck.fe.bodies.budget as budget
    import fecheck.fe.knee.crosscheck
    from fecheck.fe.bodies.scene_bodies import scene_bodies
    from fecheck.fe.bodies.settings import FESettings
    from fecheck.scene import load_scene

    def no_work(*args, **kwargs):
        raise AssertionError("the EF run started")

    monkeypatch.setattr(budget, "MAX_DOFS", 150_000)
    scene = load_scene("scanned-knee")
    settings = FESettings.from_scene(scene)
    levels = settings.levels(scene["contact.poisson"])
    bodies = scene_bodies(scene)
    raw = [budget.layer_dofs(b.surface, settings.refine, levels) for b in bodies]
    ready = [budget.sheet_dofs(b.surface, settings, levels, True) for b in bodies]
    assert sum(raw) > 150_000 > sum(ready)
    assert budget.prepared_for_size(bodies, settings, levels) == [True, True]
    assert budget.fe_estimate(bodies, settings.refine, levels, settings).count == sum(ready)
    monkeypatch.setattr(fecheck.fe.knee.crosscheck, "_ef_run", no_work)
    assert main(["fe", "scanned-knee", "--set", "fe.prepare='off'", "--no-estimate"]) == 2
    assert "FE dofs" in _error(capsys)


def test_a_sweep_past_poisson_049_is_refused_before_its_first_point(capsys):
    assert main(["sweep", "--param", "contact.poisson", "--values", "0.3,0.4999"]) == 2
    assert "contact.poisson = 0.4999 with contact.law = 'ef'" in _error(capsys)


def test_a_knee_decimated_to_a_few_faces_is_refused_with_the_floor(capsys):
    """Three tibial faces keep no compartment shape: Newton found no equilibrium (exit 1);
    below 100 faces the scene is refused on one line."""
    assert main(["run", "scanned-knee", "--set", "scanned.decimate_faces=3"]) == 2
    assert "give 0 (the full meshes) or at least 100" in _error(capsys)
