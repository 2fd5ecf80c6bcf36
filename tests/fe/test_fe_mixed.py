"""The mixed (P2 displacement / element-constant pressure, condensed) elasticity of
`fecheck.fe.material.elasticity` in the 3D layer and the axisymmetric reference.

References: exact integrals of affine fields (the patch test), Hertz on a thick block,
and the converged axisymmetric solve of `validation/fe_incompressible.py` (constants
below, produced by that script at 0.025 and 0.0125 mm under the contact).
"""

from __future__ import annotations

import numpy as np
import pytest

from fecheck.fe.bodies.solid import p2_elasticity
from fecheck.fe.material.elasticity import dilatation_matrix, resolve
from fecheck.fe.reference.axisym import axisym_divergence, axisym_sphere_on_layer, axisym_stiffness
from fecheck.reference.closed_forms import hertz_sphere_on_plane
from geometry.extrude import extrude_layer
from geometry.mesh import TriMesh

E, H = 20.0, 6.0
MEDIAL = (323.71, 25.5)            # baseline medial load (N) and condyle radius (mm)


def _sheet() -> TriMesh:
    """A 4 × 3 mm sheet of 12 right triangles, bumped so no face is axis-aligned."""
    x, y = np.meshgrid(np.linspace(0.0, 4.0, 4), np.linspace(0.0, 3.0, 3), indexing="ij")
    pts = np.column_stack([x.ravel(), y.ravel(), 0.1 * np.sin(x.ravel() + 2 * y.ravel())])
    idx = np.arange(12).reshape(4, 3)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), \
        idx[:-1, 1:].ravel()
    return TriMesh(pts, np.concatenate([np.column_stack([a, b, c]),
                                        np.column_stack([a, c, d])]))


def _interpolate(basis, field) -> np.ndarray:
    """Dof vector of the vector field `field(x)` ((dim, n) → (dim, n)) at the dofs'
    node positions."""
    comp = np.empty(basis.N, dtype=int)
    for k, idx in enumerate(basis.split_indices()):
        comp[idx] = k
    return field(basis.doflocs)[comp, np.arange(basis.N)]


A = np.array([[0.3, -0.2, 0.1], [0.5, 0.7, -0.4], [0.2, 0.1, -1.1]])


def test_element_means_of_div_integrate_an_affine_field_exactly():
    # u = A x: div u = tr A everywhere, so (D u)_T = tr A · |T|, and the volumes sum to
    # the layer's.
    layer = extrude_layer(_sheet(), 2.0, layers=2, ratio=1.5)
    _, basis, _ = p2_elasticity(layer, E, 0.49, formulation="mixed")
    D, volume = dilatation_matrix(basis)
    assert D @ _interpolate(basis, lambda x: A @ x) == pytest.approx(np.trace(A) * volume,
                                                                    rel=1e-12)
    assert volume.sum() == pytest.approx(layer.volume, rel=1e-12)


def test_mixed_element_condensation_equals_the_sparse_mean_dilatation_form():
    # p2_elasticity adds (λ/|T|) d dᵀ inside each element matrix; it must equal the μ part
    # (the displacement form at ν 0 with E/(1+ν): the same μ, λ 0) plus Dᵀ diag(λ/|T|) D
    # of scikit-fem's own basis (`dilatation_matrix`, the quadrature over div φ)
    from fecheck.fe.material.elasticity import lame, mean_dilatation_stiffness

    nu = 0.49
    layer = extrude_layer(_sheet(), 2.0, layers=2, ratio=1.5)
    _, basis, K_mixed = p2_elasticity(layer, E, nu, formulation="mixed")
    _, _, K_mu = p2_elasticity(layer, E / (1 + nu), 0.0, formulation="displacement")
    K_ref = K_mu + mean_dilatation_stiffness(*dilatation_matrix(basis), lame(E, nu)[0])
    assert abs(K_mixed - K_ref).max() < 1e-12 * abs(K_ref).max()


