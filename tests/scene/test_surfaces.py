"""Surfaces from a scene's [geometry] files: paths, units, transform, the compartment split,
the femoral orientation check and the on-disk cache (the tibial sheets' winding checks:
tests/cli/test_messages.py)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from fecheck.errors import FecheckError
from fecheck.scene import load_scene, surfaces
from geometry.io import save_mesh
from geometry.mesh import TriMesh
from geometry.plateau import plane_patch

MEDIAL_X, LATERAL_X = -22.0, 22.0


def _patches() -> dict[str, TriMesh]:
    """Two flat tibial patches (normals up), medial at -x (a right knee)."""
    return {c: plane_patch((x, 0.0, 0.0), (0.0, 0.0, 1.0), radius=10.0, size=2.0)
            for c, x in (("medial", MEDIAL_X), ("lateral", LATERAL_X))}


def _joined(parts: list[TriMesh]) -> TriMesh:
    offsets = np.cumsum([0] + [p.n_points for p in parts[:-1]])
    return TriMesh(np.vstack([p.points for p in parts]),
                   np.vstack([p.faces + o for p, o in zip(parts, offsets, strict=True)]))


def _scene(folder, geometry: dict, side: str = "right"):
    lines = ["[model]", 'kind = "femur-tibia"', "[knee]", 'preset = "custom"',
             f'side = "{side}"', "[geometry]"]
    for key, value in geometry.items():
        lines.append(f"{key} = {value!r}" if isinstance(value, str)
                     else f"{key} = {list(value)!r}")
    path = folder / "scene.toml"
    path.write_text("\n".join(lines).replace("'", '"') + "\n")
    return load_scene(path)


@pytest.mark.parametrize("split, side", [("components", "right"), ("sagittal", "right"),
                                         ("components", "left")])
def test_one_tibia_file_splits_into_its_compartments_by_side(tmp_path, split, side):
    patches = _patches()
    save_mesh(_joined([patches["lateral"], patches["medial"]]), tmp_path / "tibia.obj")
    scene = _scene(tmp_path, {"tibia": "tibia.obj", "tibia_split": split}, side)
    comps = surfaces.tibial_compartments(scene)
    x = {c: comps[c].points[:, 0].mean() for c in comps}
    medial, lateral = (MEDIAL_X, LATERAL_X) if side == "right" else (LATERAL_X, MEDIAL_X)
    assert x["medial"] == pytest.approx(medial, abs=0.5)
    assert x["lateral"] == pytest.approx(lateral, abs=0.5)
    assert comps["medial"].n_faces == patches["medial"].n_faces


def test_relative_paths_resolve_against_geometry_dir_then_the_scene_folder(tmp_path):
    patches = _patches()
    (tmp_path / "meshes").mkdir()
    save_mesh(patches["medial"], tmp_path / "meshes" / "m.stl")
    save_mesh(patches["lateral"], tmp_path / "meshes" / "l.stl")
    scene = _scene(tmp_path, {"dir": "meshes", "tibia": "m.stl", "tibia_lateral": "l.stl"})
    assert surfaces.file_path(scene, "tibia") == tmp_path / "meshes" / "m.stl"
    assert surfaces.tibial_compartments(scene)["lateral"].n_faces == patches["lateral"].n_faces
    plain = _scene(tmp_path, {"tibia": "meshes/m.stl"})
    assert surfaces.file_path(plain, "tibia") == tmp_path / "meshes" / "m.stl"


def test_units_and_rigid_transform_bring_a_file_into_the_thesis_frame(tmp_path):
    medial = _patches()["medial"]
    # the file: in metres, rotated 90° about z and shifted; the scene undoes both
    rot = surfaces.rotation_matrix((0.0, 0.0, 90.0))
    shifted = (medial.points @ rot.T + [5.0, 6.0, 7.0]) / 1000.0
    save_mesh(TriMesh(shifted, medial.faces), tmp_path / "m.vtu")
    save_mesh(_patches()["lateral"], tmp_path / "l.stl")
    read = surfaces.read_surface(tmp_path / "m.vtu", "m", (0.0, 0.0, -90.0),
                                 tuple(-np.array([5.0, 6.0, 7.0]) @ rot))
    np.testing.assert_allclose(read.points, medial.points, atol=1e-9)


def test_rotation_matrix_turns_about_x_then_y_then_z():
    r = surfaces.rotation_matrix((90.0, 90.0, 0.0))
    # x-rotation takes e_y to e_z; the y-rotation then takes e_z to e_x
    np.testing.assert_allclose(r @ [0.0, 1.0, 0.0], [1.0, 0.0, 0.0], atol=1e-12)


def test_a_femoral_sheet_facing_up_is_refused(tmp_path):
    sheet = plane_patch((0.0, 0.0, 5.0), (0.0, 0.0, 1.0), radius=30.0, size=3.0)
    save_mesh(sheet, tmp_path / "femur.ply")
    scene = _scene(tmp_path, {"femur": "femur.ply"})
    with pytest.raises(FecheckError, match="femur.ply: its normals point up"):
        surfaces.femoral_surface(scene)


def test_several_pieces_where_one_compartment_is_expected_are_refused(tmp_path):
    patches = _patches()
    save_mesh(_joined([patches["medial"], patches["lateral"]]), tmp_path / "m.stl")
    save_mesh(patches["lateral"], tmp_path / "l.stl")
    scene = _scene(tmp_path, {"tibia": "m.stl", "tibia_lateral": "l.stl"})
    with pytest.raises(FecheckError, match="one compartment per file.*2 separate pieces"):
        surfaces.tibial_compartments(scene)


def test_a_component_split_needs_two_pieces(tmp_path):
    save_mesh(_patches()["medial"], tmp_path / "t.stl")
    scene = _scene(tmp_path, {"tibia": "t.stl"})
    with pytest.raises(FecheckError, match="needs the two compartments as two separate.*"
                                           "set geometry.tibia_split = 'sagittal'"):
        surfaces.tibial_compartments(scene)


def test_missing_and_unset_files_name_the_key(tmp_path):
    scene = _scene(tmp_path, {"tibia": "nowhere.stl"})
    with pytest.raises(FecheckError, match=r"geometry.tibia = 'nowhere.stl': file not found"):
        surfaces.tibial_compartments(scene)
    with pytest.raises(FecheckError, match="needs geometry.femur"):
        surfaces.femoral_surface(scene)


def test_a_second_read_comes_from_the_cache_and_a_changed_file_is_read_again(tmp_path):
    patches = _patches()
    path = tmp_path / "m.stl"
    save_mesh(patches["medial"], path)
    first = surfaces.read_surface(path)
    assert surfaces.read_surface(path) is first            # kept in this process
    # a second run (another process, same cache folder) reads the disk cache, not the file
    code = ("from geometry import cache; from fecheck.scene.surfaces import read_surface; "
            f"m = read_surface({str(path)!r}); print(cache.STATS.hits, cache.STATS.builds); "
            "print(repr(m.points.tolist()))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.splitlines()
    assert out[0] == "1 0"
    np.testing.assert_array_equal(np.array(eval(out[1])), first.points)
    save_mesh(patches["lateral"], path)                      # new content, same name
    changed = surfaces.read_surface(path)
    assert changed.points[:, 0].mean() == pytest.approx(LATERAL_X, abs=0.5)


def test_a_femur_tibia_knee_takes_its_side_without_a_custom_preset(tmp_path, recwarn):
    patches = _patches()
    save_mesh(_joined([patches["medial"], patches["lateral"]]), tmp_path / "tibia.stl")
    path = tmp_path / "left.toml"
    path.write_text('[model]\nkind = "femur-tibia"\n[knee]\nside = "left"\n'
                    '[geometry]\ntibia = "tibia.stl"\n')
    comps = surfaces.tibial_compartments(load_scene(path))
    assert comps["medial"].points[:, 0].mean() == pytest.approx(LATERAL_X, abs=0.5)
    assert not [w for w in recwarn if "knee.side" in str(w.message)]
