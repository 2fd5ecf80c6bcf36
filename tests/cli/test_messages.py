"""Messages name the real cause: wrong units, flipped or mixed winding, meshes in metres or
far from their landmarks, truncated mesh files, FE settings out of range, bad output
paths.

Every case runs through `fecheck.cli.main` as a user would: one line on standard error,
a non-zero exit code where the run cannot be trusted, no traceback. The mesh cases use a
synthetic knee folder (a sphere-tibia scene of the baseline knee: a flat tibial sheet
under each condyle sphere), so they need no scanned data.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import fecheck.cli
from fecheck.cli import main
from fecheck.scene import load_scene
from geometry.io import save_mesh
from geometry.mesh import TriMesh
from geometry.plateau import plane_patch


@pytest.fixture(autouse=True)
def _fresh_warnings(monkeypatch):
    """Each test sees every warning the CLI prints (it prints a warning once a process)."""
    monkeypatch.setattr(fecheck.cli, "_shown", set())


def _run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return code, out, err


def _error_line(err: str) -> str:
    """The one error line of standard error."""
    lines = [line for line in err.splitlines() if line.startswith("fecheck: error:")]
    assert len(lines) == 1, err
    return lines[0]


# ----------------------------------------------------------------------- units
def test_pascals_typed_as_megapascals_is_an_error_before_the_solve(capsys):
    code, out, err = _run(capsys, "run", "--set", "contact.youngs_MPa=20e6")
    assert code == 2
    assert "max pressure MPa" not in out                 # no table of 4,263 MPa
    line = _error_line(err)
    assert "contact.youngs_MPa = 2e+07 MPa" in line and "Pa typed as MPa" in line
    assert "max pressure" not in line                    # refused before, not after, the solve


def test_a_load_in_kilonewtons_typed_as_newtons_warns_with_gravity_off(capsys):
    code, out, err = _run(capsys, "run", "--set", "load.force_N=0.8", "--set", "gravity=false")
    assert code == 0 and "converged: True" in out        # a valid, if odd, problem: solved
    warning = [w for w in err.splitlines() if w.startswith("fecheck: warning:")]
    assert warning == ["fecheck: warning: load.force_N = 0.8 N is below any knee load "
                       "(10 N-10 kN): kN typed as N? (0.8 kN = 800 N)"]


def test_a_zero_load_without_gravity_says_no_contact_not_no_equilibrium(capsys):
    code, _, err = _run(capsys, "run", "--set", "load.force_N=0", "--set", "gravity=false")
    line = _error_line(err)
    assert code == 2 and "the equilibrium is no contact" in line
    assert "within 1 m" not in line


def test_load_below_the_tibia_weight_says_so_in_the_no_equilibrium_error(capsys):
    code, _, err = _run(capsys, "run", "--set", "load.force_N=0.8")
    assert code == 2
    line = _error_line(err)
    assert "no equilibrium" in line
    assert "tibia's weight 19.62 N" in line and "kN typed as N" in line


# ----------------------------------------------------------------------- meshes
def _sheets() -> dict[str, TriMesh]:
    """A flat tibial sheet (disc, 14 mm) under each baseline condyle, normals up."""
    knee = load_scene().knee
    out = {}
    for c in ("medial", "lateral"):
        foot = knee.condyle_center[c] - knee.radius_mm(c) * np.array([0.0, 0.0, 1.0])
        out[c] = plane_patch(foot, (0.0, 0.0, 1.0), radius=14.0, size=1.0)
    return out


SHEET = "tibia_{}.stl"
"""File name of each compartment's tibial sheet in a synthetic knee folder."""


def _knee_folder(folder: Path, change=lambda c, m: m) -> Path:
    """A folder holding the two tibial sheets under the baseline condyles, each passed
    through `change(compartment, mesh)` first."""
    folder.mkdir(parents=True, exist_ok=True)
    for c, mesh in _sheets().items():
        save_mesh(change(c, mesh), folder / SHEET.format(c))
    return folder


def _run_folder(capsys, folder: Path) -> tuple[int, str, str]:
    return _run(capsys, "run", "--set", "model.kind='sphere-tibia'",
                "--set", f"geometry.dir='{folder}'",
                "--set", f"geometry.tibia='{SHEET.format('medial')}'",
                "--set", f"geometry.tibia_lateral='{SHEET.format('lateral')}'",
                "--set", "scanned.thickness='uniform'")


