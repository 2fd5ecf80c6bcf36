"""`fecheck knee import`: surface files in, a checked, documented femur-tibia scene out.

The synthetic knee is built here: two spherical femoral caps (R 20 mm, one open sheet of
two pieces, normals down) over two shallow dishes (R 100 mm, normals up), a right knee
(medial at -x), the medial cap touching at rest and the lateral one 0.1 mm off. Units mm.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import tomllib
from conftest import REPO, require_knee_data

from fecheck.cli import main
from fecheck.model.run import run_scene
from fecheck.scene import load_scene
from fecheck.scene.document import toml_value
from fecheck.scene.schema import SCHEMA
from geometry.io import load_mesh, save_mesh
from geometry.mesh import TriMesh

CONDYLE_R_MM, DISH_R_MM, HALF_MM, STEP_MM = 20.0, 100.0, 11.0, 1.0
CENTRES = {"medial": (-20.0, 0.0), "lateral": (20.0, 1.0)}
GAPS_MM = {"medial": 0.0, "lateral": 0.1}
LOAD_N = 800.0


def _grid(cx: float, cy: float, height, shift: float = 0.0) -> TriMesh:
    """A square grid around (cx, cy), z = height(dx, dy), faces counter-clockwise from +z."""
    u = np.arange(-HALF_MM, HALF_MM + 1e-9, STEP_MM) + shift
    n = len(u)
    dx, dy = (a.ravel() for a in np.meshgrid(u, u, indexing="ij"))
    i, j = (a.ravel() for a in np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij"))
    p = i * n + j
    faces = np.concatenate([np.stack([p, p + n, p + n + 1], 1), np.stack([p, p + n + 1, p + 1], 1)])
    return TriMesh(np.column_stack([cx + dx, cy + dy, height(dx, dy)]), faces)


def _merge(meshes: list[TriMesh]) -> TriMesh:
    offset = np.cumsum([0] + [m.n_points for m in meshes[:-1]])
    return TriMesh(np.concatenate([m.points for m in meshes]),
                   np.concatenate([m.faces + o for m, o in zip(meshes, offset, strict=True)]))


def femur_cap(c: str) -> TriMesh:
    """The lower cap of a condyle sphere (lowest point z = its rest gap), normals down."""
    cap = _grid(*CENTRES[c], lambda dx, dy: GAPS_MM[c] + CONDYLE_R_MM
                - np.sqrt(CONDYLE_R_MM ** 2 - dx ** 2 - dy ** 2), shift=STEP_MM / 3)
    return TriMesh(cap.points, cap.faces[:, ::-1])


def tibia_patch(c: str, lift_mm: float = 0.0) -> TriMesh:
    """A shallow dish (lowest point z = `lift_mm`), normals up."""
    return _grid(*CENTRES[c], lambda dx, dy: lift_mm + (dx ** 2 + dy ** 2) / (2 * DISH_R_MM))


def write(folder: Path, name: str, mesh: TriMesh, scale: float = 1.0) -> str:
    return str(save_mesh(TriMesh(mesh.points * scale, mesh.faces), folder / name))


@pytest.fixture
def knee(tmp_path) -> dict[str, str]:
    """Files of the synthetic knee (mm): femur, the whole tibia, each compartment."""
    data = tmp_path / "data"
    return {"femur": write(data, "femur.stl", _merge([femur_cap(c) for c in CENTRES])),
            "tibia": write(data, "tibia.stl", _merge([tibia_patch(c) for c in CENTRES])),
            "medial": write(data, "medial.stl", tibia_patch("medial")),
            "lateral": write(data, "lateral.stl", tibia_patch("lateral"))}


def _import(femur: str, tibia: str, out: Path, *extra: str) -> int:
    return main(["knee", "import", "--femur", femur, "--tibia", tibia, *extra, "-o", str(out)])


def _assert_runs(scene_path: Path) -> None:
    """The scene converges and its compartments carry the load along z."""
    result = run_scene(load_scene(scene_path))
    assert result.converged
    comps = result.compartments.values()
    assert sum(-c.force_vector_N[2] for c in comps) == pytest.approx(LOAD_N, rel=1e-6)
    assert sum(c.axial_force_N for c in comps) == pytest.approx(LOAD_N, rel=1e-3)
    assert all(c.force_N > 50.0 for c in comps)          # both compartments in contact


def test_import_writes_a_documented_scene_that_runs(knee, tmp_path, capsys):
    out = tmp_path / "scenes" / "knee.toml"
    assert _import(knee["femur"], knee["tibia"], out) == 0
    printed = capsys.readouterr().out
    for word in ("units", "closure", "components", "normals", "split", "rest gap",
                 "within 1 mm", str(out.with_name("knee_preview.png"))):
        assert word in printed, word
    text = out.read_text()
    data = tomllib.loads(text)
    assert data["model"]["kind"] == "femur-tibia" and data["gravity"] is False
    assert data["geometry"]["tibia"] == "../data/tibia.stl"       # relative to the scene
    assert data["geometry"]["tibia_split"] == "components"
    assert data["scanned"]["thickness"] == "uniform" and data["contact"]["thickness_mm"] == 6
    assert data["load"]["point_mm"][2] == -300.0 and data["dofs"]["free"] == ["z", "abduction"]
    assert "UHMWPE" in text and "460" in text and "ankle" in text and text.count("\n# ") > 15
    assert out.with_name("knee_preview.png").stat().st_size > 20_000
    _assert_runs(out)


def test_per_compartment_files_and_a_sagittal_split_agree(knee, tmp_path):
    files, plane = tmp_path / "files.toml", tmp_path / "plane.toml"
    assert _import(knee["femur"], knee["medial"], files, "--tibia-lateral",
                   knee["lateral"]) == 0
    assert _import(knee["femur"], knee["tibia"], plane, "--split-x", "0") == 0
    a, b = (run_scene(load_scene(p)).compartments for p in (files, plane))
    for c in ("medial", "lateral"):
        assert a[c].force_N == pytest.approx(b[c].force_N, rel=1e-9)


def test_metre_files_need_units_m(knee, tmp_path, capsys):
    data = tmp_path / "metres"
    femur = write(data, "femur.stl", _merge([femur_cap(c) for c in CENTRES]), 1e-3)
    tibia = write(data, "tibia.stl", _merge([tibia_patch(c) for c in CENTRES]), 1e-3)
    out = tmp_path / "m.toml"
    assert _import(femur, tibia, out) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "metres" in err and "--units m" in err and not out.exists()
    assert _import(femur, tibia, out, "--units", "m") == 0
    assert tomllib.loads(out.read_text())["geometry"]["units"] == "m"
    _assert_runs(out)


def test_inverted_tibia_is_repaired_with_a_note(knee, tmp_path, capsys):
    whole = _merge([tibia_patch(c) for c in CENTRES])
    tibia = write(tmp_path, "inverted.stl", TriMesh(whole.points, whole.faces[:, ::-1]))
    out = tmp_path / "out" / "flip.toml"
    assert _import(knee["femur"], tibia, out) == 0
    printed = capsys.readouterr().out
    fixed = out.with_name("flip_tibia_fixed.stl")
    assert "note:" in printed and "inverted" in printed and str(fixed) in printed
    assert tomllib.loads(out.read_text())["geometry"]["tibia"] == fixed.name
    _assert_runs(out)


@pytest.mark.parametrize("case, words", [
    ("two-pieces", ("--tibia", "one compartment per file", "2 separate pieces")),
    ("overlap", ("overlaps", "by 4.9", "frame/rest pose")),
    ("far", ("10 mm", "different frames or units")),
    ("nan", ("NaN",)),
    ("degenerate", ("zero area",)),
    ("garbage", ("cannot read",)),
])
def test_bad_input_is_refused_on_one_line(knee, tmp_path, capsys, case, words):
    extra: list[str] = []
    tibia = knee["tibia"]
    if case == "two-pieces":                  # a per-compartment file holding both
        extra = ["--tibia-lateral", knee["lateral"]]
    elif case in ("overlap", "far"):
        lift = 5.0 if case == "overlap" else -12.0
        tibia = write(tmp_path, "moved.stl", _merge([tibia_patch(c, lift) for c in CENTRES]))
    elif case == "garbage":
        tibia = tmp_path / "garbage.stl"
        tibia.write_text("solid x\n this is not a mesh\n")
    else:
        v = "nan 0 0" if case == "nan" else "1 1 0"
        tibia = tmp_path / f"{case}.stl"
        tibia.write_text("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 40 0 0\n"
                         "vertex 0 40 0\nendloop\nendfacet\nfacet normal 0 0 1\nouter loop\n"
                         f"vertex 0 0 0\nvertex 2 2 0\nvertex {v}\nendloop\nendfacet\n"
                         "endsolid x\n")
    out = tmp_path / "bad.toml"
    assert _import(knee["femur"], str(tibia), out, *extra) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("fecheck: error:") and "\n" not in err
    for word in words:
        assert word in err, (word, err)
    assert not out.exists()


def test_shipped_knee_reproduces_the_validation_scene(tmp_path, capsys):
    data = require_knee_data()
    out = tmp_path / "lenhart.toml"
    # the whole tibial sheet in one file (split by its connected pieces): the two halves
    halves = [load_mesh(data / f"lenhart2015_R_tibia_cartilage_{c}.stl")
              for c in ("medial", "lateral")]
    whole = TriMesh(np.vstack([m.points for m in halves]),
                    np.vstack([halves[0].faces, halves[1].faces + halves[0].n_points]))
    save_mesh(whole, tmp_path / "lenhart2015_R_tibia_cartilage.stl")
    files = {"--femur": data / "lenhart2015_R_femur_cartilage.stl",
             "--tibia": tmp_path / "lenhart2015_R_tibia_cartilage.stl",
             "--femur-bone": data / "lenhart2015_R_femur_bone_distal60.stl",
             "--tibia-bone": data / "lenhart2015_R_tibia_bone_proximal40.stl"}
    args = [a for opt, f in files.items() for a in (opt, str(f))]
    assert main(["knee", "import", *args, "-o", str(out)]) == 0
    shipped = load_scene(REPO / "validation" / "scenes" / "femur_tibia.toml",
                         [f"geometry.dir={toml_value(str(data))}"])
    # the same load: the shipped scene's ankle point and shank weight (the import leaves
    # the weight out and puts the load 300 mm below the plateau)
    same = [f"{k}={toml_value(shipped[k])}" for k in
            ("gravity", "tibia.mass_kg", "tibia.com_mm", "load.point_mm")]
    mine = load_scene(out, same)
    differ = {k for k in SCHEMA if mine[k] != shipped[k]}
    assert differ <= {"name", "geometry.dir", "geometry.tibia", "geometry.tibia_lateral",
                      "geometry.femur", "geometry.femur_bone", "geometry.tibia_bone"}, differ
    a, b = run_scene(shipped), run_scene(mine)
    assert a.converged and b.converged
    for c in ("medial", "lateral"):
        for metric in ("force_N", "axial_force_N", "area_mm2", "max_pressure_MPa"):
            assert getattr(b.compartments[c], metric) == pytest.approx(
                getattr(a.compartments[c], metric), rel=1e-6), (c, metric)


# ------------------------------------------------------------------ defects (issue 26)
def _err(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert err.startswith("fecheck: error:") and "\n" not in err, err
    return err


def test_the_same_file_for_both_compartments_is_refused(knee, tmp_path, capsys):
    copy = write(tmp_path, "copy.stl", tibia_patch("medial"))      # same surface, other path
    for lateral in (knee["medial"], copy):
        out = tmp_path / "same.toml"
        assert _import(knee["femur"], knee["medial"], out, "--tibia-lateral", lateral) == 2
        err = _err(capsys)
        assert "same surface" in err and knee["medial"] in err and lateral in err
        assert "--tibia-lateral" in err and "--split" in err and not out.exists()


def test_a_scene_naming_one_file_for_both_compartments_is_refused(knee, tmp_path):
    from fecheck.errors import FecheckError
    from fecheck.scene import surfaces

    out = tmp_path / "files.toml"
    assert _import(knee["femur"], knee["medial"], out, "--tibia-lateral", knee["lateral"]) == 0
    scene = load_scene(out, [f"geometry.tibia_lateral={toml_value(knee['medial'])}"])
    with pytest.raises(FecheckError, match="geometry.tibia and geometry.tibia_lateral name "
                                           "the same surface .medial.stl, medial.stl.; give"):
        surfaces.tibial_compartments(scene)


@pytest.mark.parametrize("x_mm", [30.0, 15.0])
def test_a_sagittal_plane_through_a_plateau_is_refused(knee, tmp_path, capsys, x_mm):
    # the lateral plateau and its condyle span x = 9..31 mm: at 30 mm 21/22 of the plateau
    # falls on the medial side, at 15 mm 6/22 (27 % of the lateral, 14 % of both)
    out = tmp_path / "plane.toml"
    assert _import(knee["femur"], knee["tibia"], out, "--split-x", str(x_mm)) == 2
    err = _err(capsys)
    assert f"--tibia {knee['tibia']}: the plane x = {x_mm:g} mm" in err and "cuts a plateau" in err
    share = float(err.split(" puts ")[1].split("%")[0]) / 100
    expected = (21 if x_mm == 30 else 6) / 22 / 2         # of the tibial area of both plateaus
    assert share == pytest.approx(expected, abs=0.04)
    gap = float(err.split("--split-x ")[1].split(" ")[0])
    assert -9.0 < gap < 9.0                               # between the plateaus (|x| > 9 mm)
    assert _import(knee["femur"], knee["tibia"], out, "--split-x", f"{gap:g}") == 0


def test_a_one_piece_tibia_names_the_sagittal_split(knee, tmp_path, capsys):
    # one sheet under both condyles: two dishes (lowest at x = ±20 mm) joined at x = 0
    sheet = _grid(0.0, 0.5, lambda dx, dy: ((3.0 * np.abs(dx) - 20.0) ** 2 + dy ** 2)
                  / (2 * DISH_R_MM))
    wide = TriMesh(sheet.points * [3.0, 1.0, 1.0], sheet.faces)   # x from -33 to 33 mm
    tibia = write(tmp_path, "one_piece.stl", wide)
    out = tmp_path / "one.toml"
    assert _import(knee["femur"], tibia, out) == 2
    err = _err(capsys)
    assert tibia in err and "1 (" in err and "--split sagittal --split-x " in err
    gap = float(err.split("--split-x ")[1].split(" ")[0])
    assert abs(gap) < 9.0


@pytest.mark.parametrize("defect, words", [
    ("duplicate", ("50 of 1986 faces repeat the three vertices", "Remove Duplicate Faces")),
    ("non-manifold", ("1 edges are shared by three or more faces", "around (-", "Non Manifold")),
])
def test_duplicate_faces_and_non_manifold_edges_are_refused(knee, tmp_path, capsys, defect,
                                                            words):
    whole = _merge([tibia_patch(c) for c in CENTRES])
    if defect == "duplicate":
        bad = TriMesh(whole.points, np.concatenate([whole.faces, whole.faces[:50]]))
    else:                                  # a fin standing on an inner edge of the medial patch
        edge = whole.faces[300, :2]
        points = np.vstack([whole.points, whole.points[edge].mean(axis=0) + [0.0, 0.3, 0.8]])
        bad = TriMesh(points, np.vstack([whole.faces, [*edge, len(points) - 1]]))
    tibia = write(tmp_path, f"{defect}.stl", bad)
    out = tmp_path / "bad.toml"
    assert _import(knee["femur"], tibia, out) == 2
    err = _err(capsys)
    assert f"--tibia: {tibia}:" in err and "nan" not in err and "export it again" in err
    for word in words:
        assert word in err, (word, err)
    # the run reads the file the same way: the same error, not a warning or a wrong force
    good = tmp_path / "good.toml"
    assert _import(knee["femur"], knee["tibia"], good) == 0
    capsys.readouterr()
    assert main(["run", str(good), "--set", f"geometry.tibia={toml_value(tibia)}"]) == 2
    assert words[0] in _err(capsys)


def _curled(c: str, curl_mm: float = 1.0) -> TriMesh:
    """The tibial dish of compartment `c` whose rim at +x (dx > 8 mm) curls down over a
    cylinder of radius `curl_mm`, turning up to 3 rad: the faces past π/2 face down."""
    patch = tibia_patch(c)
    dx = patch.points[:, 0] - CENTRES[c][0]
    out = dx > 8.0
    theta = (dx[out] - 8.0) / curl_mm
    p = patch.points.copy()
    edge_z = 64.0 / (2 * DISH_R_MM) + (p[out, 1] - CENTRES[c][1]) ** 2 / (2 * DISH_R_MM)
    p[out, 0] = CENTRES[c][0] + 8.0 + curl_mm * np.sin(theta)
    p[out, 2] = edge_z - curl_mm * (1.0 - np.cos(theta))
    return TriMesh(p, patch.faces)


def test_fe_checks_warn_of_curl_inversion_and_slivers(knee, tmp_path, capsys):
    sliver = tibia_patch("medial")
    p = sliver.points.copy()
    i = int(np.argmin(np.linalg.norm(p[:, :2] - [-25.0, 3.0], axis=1)))     # inner vertex
    j = int(np.argmin(np.linalg.norm(p[:, :2] - [-24.0, 3.0], axis=1)))     # its neighbour
    p[i] += 0.96 * (p[j] - p[i]) + [0.0, 0.02, 0.0]    # 0.04 mm from it, faces not flat
    medial = write(tmp_path, "sliver.stl", TriMesh(p, sliver.faces))
    lateral = write(tmp_path, "curled.stl", _curled("lateral"))
    out = tmp_path / "fe.toml"
    assert _import(knee["femur"], medial, out, "--tibia-lateral", lateral) == 0
    captured = capsys.readouterr()
    lines = [w for w in captured.err.splitlines() if w.startswith("fecheck: warning:")]
    rough = [w for w in lines if "it is rough" in w]         # the curl is rough; a sliver not
    assert len(rough) == 1 and "curled.stl" in rough[0] and "geometry.smooth_mm" in rough[0]
    lines = [w for w in lines if w not in rough]
    curl = [w for w in lines if "curled.stl" in w]
    slivers = [w for w in lines if "sliver.stl" in w]
    assert len(curl) == 1 and len(slivers) == 1, lines
    down, = curl
    # the curl inverts the layer as read, and the FE meshes a prepared copy instead
    # (tests/studies/test_real_data_inputs.py checks that it does)
    prepared = [o for o in captured.out.splitlines() if o.startswith("lateral       FE layer")]
    assert len(prepared) == 1 and "invert as read" in prepared[0]
    assert "mesh a prepared copy" in prepared[0] and prepared[0].endswith("extrudes: ok")
    # the faces past π/2 of the curl: x = 20 + 8 + sin(θ) mm, θ from π/2 to 3 rad
    assert "faces face down" in down and "trim them" in down
    x_down = float(down.split("around (")[1].split(",")[0])
    assert 28.0 < x_down < 29.1
    assert "the medial tibial sheet (sliver.stl)" in slivers[0]
    assert "sliver faces" in slivers[0] and "scanned.decimate_faces" in slivers[0]
    x, y = (float(v) for v in slivers[0].split("around (")[1].split(",")[:2])
    assert (x, y) == pytest.approx((-24.0, 3.0), abs=1.0)
    assert "medial        FE layer" not in captured.out


def test_a_clean_knee_passes_the_fe_checks(knee, tmp_path, capsys):
    assert _import(knee["femur"], knee["tibia"], tmp_path / "ok.toml") == 0
    captured = capsys.readouterr()
    assert captured.out.count("FE layer    6.00 mm layer (median) extrudes") == 2
    assert "warning" not in captured.err