def test_mixed_and_displacement_stiffness_agree_where_div_u_is_constant():
    # Patch test: for an affine u the element mean of div u is div u itself, so
    # v·K_mixed u = v·K_displacement u for every v (K u equal). For q = (x², yz, z²),
    # div q = 2x + 3z is linear and the energies differ by exactly λ Σ_T ∫_T (div q -
    # mean)² (P1 on a tetrahedron: ∫ f² = |T| (Σ f_i² + (Σ f_i)²) / 20).
    layer = extrude_layer(_sheet(), 2.0, layers=2, ratio=1.5)
    _, basis, K_mixed = p2_elasticity(layer, E, 0.49, formulation="mixed")
    _, _, K_disp = p2_elasticity(layer, E, 0.49, formulation="displacement")
    u = _interpolate(basis, lambda x: A @ x)
    scale = np.abs(K_disp @ u).max()
    assert np.abs(K_mixed @ u - K_disp @ u).max() < 1e-10 * scale
    q = _interpolate(basis, lambda x: np.stack([x[0] ** 2, x[1] * x[2], x[2] ** 2]))
    p = layer.points
    f = 2 * p[layer.tets, 0] + 3 * p[layer.tets, 2]                    # (tets, 4)
    vol = np.abs(layer.tet_volumes)
    spread = vol * ((f ** 2).sum(1) + f.sum(1) ** 2) / 20 - vol * f.mean(1) ** 2
    lam = E * 0.49 / (1.49 * 0.02)
    assert q @ K_disp @ q - q @ K_mixed @ q == pytest.approx(lam * spread.sum(), rel=1e-8)


def _ring_basis():
    from skfem import Basis, ElementTriP2, ElementVector, MeshTri

    mesh = MeshTri.init_tensor(np.linspace(0.5, 2.0, 4), np.linspace(-1.0, 0.0, 3))
    return Basis(mesh, ElementVector(ElementTriP2()))


def test_axisymmetric_divergence_has_the_hoop_strain_and_the_ring_volume():
    # u_r = c r, u_z = d z: div u = 2c + d (∂u_r/∂r + u_r/r + ∂u_z/∂z); the weighted
    # volumes 2πr dA sum to the ring's π (2² - 0.5²) · 1 mm³.
    basis = _ring_basis()
    c, d = 0.3, -0.8
    u = _interpolate(basis, lambda x: np.stack([c * x[0], d * x[1]]))
    D, volume = dilatation_matrix(basis, axisym_divergence, lambda x: 2 * np.pi * x[0])
    assert volume.sum() == pytest.approx(np.pi * (4.0 - 0.25), rel=1e-10)
    assert D @ u == pytest.approx((2 * c + d) * volume, rel=1e-8)
    K_mixed = axisym_stiffness(basis, E, 0.49, "mixed")
    K_disp = axisym_stiffness(basis, E, 0.49, "displacement")
    scale = np.abs(K_disp @ u).max()
    assert np.abs(K_mixed @ u - K_disp @ u).max() < 1e-8 * scale


def test_auto_formulation_is_mixed_for_nearly_incompressible_layers():
    assert resolve("auto", 0.3) == resolve("auto", 0.44) == "displacement"
    assert resolve("auto", 0.45) == resolve("auto", 0.4999) == "mixed"
    assert resolve("displacement", 0.49) == "displacement"


def test_thick_block_matches_hertz_near_incompressibility():
    # A 60 mm block under 20 N (contact radius ≈ 2.3 mm, a/h ≈ 0.04): the half-space
    # limit, where Hertz holds for any ν < 0.5 (E* = E / (1 - ν²)). The displacement P2
    # triangles lock at ν 0.4999; measured at 0.05 mm with the mixed form:
    # p_max +0.55 %, contact radius +0.04 % (displacement: +33 %, +0.04 %); allow 1 %.
    fe = axisym_sphere_on_layer(20.0, 25.5, E, 0.4999, 60.0, layer_radius_mm=80.0,
                                size_mm=0.05, formulation="mixed")
    hz = hertz_sphere_on_plane(20.0, 25.5, E, 0.4999)
    assert fe.metrics.max_pressure_MPa == pytest.approx(hz.max_pressure_MPa, rel=0.01)
    assert np.sqrt(fe.metrics.area_mm2) == pytest.approx(np.sqrt(hz.area_mm2), rel=0.01)


