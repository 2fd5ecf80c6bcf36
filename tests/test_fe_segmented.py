"""`fecheck fe` on a knee that looks like a segmentation (`knee_voxel`: the smooth
`knee_synthetic` knee voxelized at 0.6 mm and taken back by marching cubes): the raw
sheets do not extrude, the prepared ones do (``fe.prepare``), and the FE answer is close
to the FE of the smooth knee they were voxelized from."""

from __future__ import annotations

import contextlib
import io

import numpy as np
import pytest
from knee_synthetic import (
    CONDYLES,
    PATCH_HALF_MM,
    femur_mesh,
    tibia_compartment,
    tibia_mesh,
    write_mesh,
)
from knee_voxel import voxel_knee, write_voxel_knee

from fecheck.cli import main as cli
from fecheck.errors import FecheckError
from fecheck.fe.bodies import FEBody
from fecheck.fe.crosscheck import cross_check
from fecheck.fe.indenter import MeshIndenter
from fecheck.fe.press import build_layers
from fecheck.fe.settings import FESettings
from fecheck.scene import load_scene
from geometry.mesh import TriMesh

SPACING_MM = 0.6
SIZE_MM = 2.0
"""The FE element size of the end-to-end test (the default, 1 mm, takes 4 times longer)."""


def _medial(mesh: TriMesh) -> TriMesh:
    keep = mesh.points[:, 0] < 0
    faces = mesh.faces[keep[mesh.faces].all(axis=1)]
    used = np.unique(faces)
    remap = np.full(mesh.n_points, -1)
    remap[used] = np.arange(len(used))
    return TriMesh(mesh.points[used], remap[faces])


def _body(surface: TriMesh, femur: TriMesh) -> FEBody:
    return FEBody("medial", surface, np.full(surface.n_points, 6.0), MeshIndenter(femur),
                  "mesh:tibia", "mesh:femur", "uniform")


@pytest.fixture(scope="module")
def voxel():
    return voxel_knee(SPACING_MM)


def test_raw_segmented_sheet_fails_with_compartment_place_and_key(voxel):
    body = _body(_medial(voxel["tibia"]), voxel["femur"])
    with pytest.raises(FecheckError) as err:
        build_layers([body], 20.0, 0.3, FESettings(prepare="off"), lambda s: None)
    message = str(err.value)
    assert "\n" not in message
    assert message.startswith("the medial tibial sheet cannot be extruded")
    assert "fe.prepare = 'on'" in message
    x, y, _ = (float(v) for v in message.split(" at (")[1].split(") mm")[0].split(", "))
    # the place named is on the curled rim: at the edge of the 26 x 26 mm patch
    c = CONDYLES["medial"]
    edge = max(abs(x - c.patch_centre[0]), abs(y - c.patch_centre[1]))
    assert PATCH_HALF_MM - 2 * SPACING_MM < edge < PATCH_HALF_MM + 2 * SPACING_MM


def test_auto_prepares_only_what_does_not_extrude(voxel):
    settings = FESettings(prepare="auto", size_mm=SIZE_MM)
    smooth = _body(tibia_compartment("medial"), femur_mesh())
    raw = _body(_medial(voxel["tibia"]), voxel["femur"])
    kept, prepared = build_layers([smooth, raw], 20.0, 0.3, settings, lambda s: None)
    assert kept.to_ef is None                                         # the EF faces
    assert np.array_equal(kept.surface.faces, smooth.surface.faces)
    assert np.array_equal(kept.surface.points, smooth.surface.points)
    assert prepared.to_ef is not None
    assert prepared.to_ef.shape == (raw.surface.n_faces, prepared.surface.n_points)
    assert prepared.body is raw                                       # EF body kept
    assert prepared.surface.n_faces < raw.surface.n_faces / 3         # remeshed at 2 mm
    # the femoral surface is prepared too, over the compartment only
    assert kept.indenter is smooth.indenter
    femur = prepared.indenter.mesh
    assert femur.points[:, 0].max() < 0 < voxel["femur"].points[:, 0].max()


def _import(folder, files) -> object:
    scene = folder / "knee.toml"
    with contextlib.redirect_stdout(io.StringIO()):
        assert cli(["knee", "import", "--femur", str(files["femur"]), "--tibia",
                    str(files["tibia"]), "--units", "mm", "--side", "right", "-o",
                    str(scene)]) == 0
    return scene


def _face_peak(chk) -> np.ndarray:
    return np.array([c.fe_pressure_MPa[c.layer.surface.faces].mean(axis=1).max()
                     for c in chk.compartments.values()])


def test_voxel_knee_fe_matches_the_smooth_knee(tmp_path):
    """knee import -> fe on the voxel knee with the default fe.prepare ('auto'), against
    the FE of the smooth knee it was voxelized from, at the same settings (the same
    imported scene naming the smooth files, its sheets prepared the same way).

    Tolerance 5 % on the face-averaged p_max and the area (the acceptance bound of the
    voxelized knees): the voxel sheets keep terraces of up to half a voxel (0.3 mm) that
    the 2 mm smoothing (fe.smooth_mm) reduces; validation/fe_segmented.py measures the
    deviation at three element sizes on 0.5 mm voxels. With fe.smooth_mm = 1 mm the
    terraces leave -14 % on p_max there, and this test fails."""
    smooth = tmp_path / "smooth"
    smooth.mkdir()
    write_mesh(femur_mesh(), smooth / "femur.stl")
    write_mesh(tibia_mesh(), smooth / "tibia.stl")
    raw = _import(tmp_path / "raw", write_voxel_knee(tmp_path / "raw", SPACING_MM,
                                                      bones=False))
    ref = cross_check(load_scene(raw, ["fe.prepare=on", f"fe.size_mm={SIZE_MM}",
                                       f"geometry.femur={smooth / 'femur.stl'}",
                                       f"geometry.tibia={smooth / 'tibia.stl'}"]), log=None)
    chk = cross_check(load_scene(raw, [f"fe.size_mm={SIZE_MM}"]), log=None)
    assert all(c.layer.to_ef is not None for c in chk.compartments.values())
    area = np.array([c.fe.area_mm2 for c in chk.compartments.values()])
    ref_area = np.array([c.fe.area_mm2 for c in ref.compartments.values()])
    assert np.all(np.abs(_face_peak(chk) / _face_peak(ref) - 1) < 0.05)
    assert np.all(np.abs(area / ref_area - 1) < 0.05)
    # the FE pressure carried back onto the raw EF faces carries the FE force
    for c in chk.compartments.values():
        carried = float(c.fe_face_pressure_MPa @ c.layer.body.surface.face_areas)
        assert carried == pytest.approx(float(c.fe_force_N.sum()), rel=0.03)