def test_the_synthetic_knee_folder_runs_clean(tmp_path, capsys):
    code, out, err = _run_folder(capsys, _knee_folder(tmp_path / "clean"))
    assert code == 0 and "converged: True" in out
    assert "warning" not in err


def _flipped(c, m):
    return TriMesh(m.points, m.faces[:, ::-1])


def _mixed(c, m):
    faces = m.faces.copy()
    half = m.face_centroids[:, 0] > np.median(m.face_centroids[:, 0])
    faces[half] = faces[half][:, ::-1]
    return TriMesh(m.points, faces)


def _metres(c, m):
    return TriMesh(m.points * 1e-3, m.faces)


def _far_below(c, m):
    return TriMesh(m.points + np.array([0.0, 0.0, -100.0]), m.faces)


def _far_aside(c, m):
    return TriMesh(m.points + np.array([100.0, 0.0, 0.0]), m.faces)


FAR_WORDS = ["medial: the condyle sphere is", "mm from the tibial sheet", "landmarks",
             "do not match the meshes"]


@pytest.mark.parametrize("change, words", [
    (_flipped, ["medial tibial contact sheet", "normals point down", "winding is inverted"]),
    (_mixed, ["medial tibial contact sheet", "mixed winding", "face down", "(x, y)"]),
    (_metres, ["tibia_medial.stl", "0.0396 mm across", "looks like metres",
               "geometry.units = 'm'"]),
    (_far_below, FAR_WORDS),
    (_far_aside, FAR_WORDS),
], ids=["flipped", "mixed", "metres", "100-mm-below", "100-mm-aside"])
def test_mesh_defects_are_named_before_the_solve(tmp_path, capsys, change, words):
    code, out, err = _run_folder(capsys, _knee_folder(tmp_path / "knee", change))
    assert code == 2 and "converged" not in out
    line = _error_line(err)
    assert all(w in line for w in words), line
    for misleading in ("no equilibrium", "max_iterations", "load direction"):
        assert misleading not in line


def test_compartment_files_swapped_for_the_knee_side_are_named(tmp_path, capsys):
    folder = _knee_folder(tmp_path / "knee")
    code, out, err = _run(capsys, "run", "--set", "model.kind='sphere-tibia'",
                          "--set", f"geometry.dir='{folder}'",
                          "--set", f"geometry.tibia='{SHEET.format('lateral')}'",
                          "--set", f"geometry.tibia_lateral='{SHEET.format('medial')}'",
                          "--set", "scanned.thickness='uniform'")
    assert code == 2 and "converged" not in out
    line = _error_line(err)
    # the discs are centred under the baseline condyles: medial x = -20.4, lateral +28.3 mm
    assert ("knee.side = 'right' puts the medial compartment at -x, but the medial tibial "
            "sheet is centred at x = +28.3 mm and the lateral at -20.4 mm, as in a left knee"
            in line), line
    assert "swap the files geometry.tibia and geometry.tibia_lateral" in line


def _femur_tibia_scene(folder: Path, side: str) -> Path:
    """A femur-tibia scene (no landmark: knee.side names the compartments) of the
    synthetic folder: one tibial sheet per file, a flat femoral sheet above them."""
    femur = plane_patch((4.0, 12.8, -7.0), (0.0, 0.0, 1.0), radius=40.0, size=4.0)
    save_mesh(TriMesh(femur.points, femur.faces[:, ::-1]), folder / "femur.stl")
    path = folder / f"{side}.toml"
    path.write_text(f'[model]\nkind = "femur-tibia"\n[knee]\npreset = "custom"\n'
                    f'side = "{side}"\n[scanned]\nthickness = "uniform"\n[geometry]\n'
                    f'femur = "femur.stl"\ntibia = "{SHEET.format("medial")}"\n'
                    f'tibia_lateral = "{SHEET.format("lateral")}"\n')
    return path


def test_a_left_side_in_a_right_knees_scene_is_an_error_not_ignored(tmp_path, capsys):
    folder = _knee_folder(tmp_path / "knee")
    code, _, err = _run(capsys, "run", str(_femur_tibia_scene(folder, "left")))
    line = _error_line(err)
    assert code == 2 and "knee.side = 'left' puts the medial compartment at +x" in line
    assert "as in a right knee: set knee.side = 'right'" in line
    code, out, _ = _run(capsys, "run", str(_femur_tibia_scene(folder, "right")))
    assert code == 0 and "converged: True" in out       # the same knee, its own side


def test_mesh_100_mm_away_says_the_distance(tmp_path, capsys):
    _, _, err = _run_folder(capsys, _knee_folder(tmp_path / "knee", _far_below))
    distance = float(_error_line(err).split(" is ")[1].split(" mm")[0])
    assert distance == pytest.approx(100.0, abs=0.05)    # straight below the sphere


