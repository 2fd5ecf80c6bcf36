"""Transversely isotropic elasticity (`fecheck.fe.material.anisotropy`) against closed forms.

References: homogeneous uniaxial stress (strain = S σ, exact for P2) on a rotated block,
the off-axis modulus 1/E(φ) = cos⁴φ/E_t + sin⁴φ/E_p + (1/G_t − 2ν_tp/E_t) sin²φ cos²φ,
the isotropic assemblies of `fecheck.fe.bodies.solid` and `fecheck.fe.reference.axisym`, and
Lekhnitskii's cylindrically orthotropic thick-walled ring under internal pressure in plane strain
(Lekhnitskii, Theory of Elasticity of an Anisotropic Body, 1963/1981, §30):
u = A r^k + B r^-k, k = sqrt(C_θθ / C_rr).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from fecheck.errors import FecheckError
from fecheck.fe.material.anisotropy import (
    MENISCUS,
    TransIso,
    axisym_hoop_stiffness,
    hoop_directions,
    local_stiffness,
    p2_transiso,
    voigt_stiffness,
)
from fecheck.statics.frames import rotation

MAT = TransIso(E_p=20.0, E_t=140.0, nu_p=0.2, nu_tp=0.3, G_t=12.0)   # G_t ≠ G_p (8.33)
SIGMA = 0.7                                                        # MPa


def _block_strain(m: TransIso, fibre_local: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(strain tensor, R): a 2 × 1 × 1 mm block rotated by R, fibres along R fibre_local,
    pulled by SIGMA (MPa) along R e_x on its x = 0 and x = 2 ends (rigid modes removed by
    multipliers); the strain is the exact gradient fitted to the nodal displacements."""
    from skfem import FacetBasis, LinearForm, MeshTet, asm

    R = rotation(0.3, -0.5, 0.8)
    box = MeshTet.init_tensor(np.linspace(0, 2, 3), np.linspace(0, 1, 2), np.linspace(0, 1, 2))
    mesh = MeshTet(R @ box.p, box.t)
    d = np.tile(R @ fibre_local, (mesh.t.shape[1], 1))
    basis, K = p2_transiso(mesh, m, d)
    axis = R[:, 0]

    def end(x0: float):
        return mesh.facets_satisfying(lambda x: np.isclose(np.einsum("a...,a->...", x, axis),
                                                           x0))

    f = np.zeros(basis.N)
    for x0, sign in ((0.0, -1.0), (2.0, 1.0)):
        fb = FacetBasis(mesh, basis.elem, facets=end(x0), intorder=2)
        f += asm(LinearForm(lambda v, w, s=sign: s * SIGMA * np.einsum("a...,a->...", v,
                                                                          axis)), fb)
    ix, iy, iz = basis.split_indices()
    X = basis.doflocs[:, ix].T
    Z = np.zeros((basis.N, 6))
    for a in range(3):
        Z[(ix, iy, iz)[a], a] = 1.0
        e = np.eye(3)[a]
        rot = np.cross(e, X - X.mean(axis=0))
        for b in range(3):
            Z[(ix, iy, iz)[b], 3 + a] = rot[:, b]
    A = sp.bmat([[K, sp.csr_matrix(Z)], [sp.csr_matrix(Z.T), None]]).tocsc()
    u = sla.spsolve(A, np.concatenate([f, np.zeros(6)]))[:basis.N]
    U = np.column_stack([u[ix], u[iy], u[iz]])
    G = np.linalg.lstsq(np.column_stack([X, np.ones(len(X))]), U, rcond=None)[0][:3].T
    return 0.5 * (G + G.T), R


def test_uniaxial_along_fibres_on_rotated_block():
    eps, R = _block_strain(MAT, np.array([1.0, 0.0, 0.0]))
    a, b, c = R.T
    assert a @ eps @ a == pytest.approx(SIGMA / MAT.E_t, rel=1e-9)
    for lateral in (b, c):
        assert lateral @ eps @ lateral == pytest.approx(-MAT.nu_tp * SIGMA / MAT.E_t, rel=1e-9)
    assert abs(a @ eps @ b) < 1e-9 * SIGMA / MAT.E_t


