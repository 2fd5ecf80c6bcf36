"""Contact sheet checks (`geometry.sheet_checks`): extent in the wrong unit, flipped or mixed
winding, edges of three faces and folds, each found where it is and named on one line;
the scanned knee's sheets pass; the topology is computed once per mesh."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from conftest import require_knee_data

from geometry import sheet_checks as sc
from geometry.errors import FecheckError, ImplausibleInput
from geometry.mesh import TriMesh
from geometry.plateau import plane_patch


@pytest.fixture(scope="module")
def patch() -> TriMesh:
    """A flat tibial sheet, 28 mm across, normals up."""
    return plane_patch((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), radius=14.0, size=1.0)


# ----------------------------------------------------------------------- meshes
def test_mesh_extents_name_metres_and_scaling(patch):
    sc.check_extent(patch, "sheet")
    with pytest.raises(FecheckError, match="0.028 mm across.*mesh in metres"):
        sc.check_extent(TriMesh(patch.points * 1e-3, patch.faces), "sheet")
    with pytest.warns(ImplausibleInput, match="28,000 mm across"):
        sc.check_extent(TriMesh(patch.points * 1e3, patch.faces), "sheet")


def test_winding_checks_tell_flipped_from_mixed(patch):
    sc.check_winding(patch, "sheet")
    with pytest.raises(FecheckError, match="normals point down.*n_z = -1.00"):
        sc.check_winding(TriMesh(patch.points, patch.faces[:, ::-1]), "sheet")
    faces = patch.faces.copy()
    left = patch.face_centroids[:, 0] < -5.0
    faces[left] = faces[left][:, ::-1]
    with pytest.raises(FecheckError, match=r"mixed winding: \d+ edges.*around \(x, y\) = \(-"):
        sc.check_winding(TriMesh(patch.points, faces), "sheet")


def _folded(patch):
    """The patch's points with x > 6 mm folded back over the sheet, 10° up; the flap."""
    p = patch.points.copy()
    flap = p[:, 0] > 6.0
    u = p[flap, 0] - 6.0
    p[flap, 0] = 6.0 - u * np.cos(np.radians(10.0))
    p[flap, 2] = u * np.sin(np.radians(10.0)) + 0.2
    return p, flap


def test_folds_are_found_where_they_are(patch):
    assert not sc.fold_faces(patch).any()
    p, flap = _folded(patch)
    folded = sc.fold_faces(TriMesh(p, patch.faces))
    in_flap = flap[patch.faces].all(axis=1)
    assert in_flap.sum() > 50 and folded[in_flap].all()      # the flap faces down
    reach = patch.points[patch.faces][folded][:, :, 0].max(axis=1)
    assert np.all(reach > 6.0 - 2.0)                         # nothing away from the crease
    with pytest.warns(ImplausibleInput, match=r"folds back over itself: \d+ of"):
        sc.check_folds(TriMesh(p, patch.faces), "sheet")


def test_a_sheet_is_analysed_once_and_still_warns_and_raises_every_time(patch):
    """A sweep checks the same sheet at every point: its edges, folds and extent are
    computed once per mesh, but every check still gives its warning or error."""
    folded = TriMesh(_folded(patch)[0], patch.faces)
    flipped = TriMesh(patch.points, patch.faces[:, ::-1])
    for _ in range(3):
        with pytest.warns(ImplausibleInput, match="folds back over itself"):
            sc.check_sheet(folded, "sheet")
        with pytest.raises(FecheckError, match="normals point down"):
            sc.check_sheet(flipped, "sheet")
    for mesh in (folded, flipped):
        assert sc.edge_neighbours(mesh) is sc.edge_neighbours(mesh)
        assert sc.area_mean_normal(mesh) is sc.area_mean_normal(mesh)
    assert sc.extent_mm(folded) is sc.extent_mm(folded)
    with pytest.raises(ValueError, match="read-only"):
        sc.fold_faces(folded)[0] = False
    other = TriMesh(patch.points, patch.faces)                   # the same arrays, new mesh
    assert not sc.fold_faces(other).any() and sc.fold_faces(folded).any()


def test_scanned_tibial_sheets_pass_every_mesh_check():
    from fecheck.scene import lenhart

    require_knee_data()
    for c in ("medial", "lateral"):
        sheet = lenhart.mesh(f"tibia_cartilage_{c}")
        sc.check_extent(sheet, c)
        sc.check_winding(sheet, c)
        assert not sc.fold_faces(sheet).any()


def test_a_non_manifold_sheet_is_an_error_with_its_place(patch):
    # a fin: a new vertex above an inner edge, joined to it (three faces on that edge)
    i = int(np.argmin(np.linalg.norm(patch.face_centroids[:, :2] - [3.0, -2.0], axis=1)))
    edge = patch.faces[i, :2]
    points = np.vstack([patch.points, patch.points[edge].mean(axis=0) + [0.0, 0.0, 1.0]])
    fin = TriMesh(points, np.vstack([patch.faces, [*edge, len(points) - 1]]))
    x, y = patch.points[edge, :2].mean(axis=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")                     # no numpy warning on the way
        with pytest.raises(FecheckError, match=rf"1 edges shared by three or more faces "
                                               rf"\(non-manifold\), around \(x, y\) = "
                                               rf"\({x:.1f}, {y:.1f}\) mm"):
            sc.check_winding(fin, "sheet")
