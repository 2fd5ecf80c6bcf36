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