def test_uniaxial_across_fibres_on_rotated_block():
    eps, R = _block_strain(MAT, np.array([0.0, 1.0, 0.0]))
    a, d, c = R.T                                         # load, fibre, the other lateral
    assert a @ eps @ a == pytest.approx(SIGMA / MAT.E_p, rel=1e-9)
    assert d @ eps @ d == pytest.approx(-MAT.nu_tp * SIGMA / MAT.E_t, rel=1e-9)
    assert c @ eps @ c == pytest.approx(-MAT.nu_p * SIGMA / MAT.E_p, rel=1e-9)


def test_off_axis_modulus_involves_the_fibre_shear_modulus():
    phi = np.radians(35.0)
    eps, R = _block_strain(MAT, np.array([np.cos(phi), np.sin(phi), 0.0]))
    c2, s2 = np.cos(phi) ** 2, np.sin(phi) ** 2
    compliance = c2 * c2 / MAT.E_t + s2 * s2 / MAT.E_p + (1 / MAT.G_t - 2 * MAT.nu_tp / MAT.E_t) \
        * s2 * c2
    assert R[:, 0] @ eps @ R[:, 0] == pytest.approx(SIGMA * compliance, rel=1e-9)


def test_isotropic_limit_equals_the_isotropic_assemblies():
    from skfem import Basis, ElementTriP2, ElementVector, MeshTet, MeshTri

    from fecheck.fe.bodies.solid import p2_elasticity
    from fecheck.fe.reference.axisym import axisym_stiffness
    from geometry.mesh import TetMesh

    E, nu = 12.0, 0.35
    iso = TransIso(E, E, nu, nu, E / (2 * (1 + nu)))
    mesh = MeshTet.init_tensor(np.linspace(0, 1, 3), np.linspace(0, 2, 3), np.linspace(0, 1, 2))
    d = np.random.default_rng(3).normal(size=(mesh.t.shape[1], 3))
    _, K = p2_transiso(mesh, iso, d)
    _, _, K_iso = p2_elasticity(TetMesh(mesh.p.T, mesh.t.T), E, nu)
    assert abs(K - K_iso).max() < 1e-12 * abs(K_iso).max()
    _, K_point = p2_transiso(mesh, iso, lambda x: np.cos(x) + 0.1)     # fibres per point
    assert abs(K_point - K_iso).max() < 1e-12 * abs(K_iso).max()
    tri = Basis(MeshTri.init_tensor(np.linspace(1, 3, 4), np.linspace(0, 1, 3)),
                ElementVector(ElementTriP2()))
    K_ax, K_ax_iso = axisym_hoop_stiffness(tri, iso), axisym_stiffness(tri, E, nu)
    assert abs(K_ax - K_ax_iso).max() < 1e-12 * abs(K_ax_iso).max()


def test_voigt_compliance_with_fibres_along_x():
    S = np.linalg.inv(voigt_stiffness(MAT, [[2.0, 0.0, 0.0]])[0])     # order xx yy zz yz xz xy
    E_p, E_t = MAT.E_p, MAT.E_t
    expected = np.diag([1 / E_t, 1 / E_p, 1 / E_p, 2 * (1 + MAT.nu_p) / E_p, 1 / MAT.G_t,
                        1 / MAT.G_t])
    expected[0, 1:3] = expected[1:3, 0] = -MAT.nu_tp / E_t
    expected[1, 2] = expected[2, 1] = -MAT.nu_p / E_p
    assert np.abs(S - expected).max() < 1e-12 * S.max()


def test_undefined_fibre_directions_are_refused_in_one_line():
    with pytest.raises(FecheckError, match="fibre direction 1 is zero"):
        voigt_stiffness(MAT, [[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    with pytest.raises(FecheckError, match=r"\[0.0, 0.0, 5.0\] mm lies on the fibre axis"):
        hoop_directions(np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 5.0]]), np.zeros(3), [0, 0, 1.0])


def test_material_that_is_not_positive_definite_is_refused_in_one_line():
    local_stiffness(TransIso(20.0, 140.0, 0.2, 1.5, 8.0))        # ν_tp² 2.25 < 2.8: valid
    with pytest.raises(FecheckError, match="not positive definite.*nu_tp 1.7") as err:
        local_stiffness(TransIso(20.0, 140.0, 0.2, 1.7, 8.0))    # 2.89 > 2.8
    assert "\n" not in str(err.value)
    with pytest.raises(FecheckError, match="moduli must be positive"):
        local_stiffness(TransIso(20.0, 140.0, 0.2, 0.3, 0.0))


