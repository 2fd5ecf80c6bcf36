"""FE on the scene's own geometry: the extruded layer, rigid indenters, the joint contact.

References: the axisymmetric FE at 0.05 mm (converged; `fecheck.fe.reference.axisym`), exact
volumes, rigid-body invariance and the hand statics of a load-controlled contact.
"""

from __future__ import annotations

import numpy as np
import pytest

from fecheck.fe.bodies.indenter import MeshIndenter, SphereIndenter
from fecheck.fe.bodies.pose import FramePose
from fecheck.fe.bodies.solid import layer_solid
from fecheck.fe.pressure.recovery import zero_contour_area
from fecheck.fe.reference.axisym import axisym_sphere_on_layer
from fecheck.fe.solve.joint import ContactLayer, JointContact
from fecheck.statics.frames import rotation
from geometry.extrude import extrude_layer
from geometry.icosphere import icosphere
from geometry.mesh import TriMesh
from geometry.plateau import plane_patch

R, F, E, NU, H = 25.5, 323.71, 20.0, 0.3, 6.0      # baseline medial compartment
UP = np.array([0.0, 0.0, 1.0])


def _patch(size: float = 0.8) -> TriMesh:
    """The baseline's plateau disc under the medial condyle (radius 14 mm, refined 0.8 mm
    within 9 mm, as the EF run meshes it), centred at the origin."""
    return plane_patch((0.0, 0.0, 0.0), UP, radius=14.0, size=2.0, refine_point=(0, 0, 0),
                       refine_size=size, refine_radius=9.0)


def _press(surface: TriMesh, indenter, direction: np.ndarray, force: float,
           layers: int = 2):
    """Layer under `surface` pushed along `direction` into `indenter` with `force` (N)."""
    solid = layer_solid(surface, H, E, NU, layers=layers, ratio=1.6)
    gap = indenter.gap(surface.points, surface.vertex_normals).gap_mm
    cand = np.flatnonzero(gap < 1.5)
    joint = JointContact([ContactLayer("c", solid, indenter, cand)])
    d = np.asarray(direction, dtype=float)
    sol = joint.solve(lambda q: FramePose(np.eye(3), q[0] * d),
                      lambda q: np.concatenate([d, np.zeros(3)])[:, None],
                      lambda q: np.array([force]), np.zeros(1))
    contact = sol.layers[0]
    p = contact.force_N / solid.tributary_mm2
    return solid, sol, contact, p


@pytest.fixture(scope="module")
def flat():
    return _press(_patch(), SphereIndenter(np.array([0.0, 0.0, R]), R), UP, F)


@pytest.fixture(scope="module")
def axisym():
    return axisym_sphere_on_layer(F, R, E, NU, H, size_mm=0.05).metrics


def test_extruded_flat_sheet_has_the_layer_volume_and_conforming_tetrahedra():
    sheet = _patch(1.5)
    layer = extrude_layer(sheet, H, layers=3, ratio=1.5)
    assert layer.volume == pytest.approx(sheet.area * H, rel=1e-12)
    assert np.all(layer.tet_volumes > 0)
    faces = np.sort(np.concatenate([layer.tets[:, [0, 1, 2]], layer.tets[:, [0, 1, 3]],
                                    layer.tets[:, [0, 2, 3]], layer.tets[:, [1, 2, 3]]]), axis=1)
    _, count = np.unique(faces, axis=0, return_counts=True)
    assert set(np.unique(count)) == {1, 2}         # every interior face shared by two tets
    # the outer faces: top and bottom triangles, and two per rim quad per level
    rim = np.count_nonzero(_boundary_edges(sheet))
    assert np.count_nonzero(count == 1) == 2 * sheet.n_faces + 2 * 3 * rim