# The converged axisymmetric mixed solve of the baseline medial compartment (323.71 N,
# R 25.5 mm, E 20 MPa, h 6 mm), p_max (MPa) and area (mm²) at 0.0125 mm under the
# contact: `python validation/fe_incompressible.py` section 1 (it changes by < 0.2 %
# from 0.025 mm; the displacement form agrees to 0.02 % at ν 0.3 and locks at 0.4999).
REFERENCE = {0.45: (4.95638, 101.7737), 0.49: (5.18935, 97.5301), 0.4999: (5.25497, 96.4239)}


def test_mixed_matches_displacement_at_moderate_poisson():
    # At ν 0.3 both forms converge to the same solution: measured p_max 0.085 % apart at
    # 0.05 mm (0.02 % at 0.0125 mm), the same contact area (same nodes in contact).
    mixed = axisym_sphere_on_layer(*MEDIAL, E, 0.3, H, size_mm=0.05, formulation="mixed")
    disp = axisym_sphere_on_layer(*MEDIAL, E, 0.3, H, size_mm=0.05,
                                  formulation="displacement")
    assert mixed.metrics.max_pressure_MPa == pytest.approx(disp.metrics.max_pressure_MPa,
                                                           rel=1e-3)
    assert mixed.metrics.area_mm2 == pytest.approx(disp.metrics.area_mm2, rel=1e-3)


@pytest.mark.parametrize("nu", [0.49, 0.4999])
def test_axisymmetric_mixed_solve_converges_to_the_stored_reference(nu):
    # At 0.05 mm (measured: p_max +0.12 % at both ν, area -0.06 % / -0.34 %); the
    # displacement form at ν 0.4999 is +20 % there (locking). The area is quantised by
    # the node spacing (half a spacing of contact radius: ±0.9 % at 0.05 mm).
    m = axisym_sphere_on_layer(*MEDIAL, E, nu, H, size_mm=0.05).metrics
    p_ref, a_ref = REFERENCE[nu]
    assert m.max_pressure_MPa == pytest.approx(p_ref, rel=3e-3)
    assert m.area_mm2 == pytest.approx(a_ref, rel=0.01)


def test_flat_layer_at_nu_049_is_accurate_with_two_levels():
    # The general 3D path (`fecheck fe`'s extruded layer, the formulation picked by the
    # default fe.formulation = 'auto': mixed) at 1 mm under the contact with 2 levels
    # through 6 mm: measured p_max +1.1 %, area +1.3 % against the reference; the
    # displacement form there: p_max +8.0 %, area -2.0 % (the level over-stiffens and
    # the vertex pressures zigzag). Allow 2 %.
    from fecheck.fe.reference.sphere_layer import sphere_on_flat_layer

    m = sphere_on_flat_layer(*MEDIAL, E, 0.49, H, refine_size_mm=1.0, layers=2).metrics
    p_ref, a_ref = REFERENCE[0.49]
    assert m.max_pressure_MPa == pytest.approx(p_ref, rel=0.02)
    assert m.area_mm2 == pytest.approx(a_ref, rel=0.02)


def test_settings_check_the_formulation():
    from fecheck.errors import FecheckError
    from fecheck.fe.bodies.settings import FESettings

    assert FESettings().formulation_for(0.49) == "mixed"
    assert FESettings(formulation="displacement").formulation_for(0.49) == "displacement"
    with pytest.raises(FecheckError, match="fe.formulation must be one of"):
        FESettings(formulation="bbar").check()


def test_nearly_incompressible_baseline_is_refused_with_the_reason_before_any_work(
        monkeypatch, capsys):
    # At ν 0.4999 the EF's contact (radius ~1.2 mm at half the load: column stiffness
    # ∝ 1/(1 - 2ν)) refines the baseline plateaus to 0.1 mm: ~6e5 FE dofs. The refusal
    # comes before the EF run and names the cause and the remedy.
    import fecheck.fe.knee.crosscheck
    from fecheck.cli import main

    def no_work(*args, **kwargs):
        raise AssertionError("the EF run started")

    monkeypatch.setattr(fecheck.fe.knee.crosscheck, "_ef_run", no_work)
    code = main(["fe", "--set", "contact.poisson=0.4999"])
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert code == 2
    assert "FE dofs" in err
    assert "at contact.poisson 0.4999 the EF's contact" in err
    assert "set mesh.plateau_refine_mm = 0.4 " in err
