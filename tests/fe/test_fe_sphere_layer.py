"""The sphere on a flat bonded layer through the general FE path
(`fecheck.fe.reference.sphere_layer`: the reference problem of the bench, the stress matrix and
validation/fe_convergence.py) against the converged axisymmetric FE."""

from __future__ import annotations

import numpy as np
import pytest

from fecheck.fe.reference.axisym import axisym_sphere_on_layer
from fecheck.fe.reference.sphere_layer import sphere_on_flat_layer

MEDIAL = (323.71, 25.5)      # the thesis's rigid-model medial load (N) and condyle radius (mm)
E, H = 20.0, 6.0             # MPa, mm
SIZE = 1.0                   # mm under the contact: 50k dofs, ~15 s


@pytest.fixture(scope="module")
def medial():
    return sphere_on_flat_layer(*MEDIAL, E, 0.3, H, refine_size_mm=SIZE)


def test_matches_the_axisymmetric_solution(medial):
    # Converged reference: p_max moves < 0.01 % from 0.05 to 0.025 mm, area 0.4 %.
    # Measured at 1 mm against it (validation/fe_convergence.py): p_max +0.3 %, area
    # +0.4 %, depth +0.3 %; the ladder 2 … 0.5 mm scatters by up to 2.4 % (p_max) and
    # 3.3 % (area, 2 mm) and stays within 1 % on p_max from 1 mm down. Tolerances: 2 %
    # on p_max and area (the 1.4 mm mesh is 2.0 % low on p_max), 1 % on depth.
    ref = axisym_sphere_on_layer(*MEDIAL, E, 0.3, H, size_mm=0.05).metrics
    fe = medial.metrics
    assert fe.max_pressure_MPa == pytest.approx(ref.max_pressure_MPa, rel=0.02)
    assert fe.area_mm2 == pytest.approx(ref.area_mm2, rel=0.02)
    assert fe.depth_mm == pytest.approx(ref.depth_mm, rel=0.01)


def test_contact_balances_the_load_without_tension_or_penetration(medial):
    m = medial.metrics
    assert m.force_N == pytest.approx(MEDIAL[0], rel=1e-9)
    assert medial.nodal_force_N.sum() == pytest.approx(MEDIAL[0], rel=1e-9)
    assert m.mean_pressure_MPa == pytest.approx(MEDIAL[0] / m.area_mm2, rel=1e-12)
    assert medial.nodal_force_N.min() >= 0.0 and medial.pressure_MPa.min() >= 0.0
    assert medial.max_penetration_mm <= 1e-6
    assert np.abs(medial.gap_mm[medial.active]).max() < 1e-9      # closed where loaded
    # The pressure peaks where the sphere first touches (the origin): the axisymmetric
    # profile falls by under 4 % over r < 1.5 mm, so the peak vertex lies within 1.5
    # elements of the axis (measured: 1.13 mm).
    peak = medial.points[np.argmax(medial.pressure_MPa)]
    assert np.hypot(*peak[:2]) < 1.5 * SIZE
    # Before loading, the gap is the sphere's height above the flat top: R - √(R² - r²)
    # (under the sphere; the disc reaches beyond it).
    r2 = (medial.points[:, :2] ** 2).sum(axis=1)
    under = r2 < (0.8 * MEDIAL[1]) ** 2
    assert medial.gap0_mm[under] == pytest.approx(
        MEDIAL[1] - np.sqrt(MEDIAL[1] ** 2 - r2[under]), abs=1e-9)


def test_mesh_under_the_contact_has_the_requested_size(medial):
    # Gmsh meets a size field within about ±30 % on unstructured triangles.
    assert medial.size_under_contact_mm == pytest.approx(SIZE, rel=0.3)


def test_nearly_incompressible_layer_does_not_lock():
    # Quadratic tets at ν = 0.49 against the axisymmetric P2 reference (which converges
    # there, tests/fe/test_fe_axisym.py): a locking element would be far too stiff (higher
    # p_max, smaller area). Measured at 1 mm with 3 levels through the thickness: p_max
    # -0.2 %, area +1.5 %, depth +0.1 %. (With the default 2 levels the top level, 2.3 mm
    # thick, is coarser than the surface and the vertex pressures zigzag: p_max +6.7 % at
    # 1 mm, +14 % at 0.7 mm.) The displacement form itself (fe.formulation 'auto' picks
    # the mixed one here: tests/fe/test_fe_mixed.py).
    fe = sphere_on_flat_layer(*MEDIAL, E, 0.49, H, refine_size_mm=SIZE, layers=3,
                              formulation="displacement").metrics
    ref = axisym_sphere_on_layer(*MEDIAL, E, 0.49, H, size_mm=0.05).metrics
    assert fe.max_pressure_MPa == pytest.approx(ref.max_pressure_MPa, rel=0.02)
    assert fe.area_mm2 == pytest.approx(ref.area_mm2, rel=0.02)
    assert fe.depth_mm == pytest.approx(ref.depth_mm, rel=0.01)
