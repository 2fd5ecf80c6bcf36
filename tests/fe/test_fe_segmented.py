"""`fecheck fe` on a knee that looks like a segmentation (`geometry.synthetic.voxel_knee`:
the smooth `geometry.synthetic.knee` knee voxelized at 0.6 mm and taken back by marching
cubes): the raw sheets do not extrude, the prepared ones do (``fe.prepare``), and the FE
answer is close to the FE of the smooth knee they were voxelized from."""

from __future__ import annotations

import contextlib
import io

import numpy as np
import pytest

from fecheck.cli import main as cli
from fecheck.errors import FecheckError
from fecheck.fe.bodies.indenter import MeshIndenter
from fecheck.fe.bodies.scene_bodies import FEBody
from fecheck.fe.bodies.settings import FESettings
from fecheck.fe.knee.crosscheck import cross_check
from fecheck.fe.solve.press import build_layers, prepared_body
from fecheck.scene import load_scene
from geometry.mesh import TriMesh
from geometry.synthetic.knee import (
    CONDYLES,
    PATCH_HALF_MM,
    femur_mesh,
    tibia_compartment,
    tibia_mesh,
    write_mesh,
)
from geometry.synthetic.voxel_knee import voxel_knee, write_voxel_knee

SPACING_MM = 0.6
SIZE_MM = 2.0
"""The FE element size of the layer-building test (the default, 1 mm, takes 4 times
longer); the FE tests run at the default."""


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


def test_terraces_fit_the_condyle_bottom(voxel):
    """fe.terraces = 'on': the medial tibial sheet's staircase is found (step 0.590 mm for
    the 0.6 mm voxels: the terraces' fitted spacing) and the femoral surface, fitted at
    that step through its mid-riser contours, has its lowest point 0.014 mm from the true
    condyle bottom (z = 2.0 mm); the local quadric fits leave it 0.079 mm low (the
    bottom's flat terrace averaged with the risers around it)."""
    body = _body(_medial(voxel["tibia"]), voxel["femur"])
    c = CONDYLES["medial"]
    bottom = c.centre[2] - c.axes[2]
    fitted, prepared = prepared_body(body, 1.0, 4.0, terraces=True)
    assert prepared.staircase.step == pytest.approx(SPACING_MM, rel=0.03)
    assert fitted.indenter.mesh.points[:, 2].min() == pytest.approx(bottom, abs=0.03)
    quadric, plain = prepared_body(body, 1.0, 4.0)
    assert plain.staircase is None
    assert quadric.indenter.mesh.points[:, 2].min() < bottom - 0.05


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


@pytest.fixture(scope="module")
def smooth_scene(tmp_path_factory):
    folder = tmp_path_factory.mktemp("smooth")
    return _import(folder, {"femur": write_mesh(femur_mesh(), folder / "femur.stl"),
                            "tibia": write_mesh(tibia_mesh(), folder / "tibia.stl")})


@pytest.fixture(scope="module")
def own_fe(smooth_scene):
    """The smooth knee's own FE: its own faces, not prepared (the reference)."""
    return cross_check(load_scene(smooth_scene, ["fe.prepare=off"]), log=None)


@pytest.fixture(scope="module")
def voxel_fe(tmp_path_factory):
    """knee import -> fe on the voxel knee at the default fe.prepare ('auto')."""
    folder = tmp_path_factory.mktemp("raw")
    scene = _import(folder, write_voxel_knee(folder, SPACING_MM, bones=False))
    return cross_check(load_scene(scene, []), log=None)


def _area(chk) -> np.ndarray:
    return np.array([c.fe.area_mm2 for c in chk.compartments.values()])


def _carries_its_force(chk) -> None:
    """The FE pressure carried back onto the EF faces carries the FE force."""
    for c in chk.compartments.values():
        carried = float(c.fe_face_pressure_MPa @ c.layer.body.surface.face_areas)
        assert carried == pytest.approx(float(c.fe_force_N.sum()), rel=0.03)