def _folded(c, m):
    """The sheet's front part (y > y0 + 4 mm) folded back over it, 10° above."""
    p = m.points.copy()
    y0 = float(np.median(p[:, 1])) + 4.0
    flap = p[:, 1] > y0
    u = p[flap, 1] - y0
    p[flap, 1] = y0 - u * np.cos(np.radians(10.0))
    p[flap, 2] += u * np.sin(np.radians(10.0)) + 0.3
    return TriMesh(p, m.faces)


def test_a_folded_tibial_sheet_is_warned_with_the_count_and_place(tmp_path, capsys):
    _, _, err = _run_folder(capsys, _knee_folder(tmp_path / "knee", _folded))
    warning = [w for w in err.splitlines() if "folds back over itself" in w]
    assert len(warning) == 2                             # one per compartment
    assert "faces turn more than 120°" in warning[0] and "(x, y) = (" in warning[0]
    count = int(warning[0].split("itself: ")[1].split(" of ")[0])
    assert count > 100


def test_a_truncated_binary_stl_is_one_line_naming_the_file(tmp_path, capsys):
    folder = _knee_folder(tmp_path / "knee")
    path = folder / SHEET.format("medial")
    data = path.read_bytes()
    path.write_bytes(data[:len(data) // 2])
    code, _, err = _run_folder(capsys, folder)
    assert code == 2
    line = _error_line(err)
    assert str(path) in line and "truncated" in line and "triangles" in line


def test_mesh_info_names_a_truncated_stl_too(tmp_path, capsys):
    import trimesh

    path = tmp_path / "cut.stl"
    trimesh.creation.icosphere(subdivisions=2, radius=20.0).export(path)
    path.write_bytes(path.read_bytes()[:-7])
    code, _, err = _run(capsys, "mesh", "info", str(path))
    assert code == 2 and "binary STL truncated" in _error_line(err)


# ----------------------------------------------------------------------- FE
@pytest.mark.parametrize("args, words", [
    (["--refine", "9"], "fe.refine must be 0 to 4 subdivisions, got 9"),
    (["--set", "fe.layers=-1"], "fe.layers = -1 is out of range"),
], ids=["refine", "layers"])
def test_fe_settings_out_of_range_are_refused_before_any_work(capsys, args, words):
    code, _, err = _run(capsys, "fe", *args)
    assert code == 2
    assert words in _error_line(err)
    assert "EF equilibrium" not in err                        # no work began


def test_fe_shows_each_step_on_stderr(capsys):
    # a 2 mm plateau mesh: two layers of ~9k dofs, a few seconds
    code, _, err = _run(capsys, "fe", "--set", "mesh.plateau_refine_mm=2")
    assert code == 0
    steps = ["solving the EF equilibrium", "medial: layer of", "quadratic tetrahedra",
             "lateral: layer of", "FE medial: factorizing", "contact candidates",
             "FE lateral: factorizing", "FE pose update 1:", "vertices in contact"]
    where = [err.find(s) for s in steps]
    assert -1 not in where and where == sorted(where), err


# ----------------------------------------------------------------------- outputs
@pytest.mark.parametrize("args", [
    ["bench", "--json", "/proc/x.json"],
    ["bench", "detection", "--json", "/proc/x.json"],
    ["stress", "--json", "/proc/x.json"],
    ["mesh", "icosphere", "--radius", "10", "--subdivisions", "1", "-o", "/proc/x.stl"],
    ["validate", "--out", "/proc", "--only", "rigid"],      # a folder that exists
], ids=["bench", "bench-detection", "stress", "mesh", "validate"])
def test_an_unwritable_output_is_one_line_before_the_work(capsys, args):
    from geometry.cache import STATS

    meshes = (STATS.builds, STATS.hits)
    code, out, err = _run(capsys, *args)
    assert code == 2
    assert err.strip() == _error_line(err)              # no progress: nothing ran first
    assert "/proc" in err and out == ""
    assert (STATS.builds, STATS.hits) == meshes          # no mesh built or read


def test_json_dash_goes_to_standard_output_not_a_file(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, out, err = _run(capsys, "stress", "--only", "E nan", "--json", "-")
    assert code == 0
    doc = json.loads(out)                               # standard output is the JSON only
    assert doc["summary"]["clear-error"] == 1 and "E nan" in err
    assert not (tmp_path / "-").exists()
