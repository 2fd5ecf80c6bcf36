"""Properties that earlier regressions broke while the rest of the suite still passed.

Each test compares the library with a reference written here (equilibrium, an exactly
representable field, the closed-form law, the spring formula), not with the library's own
numbers. None needs the scanned-knee data set.

* FE pressure recovery (3D): a tributary area off by a factor (×1.015 lowered p_max by
  1.5 %) breaks the equilibrium of the recovered pressure with the contact reaction.
* FE pressure projection (axisymmetric): row-sum lumping instead of the consistent mass
  no longer gives a pressure whose consistent loads are the FE contact forces.
* Blankevoort's log law continued linearly from 0.8 h instead of 0.9 h.
* The Blankevoort 1991 ligament toe region scaled by 4/3.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.polynomial.legendre import leggauss

from fecheck import laws
from fecheck.fe.pressure.recovery import project_pressure, tributary_areas
from fecheck.fe.reference.axisym import _line_p2_mass, axisym_sphere_on_layer
from fecheck.fe.reference.sphere_layer import sphere_on_flat_layer
from fecheck.statics.frames import rotation
from fecheck.statics.ligaments import SpringLigament, blankevoort_tension, spring_wrench

MEDIAL = (323.71, 25.5)          # rigid-model medial load (N) and condyle radius (mm)
E, NU, H = 20.0, 0.3, 6.0        # MPa, -, mm


def _triangle_areas(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    p = points[faces]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)


# ------------------------------------------------------------- 1. 3D pressure recovery
def test_tributary_areas_partition_the_surface_area():
    # A lumped area per vertex is a third of each adjacent triangle: they add up to the
    # surface's area exactly, and a vertex of a regular fan of six equal triangles gets
    # two of them. Measured: 2e-16 relative; tolerance 1e-12.
    ang = np.linspace(0.0, 2 * np.pi, 7)[:-1]
    points = np.vstack([[0.0, 0.0, 0.0], np.column_stack([np.cos(ang), np.sin(ang),
                                                          np.zeros(6)])])
    faces = np.array([[0, 1 + i, 1 + (i + 1) % 6] for i in range(6)])
    tri_area = math.sqrt(3) / 4                      # equilateral, unit side
    trib = tributary_areas(points, faces)
    assert trib.sum() == pytest.approx(6 * tri_area, rel=1e-12)
    assert trib[0] == pytest.approx(2 * tri_area, rel=1e-12)
    assert trib[1:] == pytest.approx(np.full(6, 2 * tri_area / 3), rel=1e-12)


@pytest.fixture(scope="module")
def medial_3d_coarse():
    # the general path at 2 mm under the contact: 29k dofs, ~7 s
    return sphere_on_flat_layer(*MEDIAL, E, NU, H, refine_size_mm=2.0)


def test_3d_recovered_pressure_integrates_to_the_contact_reaction(medial_3d_coarse):
    # Equilibrium: the recovered pressure is piecewise linear on the top triangles, so
    # its integral is Σ area × mean of the vertex values, computed here from the
    # triangles alone; it must equal the summed contact forces, i.e. the load (load
    # control). A tributary area off by 1.5 % gives a 1.5 % deficit.
    # Measured: 2e-16 relative (round-off); tolerance 1e-9.
    fe = medial_3d_coarse
    area = _triangle_areas(fe.points, fe.faces)
    integral = float((area * fe.pressure_MPa[fe.faces].mean(axis=1)).sum())
    assert fe.nodal_force_N.sum() == pytest.approx(MEDIAL[0], rel=1e-9)
    assert integral == pytest.approx(MEDIAL[0], rel=1e-9)
    # and vertex by vertex: p_i × (a third of the adjacent triangle areas) = λ_i
    third = np.zeros(len(fe.points))
    np.add.at(third, fe.faces.ravel(), np.repeat(area / 3, 3))
    loaded = fe.nodal_force_N > 0
    assert fe.pressure_MPa[loaded] * third[loaded] == pytest.approx(
        fe.nodal_force_N[loaded], rel=1e-9)


# -------------------------------------------------- 2. axisymmetric pressure projection
def _p2_shape(s: np.ndarray) -> np.ndarray:
    """Quadratic Lagrange shape functions at s ∈ [0, 1]: (3, nq), nodes at 0, 1/2, 1."""
    return np.stack([(1 - s) * (1 - 2 * s), 4 * s * (1 - s), s * (2 * s - 1)])


def _consistent_loads(r: np.ndarray, values, n_gauss: int = 6) -> np.ndarray:
    """∫ φ_i p 2πr dr on 3-node segments (r[2j], r[2j+1], r[2j+2]) by Gauss-Legendre.

    `values(e, s)` is the pressure on segment e at local coordinates s (MPa)."""
    xi, wq = leggauss(n_gauss)
    s = 0.5 * (xi + 1)
    phi = _p2_shape(s)
    loads = np.zeros(len(r))
    for e in range((len(r) - 1) // 2):
        r0, r1 = r[2 * e], r[2 * e + 2]
        rq = r0 + (r1 - r0) * s
        w = 0.5 * wq * (r1 - r0) * 2 * np.pi * rq
        loads[2 * e:2 * e + 3] += phi @ (w * values(e, s))
    return loads


def test_pressure_projection_recovers_a_quadratic_pressure_from_its_consistent_loads():
    # The P2 space holds p(r) = 3 - 0.4 r - 0.05 r² exactly, so the variational recovery
    # M p = λ returns it at the nodes from its consistent loads (computed here by 6-point
    # Gauss, exact for this degree-5 integrand). Graded nodes, as near a contact edge.
    # Measured: 1.3e-14 MPa (p ≈ 2-3 MPa); tolerance 3e-12. Row-sum lumping is off by
    # 0.1-4.8 % away from the axis, and on it the corner row sum ∫ φ_0 2πr dr is zero.
    corners = np.array([0.0, 0.4, 0.7, 1.2, 1.5, 1.6, 2.0, 2.9, 4.0])
    r = np.sort(np.concatenate([corners, 0.5 * (corners[1:] + corners[:-1])]))
    seg = np.stack([np.arange(0, len(r) - 2, 2), np.arange(1, len(r) - 1, 2),
                    np.arange(2, len(r), 2)], axis=1)

    def field(x):
        return 3.0 - 0.4 * x - 0.05 * x * x

    loads = _consistent_loads(r, lambda e, s: field(r[2 * e] + (r[2 * e + 2] - r[2 * e]) * s))
    p = project_pressure(_line_p2_mass(r, seg), loads)
    assert p == pytest.approx(field(r), rel=0, abs=1e-12 * 3.0)


def test_axisym_recovered_pressure_has_the_fe_contact_forces_as_consistent_loads():
    # The recovered pressure is the P2 field on the top whose consistent loads are the
    # FE nodal contact forces: its loads, integrated here node by node, must return
    # them. Medial layer at 0.2 mm (0.2 s). Measured: 3e-16 of the largest nodal force;
    # tolerance 1e-9 (round-off of a dense solve). Row-sum lumping misses by far more
    # (the axis row sum vanishes, see above).
    fe = axisym_sphere_on_layer(*MEDIAL, E, NU, H, size_mm=0.2)
    r, p, lam = fe.points[:, 0], fe.pressure_MPa, fe.nodal_force_N
    assert len(r) % 2 == 1 and np.all(np.diff(r) > 0)
    loads = _consistent_loads(r, lambda e, s: _p2_shape(s).T @ p[2 * e:2 * e + 3])
    assert np.abs(loads - lam).max() <= 1e-9 * lam.max()
    assert loads.sum() == pytest.approx(MEDIAL[0], rel=1e-9)


# ------------------------------------------------------------------ 3. Blankevoort law
def test_blankevoort_law_is_the_log_law_up_to_0_9h_and_its_tangent_line_beyond():
    # p = -k0 ln(1 - d/h), k0 = (1-ν)E/((1+ν)(1-2ν)), up to d = 0.9 h (including the band
    # 0.8 h-0.9 h), then the C¹ tangent line at 0.9 h. Written here from the formula.
    # Measured: 8e-16 relative; tolerance 1e-12.
    k0 = (1 - NU) * E / ((1 + NU) * (1 - 2 * NU))
    law = laws.blankevoort_pressure(E, NU, H)
    frac = np.array([0.01, 0.3, 0.6, 0.8, 0.82, 0.85, 0.88, 0.9])
    p, slope = law(frac * H)
    assert p == pytest.approx(-k0 * np.log(1 - frac), rel=1e-12)
    assert slope == pytest.approx(k0 / (H * (1 - frac)), rel=1e-12)
    beyond = np.array([0.9 + 1e-6, 0.92, 0.95, 1.0, 1.3])
    p, slope = law(beyond * H)
    pc, sc = -k0 * math.log(0.1), k0 / (0.1 * H)
    assert p == pytest.approx(pc + sc * (beyond - 0.9) * H, rel=1e-12)
    assert slope == pytest.approx(np.full(len(beyond), sc), rel=1e-12)
    assert laws.BLANKEVOORT_LINEAR_FROM == 0.9


# ------------------------------------------------------------- 4. ligament springs
K_LIG, EPS_T = 820.0, 0.06       # ACL bundle stiffness (N per unit strain), ε_t


def _spring_force(strain: np.ndarray) -> np.ndarray:
    """Blankevoort 1991 as OpenSim writes it: k ε²/(2 ε_t) up to ε_t, k (ε - ε_t/2) beyond."""
    e = np.asarray(strain, dtype=float)
    return np.where(e <= 0, 0.0, np.where(e < EPS_T, K_LIG * e * e / (2 * EPS_T),
                                          K_LIG * (e - EPS_T / 2)))


STRAINS = np.array([-0.05, 0.0, 0.005, 0.02, 0.04, 0.0599, 0.06, 0.0601, 0.08, 0.15])


def test_ligament_spring_force_is_the_blankevoort_toe_then_the_linear_region():
    # Values and slopes at strains in the slack, toe and linear regions; the curve is C¹
    # at ε_t. Measured: 0 (exact); tolerance 1e-12 (a toe ×4/3 is off by 33 %).
    f, df = blankevoort_tension(STRAINS, K_LIG, EPS_T)
    assert f == pytest.approx(_spring_force(STRAINS), rel=1e-12, abs=1e-12)
    slope = np.where(STRAINS <= 0, 0.0, np.where(STRAINS < EPS_T, K_LIG * STRAINS / EPS_T,
                                                  K_LIG))
    assert df == pytest.approx(slope, rel=1e-12, abs=1e-12)
    below, above = blankevoort_tension(np.array([EPS_T - 1e-9, EPS_T + 1e-9]), K_LIG, EPS_T)[0]
    assert below == pytest.approx(above, rel=1e-6)


def test_spring_ligament_pulls_the_tibia_point_toward_the_femur_with_that_force():
    # A spring of slack length l0 between a femur point P and a tibia point Q: at each
    # length l the wrench on the tibia is f((l - l0)/l0) along (P - x)/l at x, with its
    # moment x × F about the origin. The spring is built from a reference length and
    # strain as the models do (`spring_wrench`) and directly (`SpringLigament`).
    femur = np.array([3.5, -1.3, 22.2])
    tibia = np.array([-1.8, 13.8, 1.0])
    axis = (femur - tibia) / np.linalg.norm(femur - tibia)
    rest = float(np.linalg.norm(femur - tibia))
    l0 = rest / 1.03                                   # 3 % strain at the rest pose
    spring = spring_wrench(femur, tibia, rest, K_LIG, 0.03, EPS_T)
    same = SpringLigament(femur, tibia, l0, K_LIG, EPS_T)
    assert spring.slack_length_mm == pytest.approx(l0, rel=1e-14)
    rot = rotation(*np.radians([2.0, -3.0, 1.5]))
    for strain in STRAINS:
        # move the tibia so that Q sits at the length (1 + strain) l0 from P, turned
        t = femur - (1 + strain) * l0 * axis - rot @ tibia
        x = rot @ tibia + t
        force = _spring_force(strain) * axis
        wrench, _ = spring(rot, t)
        assert wrench[:3] == pytest.approx(force, rel=1e-9, abs=1e-9)
        assert wrench[3:] == pytest.approx(np.cross(x, force), rel=1e-9, abs=1e-7)
        assert same(rot, t)[0] == pytest.approx(wrench, rel=1e-12, abs=1e-9)
        assert same.tension((1 + strain) * l0) == pytest.approx(_spring_force(strain),
                                                                rel=1e-9, abs=1e-9)


def test_building_a_mesh_with_gmsh_leaves_broken_pipes_ignored():
    """Gmsh's initialisation restores SIGPIPE's default action (killing the process at a
    write to a closed pipe: a sweep's parent died that way, exit 141, about one run in
    three); the session ignores it again, as Python does, checked in the kernel's mask."""
    import subprocess
    import sys

    code = ("from geometry.gmsh_session import gmsh_session\n"
            "with gmsh_session('t') as g:\n"
            "    g.model.occ.addBox(0, 0, 0, 1, 1, 1)\n"
            "line = next(s for s in open('/proc/self/status') if s.startswith('SigIgn'))\n"
            "print(int(line.split()[1], 16) >> 12 & 1)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "1"
