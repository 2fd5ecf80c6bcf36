"""The hierarchical winding number, the side grid and the menisci solve they speed up.

References: a face-by-face sum of solid angles written here in plain NumPy (the obvious
version), the cube's winding numbers (1 inside, 0 outside), and the femur_tibia_menisci
solve with every side taken from libigl's winding number.
"""

from __future__ import annotations

import igl
import numpy as np
import pytest

from fecheck.contact import winding
from fecheck.contact.mesh_master import MeshMaster
from fecheck.contact.winding import SideGrid, WindingTree, face_winding
from fecheck.model import menisci
from fecheck.scene import load_scene
from geometry.mesh import TriMesh

CUBE_QUADS = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4),
              (1, 5, 7, 3)]


def numpy_winding(points: np.ndarray, faces: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Σ_f Ω_f(q) / 4π face by face (Van Oosterom & Strackee), plain NumPy, 100 points at
    a time."""
    out = []
    for chunk in np.array_split(q, max(1, len(q) // 100)):
        a, b, c = (points[faces[:, k]][None] - chunk[:, None] for k in range(3))
        la, lb, lc = (np.linalg.norm(v, axis=2) for v in (a, b, c))
        det = np.einsum("ijk,ijk->ij", a, np.cross(b, c))
        den = (la * lb * lc + np.einsum("ijk,ijk->ij", a, b) * lc
               + np.einsum("ijk,ijk->ij", b, c) * la + np.einsum("ijk,ijk->ij", c, a) * lb)
        out.append(2.0 * np.arctan2(det, den).sum(axis=1) / (4.0 * np.pi))
    return np.concatenate(out)


@pytest.fixture(scope="module")
def meniscus():
    folder = menisci.menisci_dir(load_scene("femur_tibia_menisci"))
    return menisci.read_volume(folder, "medial")


def _probes(mesh: TriMesh, n: int, sigma_mm: float, seed: int = 0) -> np.ndarray:
    """Points scattered about the mesh's vertices (most within 2 sigma of the surface)
    and through its box grown by 3 mm."""
    rng = np.random.default_rng(seed)
    near = mesh.points[rng.integers(0, mesh.n_points, n)] + rng.normal(0, sigma_mm, (n, 3))
    box = rng.uniform(mesh.points.min(axis=0) - 3, mesh.points.max(axis=0) + 3, (n, 3))
    return np.concatenate([near, box])


def test_cube_winding_is_one_inside_and_zero_outside():
    cube = np.array([[x, y, z] for x in (0., 1) for y in (0., 1) for z in (0., 1)])
    tri = np.array([t for a, b, c, d in CUBE_QUADS for t in ((a, b, c), (a, c, d))])
    q = np.array([[0.5, 0.5, 0.5], [0.01, 0.99, 0.5], [1.01, 0.5, 0.5], [3.0, -2.0, 0.5]])
    np.testing.assert_allclose(WindingTree(TriMesh(cube, tri))(q), [1, 1, 0, 0], atol=1e-12)


def test_tree_equals_the_face_by_face_sum_on_the_meniscus(meniscus):
    """3,124 faces, 4,000 points: every node's fan stands for its faces exactly, so the
    tree differs from the face sum by rounding only (measured 1.3e-14); both kernels
    against the NumPy reference."""
    q = _probes(meniscus, 2000, 0.3)
    ref = numpy_winding(meniscus.points, meniscus.faces, q)
    assert 0.2 < (ref > 0.5).mean() < 0.8               # both sides probed
    np.testing.assert_allclose(WindingTree(meniscus)(q), ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(face_winding(meniscus.points, meniscus.faces.astype(np.int64),
                                            q), ref, rtol=0, atol=1e-12)


def test_tree_is_exact_on_an_open_sheet_too(meniscus):
    """Half the meniscus (an open sheet): fractional winding numbers, which only the
    exact fan identity reproduces (a fan oriented the wrong way, or a boundary that
    drops an edge, is off by O(1))."""
    half = TriMesh(meniscus.points, meniscus.faces[: meniscus.n_faces // 2])
    q = _probes(meniscus, 1000, 1.0, seed=1)
    ref = numpy_winding(half.points, half.faces, q)
    assert np.abs(ref - np.round(ref)).max() > 0.1      # non-integer values probed
    np.testing.assert_allclose(WindingTree(half)(q), ref, rtol=0, atol=1e-12)


def test_side_grid_answers_far_points_and_only_with_the_true_side(meniscus):
    master = MeshMaster(meniscus, "winding")
    tables = SideGrid.tables(master._V, 1.0, master.distance_mm, master._winding)
    q = _probes(meniscus, 3000, 1.0, seed=2)
    answered, inside = SideGrid.sides(*tables, q)
    truth = numpy_winding(meniscus.points, meniscus.faces, q) > 0.5
    np.testing.assert_array_equal(inside[answered], truth[answered])
    dist = master.distance_mm(q)
    in_box = np.all((q >= tables[0][:3]) & (q <= tables[0][:3] + (tables[1] - 1)), axis=1)
    # a point over a 1 mm cell's diagonal from the surface is within half of it from its
    # node, whose empty ball then holds it
    assert answered[in_box & (dist > np.sqrt(3.0) + 1e-6)].all()
    assert not answered[dist < 1e-3].any()


def test_side_grid_bounds_hold_the_signed_distance(meniscus):
    master = MeshMaster(meniscus, "winding")
    tables = SideGrid.tables(master._V, 1.0, master.distance_mm, master._winding)
    q = _probes(meniscus, 3000, 1.5, seed=4)
    lower, upper = SideGrid.bounds(*tables, q)
    signed = master.reach(q)
    assert np.all(lower <= signed) and np.all(signed <= upper)
    on_grid = np.isfinite(lower)
    assert on_grid.mean() > 0.9
    assert np.all((upper - lower)[on_grid] <= np.sqrt(3.0) + 1e-6)    # twice the half diagonal


def _no_grid(*tables):
    n = len(tables[-1])
    return np.zeros(n, bool), np.zeros(n, bool)


def test_margin_reach_tells_reach_above_minus_margin_like_the_signed_distance(meniscus,
                                                                              monkeypatch):
    """With the grid's bounds: the same answers as the signed distance; without them, none
    of the points within the margin is sent to the winding number."""
    master = MeshMaster(meniscus, "winding")
    q = _probes(meniscus, 3000, 1.5, seed=3)
    signed = master.reach(q)
    assert 0.1 < (signed > -2.0).mean() < 0.9
    np.testing.assert_array_equal(master.margin_reach(2.0)(q) > -2.0, signed > -2.0)
    asked = []
    tree = master._winding
    monkeypatch.setattr(master, "_winding", lambda p: asked.append(p) or tree(p))
    monkeypatch.setattr(SideGrid, "sides", staticmethod(_no_grid))
    monkeypatch.setattr(SideGrid, "bounds", staticmethod(
        lambda *a: (np.full(len(a[-1]), -np.inf), np.full(len(a[-1]), np.inf))))
    near = master.margin_reach(2.0)(q)
    np.testing.assert_array_equal(near > -2.0, signed > -2.0)
    assert len(asked) == 1 and len(asked[0]) == int((np.abs(signed) >= 2.0).sum())


def _solve(scene):
    problem, interfaces, springs, _, sides, _ = menisci.build_problem(scene)
    sol = menisci.solve(problem)
    poses = [menisci.body_pose(q) for q in sol.q]
    return sol, menisci._shares(interfaces, poses, sides), menisci.balance(problem, sol.q)


def test_menisci_solve_equals_the_libigl_winding_solve(monkeypatch):
    """femur_tibia_menisci at 800 N with the grid, the tree and the broad phase's
    bounds and unsigned margin, against every point's side from libigl's winding number (the path
    before them): the same
    poses, forces and shares (1e-9 relative), each balanced to 1e-8 of the load."""
    scene = load_scene("femur_tibia_menisci")
    fast, fast_rows, fast_balance = _solve(scene)
    monkeypatch.setattr(winding.WindingTree, "__call__",
                        lambda self, p: igl.winding_number(self._points, self._faces, p))
    monkeypatch.setattr(SideGrid, "sides", staticmethod(_no_grid))
    monkeypatch.setattr(MeshMaster, "margin_reach", lambda self, margin: self.reach)
    ref, ref_rows, ref_balance = _solve(scene)
    assert fast.converged and ref.converged
    for q_fast, q_ref in zip(fast.q, ref.q, strict=True):
        np.testing.assert_allclose(q_fast, q_ref, rtol=1e-9, atol=1e-9)
    for comp, row in ref_rows.items():
        for key, value in row.items():
            assert fast_rows[comp][key] == pytest.approx(value, rel=1e-9, abs=1e-9), key
    load = scene["load.force_N"]
    assert max(fast_balance.values()) <= 1e-8 * load
    assert max(ref_balance.values()) <= 1e-8 * load