A_IN, B_OUT, P_IN = 10.0, 16.0, 1.0                   # ring radii (mm), internal pressure MPa


def _lekhnitskii_u(m: TransIso, r: np.ndarray) -> np.ndarray:
    """Radial displacement (mm) of the plane-strain ring, hoop fibres, from the constants:
    compliance in (r, θ, z) with θ the fibre axis, reduced for ε_z = 0."""
    S = np.array([[1 / m.E_p, -m.nu_tp / m.E_t, -m.nu_p / m.E_p],
                  [-m.nu_tp / m.E_t, 1 / m.E_t, -m.nu_tp / m.E_t],
                  [-m.nu_p / m.E_p, -m.nu_tp / m.E_t, 1 / m.E_p]])
    beta = S[:2, :2] - np.outer(S[:2, 2], S[:2, 2]) / S[2, 2]
    (c_rr, c_rt), (_, c_tt) = np.linalg.inv(beta)
    k = np.sqrt(c_tt / c_rr)
    rows = [[(c_rr * k + c_rt) * rr ** (k - 1), (c_rt - c_rr * k) * rr ** (-k - 1)]
            for rr in (A_IN, B_OUT)]
    A, B = np.linalg.solve(np.array(rows), [-P_IN, 0.0])
    return A * r ** k + B * r ** (-k)


def _ring_3d(m: TransIso, n_r: int, n_t: int, per_point: bool) -> tuple[np.ndarray, np.ndarray]:
    """(r, u_r) at the vertices of a quarter ring (1 mm long, u_z = 0: plane strain;
    symmetry planes x = 0 and y = 0) of P2 tetrahedra, hoop fibres per element or per
    quadrature point."""
    from skfem import FacetBasis, LinearForm, MeshTet, asm

    box = MeshTet.init_tensor(np.linspace(A_IN, B_OUT, n_r + 1),
                              np.linspace(0, np.pi / 2, n_t + 1), np.linspace(0, 1, 2))
    r, t = box.p[0], box.p[1]
    mesh = MeshTet(np.array([r * np.cos(t), r * np.sin(t), box.p[2]]), box.t)

    def hoop(x: np.ndarray) -> np.ndarray:
        return hoop_directions(x, np.zeros(3), [0, 0, 1.0])

    basis, K = p2_transiso(mesh, m, hoop if per_point else hoop(mesh.p[:, mesh.t].mean(axis=1).T))
    inner = mesh.facets_satisfying(lambda x: np.hypot(x[0], x[1]) < A_IN + 1e-6)
    fb = FacetBasis(mesh, basis.elem, facets=inner, intorder=3)
    f = asm(LinearForm(lambda v, w: -P_IN * np.einsum("a...,a...->...", w.n, v)), fb)
    ix, iy, iz = basis.split_indices()
    loc = basis.doflocs
    fixed = np.concatenate([iz, ix[np.isclose(loc[0, ix], 0.0)],
                            iy[np.isclose(loc[1, iy], 0.0)]])
    free = np.setdiff1d(np.arange(basis.N), fixed)
    u = np.zeros(basis.N)
    u[free] = sla.spsolve(K[free][:, free].tocsc(), f[free])
    xy = mesh.p[:2]
    rr = np.hypot(*xy)
    ur = (u[basis.nodal_dofs[0]] * xy[0] + u[basis.nodal_dofs[1]] * xy[1]) / rr
    return rr, ur


