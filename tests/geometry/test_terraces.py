"""`geometry.terraces`: the staircase of a sheet cut from voxels, and the smooth surface
fitted to it, against the exact surface the voxels were drawn from."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from geometry.io import load_mesh
from geometry.mesh import TriMesh
from geometry.prepare import prepare_sheet
from geometry.synthetic.knee import COMPARTMENTS, femur_mesh, tibia_compartment
from geometry.terraces import TerraceFit, staircase

RADIUS_MM, TOP_MM, VOXEL_MM = 40.0, 2.0, 0.5
Z = np.array([0.0, 0.0, 1.0])


def _cap(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    return TOP_MM - (x ** 2 + y ** 2) / (2 * RADIUS_MM)


def _voxel_cap(offset: float) -> TriMesh:
    """The top of the label z <= cap(x, y) on a grid of `VOXEL_MM` whose z planes are
    shifted by `offset` mm (blurred by a voxel and taken back by marching cubes, as
    geometry/synthetic/voxel_knee.py does), within 14 mm of the axis."""
    from skimage.measure import marching_cubes

    x = np.arange(-16.0, 16.0 + 1e-9, VOXEL_MM)
    z = np.arange(-4.0, 4.0 + 1e-9, VOXEL_MM) + offset
    X, Y, Zg = np.meshgrid(x, x, z, indexing="ij")
    field = ndimage.gaussian_filter((Zg <= _cap(X, Y)).astype(np.float32), 1.0)
    points, faces, _, _ = marching_cubes(field, 0.5, spacing=(VOXEL_MM,) * 3)
    points += [x[0], x[0], z[0]]
    mesh = TriMesh(points, faces[:, ::-1].astype(np.int64))
    centre = points[mesh.faces].mean(axis=1)
    keep = (mesh.face_normals[:, 2] > 0.3) & (np.hypot(centre[:, 0], centre[:, 1]) < 14)
    return TriMesh(points, mesh.faces[keep])


def _errors(sheet: TriMesh, **kw) -> tuple[float, float]:
    """RMS and largest height error (mm) of the sheet prepared at 1 mm within 12 mm."""
    p = prepare_sheet(sheet, 1.0, axis=Z, **kw).mesh.points
    e = (p[:, 2] - _cap(p[:, 0], p[:, 1]))[np.hypot(p[:, 0], p[:, 1]) < 12]
    return float(np.sqrt(np.mean(e ** 2))), float(np.abs(e).max())


def test_staircase_fit_recovers_a_voxelized_cap():
    """Voxels of 0.5 mm on a cap of radius 40 mm (z planes 0.1 mm off its top): the
    staircase is found (step 0.499 mm: flat faces on 3 levels) and the fit through the
    mid-riser contours alone is 0.016 mm RMS (0.047 mm at most) from
    the exact cap, a thirtieth of a voxel (bounds: 1.5 times that); the local quadric
    fits of the same sheet are 0.032 / 0.146 mm off (a flat top terrace)."""
    sheet = _voxel_cap(0.1)
    stair = staircase(sheet, Z)
    assert stair is not None
    assert stair.step == pytest.approx(VOXEL_MM, rel=0.005)
    rms, worst = _errors(sheet, terraces=TerraceFit(terrace_weight=0.0))
    quadric_rms, quadric_worst = _errors(sheet)
    assert rms < 0.025 and worst < 0.07
    assert rms < 0.6 * quadric_rms and worst < 0.5 * quadric_worst


def test_staircase_fit_at_a_known_step_finds_a_top_on_a_voxel_plane():
    """The top of the cap on a plane of voxel centres (the worst case: the top terrace
    half a voxel below it, on 2 levels of flat faces only, too few to detect the
    staircase alone): at the known step 0.5 mm, through the mid-riser contours alone (the
    femoral surface's fit), the top is recovered to 0.019 mm and the
    cap to 0.018 mm RMS (0.055 mm at most); the local quadric fits leave the top 0.22 mm
    low."""
    sheet = _voxel_cap(0.0)
    assert staircase(sheet, Z) is None
    rms, worst = _errors(sheet, terraces=TerraceFit(step_mm=VOXEL_MM, terrace_weight=0.0))
    top = prepare_sheet(sheet, 1.0, axis=Z,
                        terraces=TerraceFit(step_mm=VOXEL_MM, terrace_weight=0.0))
    assert top.mesh.points[:, 2].max() == pytest.approx(TOP_MM, abs=0.04)
    assert rms < 0.025 and worst < 0.08
    quadric = prepare_sheet(sheet, 1.0, axis=Z).mesh.points[:, 2].max()
    assert quadric < TOP_MM - 0.15


@pytest.mark.parametrize("name", COMPARTMENTS)
def test_smooth_and_scanned_sheets_have_no_staircase(name):
    """No staircase on the smooth knee's sheets nor on the scanned (Lenhart) tibial
    cartilage: fe.terraces leaves them to the local quadric fits."""
    assert staircase(tibia_compartment(name), Z) is None
    assert staircase(femur_mesh(), -Z) is None
    scanned = load_mesh(f"fecheck/data/knee/lenhart2015/lenhart2015_R_tibia_cartilage_{name}.stl")
    assert staircase(scanned, scanned.face_normals.mean(axis=0)) is None


def test_a_sheet_within_one_terrace_keeps_the_local_fits():
    """A flat sheet at a known step has a terrace but no riser: with the contours alone (the
    femoral surface's fit) nothing holds a thin plate, so the sheet keeps the local
    quadric fits (its plane, exactly) and no staircase."""
    x = np.linspace(-5.0, 5.0, 11)
    X, Y = np.meshgrid(x, x, indexing="ij")
    points = np.column_stack([X.ravel(), Y.ravel(), np.full(X.size, 0.25)])
    i, j = np.meshgrid(np.arange(10), np.arange(10), indexing="ij")
    p = (i * 11 + j).ravel()
    faces = np.concatenate([np.column_stack([p, p + 11, p + 1]),
                            np.column_stack([p + 11, p + 12, p + 1])])
    sheet = TriMesh(points, faces)
    assert staircase(sheet, Z, VOXEL_MM) is not None
    prepared = prepare_sheet(sheet, 1.0, axis=Z, terraces=TerraceFit(step_mm=VOXEL_MM,
                                                                  terrace_weight=0.0))
    assert prepared.staircase is None
    np.testing.assert_allclose(prepared.mesh.points[:, 2], 0.25, atol=1e-9)
