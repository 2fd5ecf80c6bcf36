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


def test_mesh_info_table_and_json(tmp_path, capsys):
    files = []
    for k, pts in enumerate((icosahedron()[0], icosahedron()[0] * 2)):
        files.append(tmp_path / f"m{k}.obj")
        save_mesh(TriMesh(pts, icosahedron()[1]), files[-1])
    js = tmp_path / "info.json"
    assert main(["mesh", "info", *map(str, files), "--json", str(js)]) == 0
    table = capsys.readouterr().out.splitlines()
    assert len(table) == 3 and "χ" in table[0]
    rows = json.loads(js.read_text())
    assert [r["faces"] for r in rows] == [20, 20]
    assert rows[1]["volume_mm3"] == pytest.approx(8 * rows[0]["volume_mm3"])
    assert rows[0] == mesh_report(load_mesh(files[0]), str(files[0])).as_dict()


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