def _ring_axisym(m: TransIso, n_r: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """(r, u_r) at the vertices of the same ring as an (r, z) section of P2 triangles with
    hoop fibres, u_z = 0 (plane strain), the pressure on r = A_IN weighted by 2πr."""
    from skfem import Basis, ElementTriP2, ElementVector, FacetBasis, LinearForm, MeshTri, asm

    mesh = MeshTri.init_tensor(np.linspace(A_IN, B_OUT, n_r + 1), np.linspace(0, 1, 2))
    basis = Basis(mesh, ElementVector(ElementTriP2()))
    K = axisym_hoop_stiffness(basis, m)
    fb = FacetBasis(mesh, basis.elem, facets=mesh.facets_satisfying(
        lambda x: x[0] < A_IN + 1e-9), intorder=3)
    f = asm(LinearForm(lambda v, w: P_IN * v[0] * 2 * np.pi * w.x[0]), fb)
    free = basis.split_indices()[0]
    u = np.zeros(basis.N)
    u[free] = sla.spsolve(K[free][:, free].tocsc(), f[free])
    return mesh.p[0], u[basis.nodal_dofs[0]]


def test_hoop_stiff_ring_3d_and_axisym_against_lekhnitskii():
    r3, u3 = _ring_3d(MENISCUS, 6, 48, per_point=False)   # 1.9° elements
    rp, up = _ring_3d(MENISCUS, 6, 24, per_point=True)    # 3.75° elements
    ra, ua = _ring_axisym(MENISCUS)
    iso = _lekhnitskii_u(TransIso(20.0, 20.0, 0.2, 0.2, 20.0 / 2.4), r3)
    ref3, refa = _lekhnitskii_u(MENISCUS, r3), _lekhnitskii_u(MENISCUS, ra)
    assert np.abs(u3 / ref3 - 1).max() < 0.01             # fibres per element: 0.46 %
    assert np.abs(up / _lekhnitskii_u(MENISCUS, rp) - 1).max() < 0.005   # per point: 0.17 %
    assert np.abs(ua / refa - 1).max() < 1e-4
    inner = np.isclose(r3, A_IN)
    assert u3[inner].mean() == pytest.approx(ua[0], rel=0.01)
    assert ref3.max() < 0.5 * iso.max()                     # the hoop fibres matter



def _energy(K: sp.spmatrix, held: np.ndarray, u_held: np.ndarray, n: int) -> float:
    """Strain energy ½ uᵀ K u (N mm) with the `held` dofs at `u_held` (mm), others free."""
    u = np.zeros(n)
    u[held] = u_held
    free = np.setdiff1d(np.arange(n), held)
    u[free] = sla.spsolve(K[free][:, free].tocsc(), -(K[free][:, held] @ u[held]))
    return float(0.5 * u @ (K @ u))


def test_ring_sheared_between_plates_3d_equals_axisym():
    """A ring (A_IN..B_OUT, 3 mm high), bottom bonded, top bonded to a plate that expands
    radially by 0.01 mm: r-z shear (G_p in the plane of isotropy; G_t ≠ G_p in MAT) and hoop
    stretch. Strain energy of the 3D quarter ring (× 4, fibres per point) against the
    axisymmetric ring."""
    from skfem import Basis, ElementTriP2, ElementVector, MeshTet, MeshTri

    h, c = 3.0, 0.01
    box = MeshTet.init_tensor(np.linspace(A_IN, B_OUT, 7), np.linspace(0, np.pi / 2, 25),
                              np.linspace(0.0, h, 5))
    r, t = box.p[0], box.p[1]
    mesh = MeshTet(np.array([r * np.cos(t), r * np.sin(t), box.p[2]]), box.t)
    basis, K = p2_transiso(mesh, MAT, lambda x: hoop_directions(x, np.zeros(3), [0, 0, 1.0]))
    ix, iy, iz = basis.split_indices()
    x = basis.doflocs
    rx = np.hypot(x[0], x[1])
    top = [i[np.isclose(x[2, i], h)] for i in (ix, iy, iz)]
    held = np.concatenate([i[np.isclose(x[2, i], 0.0)] for i in (ix, iy, iz)]
                          + top + [ix[np.isclose(x[0, ix], 0)], iy[np.isclose(x[1, iy], 0)]])
    u_held = np.zeros(basis.N)
    u_held[top[0]] = c * x[0, top[0]] / rx[top[0]]
    u_held[top[1]] = c * x[1, top[1]] / rx[top[1]]
    held = np.unique(held)
    energy_3d = 4 * _energy(K, held, u_held[held], basis.N)
    ab = Basis(MeshTri.init_tensor(np.linspace(A_IN, B_OUT, 13), np.linspace(0, h, 9)),
               ElementVector(ElementTriP2()))
    ir, jz = ab.split_indices()
    y = ab.doflocs
    top_r = ir[np.isclose(y[1, ir], h)]
    held_ax = np.concatenate([ir[np.isclose(y[1, ir], 0) | np.isclose(y[1, ir], h)],
                              jz[np.isclose(y[1, jz], 0) | np.isclose(y[1, jz], h)]])
    u_ax = np.zeros(ab.N)
    u_ax[top_r] = c
    energy_ax = _energy(axisym_hoop_stiffness(ab, MAT), held_ax, u_ax[held_ax], ab.N)
    assert energy_3d == pytest.approx(energy_ax, rel=0.01)