def test_prepared_smooth_knee_matches_its_own_fe(smooth_scene, own_fe):
    """knee import -> fe on the smooth knee, its sheets prepared (fe.prepare = 'on', the
    default smoothing) against the FE on its own faces (fe.prepare = 'off'): within 5 %
    on the face-averaged p_max and the area at the default 1 mm elements (like with like:
    the own faces are 0.8-0.9 mm; at 2 mm the face average alone takes -10 %). The
    preparation keeps curved shapes (local
    quadric fits): the first smoothing, a spline penalising curvature over 2 mm,
    flattened the plateau's 0.4 mm bump and left -30 % / -22 % on p_max."""
    chk = cross_check(load_scene(smooth_scene, ["fe.prepare=on"]), log=None)
    assert all(c.layer.to_ef is not None for c in chk.compartments.values())
    assert np.all(np.abs(_face_peak(chk) / _face_peak(own_fe) - 1) < 0.05)
    assert np.all(np.abs(_area(chk) / _area(own_fe) - 1) < 0.05)
    _carries_its_force(chk)


def test_voxel_knee_fe_is_prepared_and_carries_its_force(voxel_fe):
    assert all(c.layer.to_ef is not None for c in voxel_fe.compartments.values())
    assert np.all(np.isfinite(_face_peak(voxel_fe)))
    _carries_its_force(voxel_fe)


FINE_VOXEL_MM = 0.3
"""The voxel size within which the face p_max and area of this knee's FE are held to 5 %."""


@pytest.fixture(scope="module")
def fine_voxel_fe(tmp_path_factory):
    """knee import -> fe on the knee voxelized at `FINE_VOXEL_MM`, fe.prepare 'auto'."""
    folder = tmp_path_factory.mktemp("fine")
    scene = _import(folder, write_voxel_knee(folder, FINE_VOXEL_MM, bones=False))
    return cross_check(load_scene(scene, []), log=None)


@pytest.mark.slow
def test_fine_voxel_knee_fe_matches_the_smooth_knees_own_fe_within_5_percent(fine_voxel_fe,
                                                                             own_fe):
    """At 0.3 mm voxels the face-averaged p_max and the area are within 5 % of the smooth
    knee's own FE at the default settings (measured, medial / lateral: p_max +3.7 / +0.7 %,
    area +3.5 / +1.2 %). Coarser voxels are held to the bound of the next test."""
    assert np.all(np.abs(_face_peak(fine_voxel_fe) / _face_peak(own_fe) - 1) < 0.05)
    assert np.all(np.abs(_area(fine_voxel_fe) / _area(own_fe) - 1) < 0.05)


def test_coarse_voxel_knee_fe_stays_within_its_measured_error(voxel_fe, own_fe):
    """Beyond 0.3 mm voxels the face p_max is off by up to 20 % and the area by up to
    8 % (default settings, medial / lateral, against the smooth knee's own FE): 0.35 mm
    p_max +2.3 / +6.6 %, area +1.0 / -0.0 %; 0.4 mm -13.0 / -12.4 %, +3.3 / +4.5 %;
    0.5 mm -18.9 / -19.9 %, +6.9 / +6.1 %; 0.6 mm -2.5 / +6.5 %, -5.7 / -1.0 %. The
    error does not shrink steadily with the voxel: it follows where the condyle bottoms
    fall in the voxel grid (at 0.5 mm both lie on a plane of voxel centres, and the
    terrace half a voxel above each bottom's middle leaves the prepared gap 0.2 mm too
    wide where the FE peaks). Checked here at 0.6 mm."""
    assert np.all(np.abs(_face_peak(voxel_fe) / _face_peak(own_fe) - 1) < 0.20)
    assert np.all(np.abs(_area(voxel_fe) / _area(own_fe) - 1) < 0.08)