def _boundary_edges(sheet: TriMesh) -> np.ndarray:
    e = np.sort(sheet.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, count = np.unique(e, axis=0, return_counts=True)
    return count == 1


def test_thickness_map_puts_each_bottom_vertex_its_own_depth_below_the_surface():
    sheet = _patch(1.5)
    h = 3.0 + 0.1 * sheet.points[:, 0]                 # 1.6 … 4.4 mm across the disc
    layer = extrude_layer(sheet, h, layers=2)
    n = sheet.n_points
    assert np.allclose(layer.points[2 * n:, 2], -h, atol=1e-12)


def test_flat_layer_matches_the_axisymmetric_reference(flat, axisym):
    # acceptance: p_max within 1 %, area within 2 % of the converged axisymmetric FE, on
    # the EF run's own plateau mesh (measured: -0.04 %, +0.18 %)
    solid, sol, contact, p = flat
    area = zero_contour_area(solid.surface.points, solid.surface.faces, p, contact.active)
    assert p.max() == pytest.approx(axisym.max_pressure_MPa, rel=0.01)
    assert area == pytest.approx(axisym.area_mm2, rel=0.02)


def test_contact_is_exact_and_balances_the_load(flat):
    solid, sol, contact, _ = flat
    assert contact.force_N.sum() == pytest.approx(F, rel=1e-10)
    assert contact.force_N.min() >= 0.0
    cand = np.isfinite(contact.gap_mm)
    assert contact.gap_mm[cand].min() > -1e-9                 # no penetration
    assert np.abs(contact.gap_mm[contact.active]).max() < 1e-9


def test_a_plateau_rotated_with_its_sphere_gives_the_flat_answer(flat):
    # frictionless along the normal, whatever the slope: rotate the disc, the sphere and
    # the load by 15° about y and 10° about x; p_max, area and force must not change
    _, _, contact0, p0 = flat
    rot = rotation(np.radians(10.0), np.radians(15.0), 0.0)
    sheet = _patch()
    tilted = TriMesh(sheet.points @ rot.T, sheet.faces)
    solid, _, contact, p = _press(tilted, SphereIndenter(rot @ np.array([0, 0, R]), R),
                                  rot @ UP, F)
    area0 = zero_contour_area(sheet.points, sheet.faces, p0, contact0.active)
    pts = solid.surface.points @ rot                 # back to the plateau's own frame
    area = zero_contour_area(pts, solid.surface.faces, p, contact.active)
    assert p.max() == pytest.approx(p0.max(), rel=0.01)
    assert area == pytest.approx(area0, rel=0.01)
    assert contact.force_N.sum() == pytest.approx(F, rel=1e-10)


def test_a_meshed_sphere_indenter_agrees_with_the_analytic_one(flat):
    # the femoral surface as a mesh (the scanned path): an icosphere of the same radius;
    # its faceting (level 5, 0.5 mm edges) shifts p_max by well under 2 %
    _, _, _, p0 = flat
    ball = icosphere(R, 5, (0.0, 0.0, R), method="trimesh", cache=False)
    _, _, contact, p = _press(_patch(), MeshIndenter(ball), UP, F)
    assert contact.force_N.sum() == pytest.approx(F, rel=1e-10)
    assert p.max() == pytest.approx(p0.max(), rel=0.02)


def test_pressure_is_smooth_in_the_load():
    # one mesh and one condensation for every load: no jump above 0.1 % between
    # neighbouring loads 1e-3 N apart
    sheet = _patch()
    solid = layer_solid(sheet, H, E, NU, layers=2, ratio=1.6)
    ind = SphereIndenter(np.array([0.0, 0.0, R]), R)
    cand = np.flatnonzero(ind.gap(sheet.points, sheet.vertex_normals).gap_mm < 1.5)
    joint = JointContact([ContactLayer("c", solid, ind, cand)])
    pmax = []
    for load in np.arange(324.0, 324.3 + 1e-9, 1e-3):
        sol = joint.solve(lambda q: FramePose(np.eye(3), q[0] * UP),
                          lambda q: np.concatenate([UP, np.zeros(3)])[:, None],
                          lambda q, f=load: np.array([f]), np.zeros(1))
        pmax.append((sol.layers[0].force_N / solid.tributary_mm2).max())
    jumps = np.abs(np.diff(pmax)) / np.asarray(pmax[:-1])
    assert jumps.max() < 1e-3


def test_vectorised_p2_assembly_equals_scikit_fem_forms():
    from skfem import asm
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    from fecheck.fe.bodies.solid import p2_elasticity

    layer = extrude_layer(_patch(2.0), H, layers=2, ratio=1.6)
    _, basis, K = p2_elasticity(layer, E, 0.45, chunk=500)          # several chunks
    reference = asm(linear_elasticity(*lame_parameters(E, 0.45)), basis)
    assert abs(K - reference).max() <= 1e-12 * abs(reference).max()
