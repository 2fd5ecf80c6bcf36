"""`fecheck mesh`: builds, info table, one-line errors with exit code 2, light imports."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from fecheck.cli import main
from geometry.checks import mesh_report
from geometry.icosphere import icosahedron
from geometry.io import load_mesh, save_mesh
from geometry.mesh import TriMesh

HEAVY = ("gmsh", "pyvista", "skfem", "vtk", "trimesh")


def _imported_modules(args, tmp_path):
    env = dict(os.environ, FECHECK_CACHE_DIR=str(tmp_path / "cache"))
    out = subprocess.run([sys.executable, "-X", "importtime", "-m", "fecheck", *args],
                         capture_output=True, text=True, env=env, check=False)
    assert out.returncode == 0, out.stderr[-2000:]
    names = [line.split("|")[-1].strip() for line in out.stderr.splitlines()
             if line.startswith("import time:") and "|" in line]
    return {n.split(".")[0] for n in names}, out


def test_help_and_mesh_info_do_not_import_heavy_packages(tmp_path):
    mesh_file = tmp_path / "ico.stl"
    save_mesh(TriMesh(*icosahedron()), mesh_file)
    for args in (["--help"], ["mesh", "info", str(mesh_file)]):
        top, _ = _imported_modules(args, tmp_path)
        assert not top & set(HEAVY), (args, top & set(HEAVY))


def test_mesh_icosphere_writes_the_file_then_reuses_the_cache(tmp_path, capsys):
    out = tmp_path / "ico.vtu"
    argv = ["mesh", "icosphere", "--radius", "25.5", "--subdivisions", "3",
            "--center", "-20.4", "12.8", "16.8", "-o", str(out)]
    assert main(argv) == 0
    assert main(argv) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "from cache" in lines[-1]
    m = load_mesh(out)
    assert m.n_faces == 1280
    np.testing.assert_allclose(np.linalg.norm(m.points - [-20.4, 12.8, 16.8], axis=1), 25.5)


@pytest.mark.parametrize("argv, faces", [
    (["cap", "--radius", "10", "--subdivisions", "2", "--cut-point", "0", "0", "0",
      "--cut-normal", "0", "0", "1", "--closed"], None),
    (["plateau", "--kind", "box", "--sagittal", "-3", "--frontal", "-6"], 12),
    (["plateau", "--kind", "patch", "--radius", "10", "--size", "2"], None),
    (["plateau", "--kind", "polynomial", "--coeffs", "[[-8, 0.01], [0.05, 0.002]]",
      "--footprint", "ellipse", "--size", "3"], None),
])
def test_mesh_builders_write_checkable_files(tmp_path, argv, faces):
    out = tmp_path / "m.stl"
    assert main(["mesh", *argv, "--no-cache", "-o", str(out)]) == 0
    r = mesh_report(load_mesh(out))
    assert r.winding_consistent and r.components == 1
    if faces is not None:
        assert r.faces == faces


def test_mesh_layer_writes_a_tet_mesh(tmp_path):
    from geometry.mesh import TetMesh

    out = tmp_path / "layer.vtu"
    assert main(["mesh", "layer", "--half-x", "10", "--half-y", "8", "--thickness", "4",
                 "--size", "4", "-o", str(out)]) == 0
    m = load_mesh(out)
    assert isinstance(m, TetMesh)
    assert m.volume == pytest.approx(20 * 16 * 4, rel=1e-9)


def test_mesh_info_rows_for_the_four_table_3_1_kinds(tmp_path, capsys):
    from test_checks import TABLE_3_1, _meshes

    files = []
    for k, mesh in enumerate(_meshes().values()):
        files.append(tmp_path / f"{k}.stl")
        save_mesh(mesh, files[-1])
    js = tmp_path / "info.json"
    assert main(["mesh", "info", *map(str, files), "--json", str(js)]) == 0
    table = capsys.readouterr().out.splitlines()
    assert len(table) == 5 and "χ" in table[0]
    rows = json.loads(js.read_text())
    for row, kind in zip(rows, TABLE_3_1, strict=True):
        got = (row["euler"], row["winding_consistent"], row["convex"], row["watertight"],
               row["empty"])
        assert got == TABLE_3_1[kind], kind
    added = ("sha256", "provenance")             # the file's hash and the command's
    assert {k: v for k, v in rows[0].items() if k not in added} == mesh_report(
        load_mesh(files[0]), str(files[0])).as_dict()


@pytest.mark.parametrize("ext", [".stl", ".obj", ".vtu", ".vtk", ".msh", ".ply", ".off"])
def test_surface_round_trip_in_every_format(tmp_path, ext):
    from geometry.icosphere import icosphere

    mesh = icosphere(10.0, 2)
    back = load_mesh(save_mesh(mesh, tmp_path / f"m{ext}"))
    assert back.n_faces == mesh.n_faces and back.n_points == mesh.n_points
    # STL stores float32 coordinates; the others keep float64
    tol = 1e-5 if ext == ".stl" else 1e-12
    np.testing.assert_allclose(back.triangles, mesh.triangles, atol=tol)


def test_stl_vertices_are_merged_into_a_connected_surface(tmp_path):
    p, f = icosahedron()
    soup = TriMesh(p[f].reshape(-1, 3), np.arange(60).reshape(20, 3))  # 60 loose vertices
    back = load_mesh(save_mesh(soup, tmp_path / "soup.stl"))
    r = mesh_report(back)
    assert (back.n_points, r.watertight, r.euler, r.components) == (12, True, 2, 1)


def test_tet_mesh_round_trip_keeps_tets(tmp_path):
    from geometry.mesh import TetMesh

    tet = TetMesh(np.vstack([np.zeros(3), np.eye(3)]), np.array([[0, 1, 2, 3]]))
    for ext in (".vtu", ".msh"):
        back = load_mesh(save_mesh(tet, tmp_path / f"t{ext}"))
        assert isinstance(back, TetMesh)
        assert back.volume == pytest.approx(1 / 6)


def _bad_inputs(tmp):
    (tmp / "garbage.stl").write_text("solid nothing here\nfacet normal x y z\n")
    (tmp / "empty.obj").write_text("")
    return [
        ["mesh", "info", str(tmp / "missing.stl")],
        ["mesh", "info", str(tmp / "garbage.stl")],
        ["mesh", "info", str(tmp / "empty.obj")],
        ["mesh", "info", str(tmp / "file.xyz")],
        ["mesh", "icosphere", "--radius", "-1", "--subdivisions", "2", "-o", str(tmp / "a.stl")],
        ["mesh", "icosphere", "--radius", "1", "--subdivisions", "9", "-o", str(tmp / "a.stl")],
        ["mesh", "icosphere", "--radius", "1", "--subdivisions", "-1", "-o", str(tmp / "a.stl")],
        ["mesh", "icosphere", "--radius", "1", "--subdivisions", "2", "-o", str(tmp / "a.xyz")],
        ["mesh", "plateau", "--kind", "polynomial", "-o", str(tmp / "a.stl")],
    ]


def test_bad_inputs_exit_2_with_one_line(tmp_path, capsys):
    for argv in _bad_inputs(tmp_path):
        if argv[-1].endswith(".xyz") and argv[1] == "info":
            (tmp_path / "file.xyz").write_text("1 2 3\n")
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("fecheck: error: "), (argv, err)
