"""The FE contact core (fecheck.fe.contact) against independent solutions: the active
set against non-negative least squares, the node-to-surface operator against the gap's
definition, the candidates' rounds on a hand-made sequence, and poses' identities."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.linalg import cholesky, solve_triangular
from scipy.optimize import nnls
from scipy.spatial.transform import Rotation

from fecheck.fe.bodies.pose import FramePose
from fecheck.fe.contact.active_set import active_set, settled
from fecheck.fe.contact.candidates import Outcome, Round, widened
from fecheck.fe.contact.condense import CondensedBodies, ElasticBody, Pair
from fecheck.fe.contact.gap import (
    kept_dofs,
    nodal_displacements,
    surface_entries,
    surface_give,
)


def _compliance(m: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(m, m))
    return 0.01 * (a @ a.T / m + np.eye(m))


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_active_set_finds_the_lcp_solution_nnls_gives(seed):
    # Without rigid unknowns the complementarity g0 + Cλ ≥ 0, λ ≥ 0, λ·g = 0 is the
    # optimality of min ½λᵀCλ + g0ᵀλ over λ ≥ 0, i.e. (C = L Lᵀ) the non-negative least
    # squares min |Lᵀλ + L⁻¹g0|: scipy's NNLS (Lawson-Hanson) solves it independently.
    # Measured agreement ~1e-13 N on forces of ~10 N.
    m = 40
    C = _compliance(m, seed)
    g0 = np.random.default_rng(seed + 10).uniform(-0.08, 0.1, m)
    L = cholesky(C, lower=True)
    exact, _ = nnls(L.T, -solve_triangular(L, g0, lower=True), maxiter=50 * m)
    assert 0 < (exact > 0).sum() < m
    # From the deepest candidate alone (the set must grow) and from every candidate (it
    # must shrink).
    for start in (g0 == g0.min(), np.ones(m, dtype=bool)):
        lam, dq, active, _ = active_set(C, g0, np.zeros((m, 0)), np.zeros((m, 0)),
                                        np.zeros(0), np.zeros((0, 0)), start, 100, "")
        assert dq.shape == (0,)
        np.testing.assert_allclose(lam, exact, rtol=0, atol=1e-9)
        assert np.array_equal(active, exact > 0)
        gap = g0 + C @ lam
        assert gap.min() > -1e-12 and abs(lam @ gap) < 1e-12


def test_the_fallbacks_reach_the_same_answer_under_load_control():
    # A plate pushed with 100 N onto a coupled bed: the block update and the fallbacks
    # of `settled` solve one complementarity: the same forces, summing to the load. With
    # one block iteration allowed from every candidate in, both block tries stop short
    # and the one-at-a-time changes must finish.
    m = 30
    C = _compliance(m, 7)
    g0 = np.random.default_rng(8).uniform(0.0, 0.3, m)
    J = G = np.ones((m, 1))
    Q, dQ = np.array([-100.0]), np.zeros((1, 1))
    deepest = g0 == g0.min()
    lam_b, dq_b, _, _ = active_set(C, g0, J, G, Q, dQ, deepest, 200, "")
    lam_s, dq_s, _, it = settled(C, g0, J, G, Q, dQ, np.ones(m, dtype=bool), 1, "")
    assert it > 1
    np.testing.assert_allclose(lam_s, lam_b, rtol=0, atol=1e-9)
    assert lam_s.sum() == pytest.approx(100.0, rel=1e-12)
    assert dq_s == pytest.approx(dq_b, rel=1e-10)


def test_the_node_to_surface_rows_read_the_gap_change_by_its_definition():
    # Slave nodes 0-3 of a 12-node body (3 dofs each, node 5's z fixed) meet faces of
    # nodes 4-11 at random barycentric points: the rows (master w_a n, slave -n) times the
    # kept-dof displacements must equal (Σ w_a u_a − u_s)·n node by node.
    rng = np.random.default_rng(4)
    node_dofs = np.arange(36).reshape(12, 3)
    node_dofs[5, 2] = -1
    node_dofs[node_dofs > 17] -= 1
    u = rng.normal(size=35)
    slaves = np.arange(4)
    faces = np.array([rng.choice(np.arange(4, 12), 3, replace=False) for _ in range(4)])
    w = rng.uniform(0.1, 1.0, (4, 3))
    w /= w.sum(axis=1, keepdims=True)
    n = rng.normal(size=(4, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    rows = np.arange(4)
    entries = [surface_entries(rows, faces, w, n, kept_dofs(node_dofs)),
               surface_entries(rows, slaves[:, None], -np.ones((4, 1)), n,
                               kept_dofs(node_dofs))]
    r, c, v = (np.concatenate(x) for x in zip(*entries, strict=True))
    D = sp.csr_matrix((v, (r, c)), shape=(4, 35))
    disp = nodal_displacements(node_dofs, u, np.arange(12))
    assert disp[5, 2] == 0.0
    expected = np.einsum("mk,mkc,mc->m", w, disp[faces], n) - np.einsum(
        "mc,mc->m", disp[slaves], n)
    np.testing.assert_allclose(D @ u, expected, rtol=0, atol=1e-13)
    np.testing.assert_allclose(surface_give(disp[faces], w, n) - np.einsum(
        "mc,mc->m", disp[slaves], n), expected, rtol=0, atol=1e-13)


def test_the_candidates_widen_until_no_vertex_penetrates():
    # Ten vertices; vertex 5 penetrates while it is not a candidate (gap -1 mm), vertex 6
    # stays 0.3 mm off, the others 2 mm; a candidate sits at +0.1 mm. Margin 0.5 mm: the
    # first round on vertices 0-2 leaves 5 penetrating, so 5 and 6 (under the margin)
    # join, and the second round settles.
    calls = []

    def solve(cands):
        calls.append(sorted(cands["a"].tolist()))
        gaps = np.full(10, 2.0)
        gaps[[5, 6]] = -1.0, 0.3
        gaps[cands["a"]] = 0.1
        return Round(None, {"a": gaps}, float(max(0.0, -gaps.min())))

    result, outcome, cands = widened(solve, {"a": np.arange(3)}, 0.5, 4, 1e-6)
    assert outcome is Outcome.SETTLED and calls == [[0, 1, 2], [0, 1, 2, 5, 6]]
    assert result.worst == 0.0 and cands["a"].tolist() == [0, 1, 2, 5, 6]

    def deaf(cands):        # a penetration that widening cannot reach (gap above margin)
        return Round(None, {"a": np.full(10, 1.0)}, 0.3)

    assert widened(deaf, {"a": np.arange(3)}, 0.5, 4, 1e-6)[1] is Outcome.STUCK
    repaired = lambda cands: Round(None, {"a": np.full(10, 1.0)}, 0.3, repaired=2)  # noqa: E731
    assert widened(repaired, {"a": np.arange(3)}, 0.5, 3, 1e-6)[1] is Outcome.EXHAUSTED


def _random_pose(seed: int, frame: str, body: str) -> FramePose:
    rng = np.random.default_rng(seed)
    return FramePose(Rotation.random(random_state=seed).as_matrix(), rng.normal(size=3) * 50.0,
                frame, body)


def test_poses_compose_and_invert_as_rigid_motions():
    X_WT = _random_pose(1, "W", "T")
    X_TM = _random_pose(2, "T", "M")
    X_MF = _random_pose(3, "M", "F")
    p_F = np.random.default_rng(4).normal(size=(5, 3))
    # A point carried through the chain one pose at a time, and by the composed pose.
    X_WF = X_WT @ X_TM @ X_MF
    assert X_WF.name == "X_WF"
    np.testing.assert_allclose(X_WF.points(p_F), X_WT.points(X_TM.points(X_MF.points(p_F))),
                               atol=1e-12)
    np.testing.assert_allclose((X_WT @ (X_TM @ X_MF)).translation, X_WF.translation,
                               atol=1e-12)
    # X_WT @ X_TW is the identity of W, and the inverse undoes the pose on points.
    one = X_WT @ X_WT.inverse()
    assert (one.frame, one.body) == ("W", "W")
    np.testing.assert_allclose(one.rotation, np.eye(3), atol=1e-14)
    np.testing.assert_allclose(one.translation, 0.0, atol=1e-12)
    np.testing.assert_allclose(X_WT.inverse().points(X_WT.points(p_F)), p_F, atol=1e-12)
    # By hand: T turned 90° about z and moved by (1, 2, 3) mm; T's x axis is W's y.
    quarter = FramePose(Rotation.from_euler("z", 90, degrees=True).as_matrix(),
                   np.array([1.0, 2.0, 3.0]))
    np.testing.assert_allclose(quarter.points(np.array([[1.0, 0.0, 0.0]])),
                               [[1.0, 3.0, 3.0]], atol=1e-15)
    np.testing.assert_allclose(quarter.vectors(np.array([[1.0, 0.0, 0.0]])),
                               [[0.0, 1.0, 0.0]], atol=1e-15)
    with pytest.raises(ValueError, match="not in frame T"):
        X_WT @ X_MF


def _spd(n: int, seed: int) -> sp.csc_matrix:
    """A sparse symmetric positive definite stiffness (N/mm) of n dofs."""
    rng = np.random.default_rng(seed)
    a = sp.random(n, n, density=0.3, random_state=rng)
    return sp.csc_matrix(a @ a.T + n * sp.eye(n))


def _unit(rng: np.random.Generator, m: int) -> np.ndarray:
    v = rng.normal(size=(m, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@pytest.mark.parametrize("solver", ["cholmod", "superlu"])
def test_condensed_bodies_match_the_dense_compliance_of_each_side(solver):
    # A slave (12 nodes) and a master (10 nodes) in different frames: the slave's rows read
    # its nodes along its normals, the master's along its own (rotated) normals at the
    # weighted nodes of the faces hit, and a row of weight 0 reads no master. C must be
    # D_s K_s⁻¹ D_sᵀ + D_m K_m⁻¹ D_mᵀ by dense inverses, whichever path condenses each
    # body (the normal compliance or block solves for the slave, the nodal one for the
    # master, held before any pair reads it). Measured agreement ~1e-16 mm/N.
    rng = np.random.default_rng(4)
    Ks, Km = _spd(36, 1), _spd(30, 2)
    slave = ElasticBody("slave", Ks, np.arange(36).reshape(12, 3))
    master = ElasticBody("master", Km, np.arange(30).reshape(10, 3))
    m = 8
    nodes = rng.choice(12, m, replace=False)
    normals = _unit(rng, m)
    turned = normals @ Rotation.from_rotvec([0.3, -0.2, 0.5]).as_matrix().T
    hit = np.array([rng.choice(10, 3, replace=False) for _ in range(m)])
    weights = rng.dirichlet(np.ones(3), m)
    weights[2] = 0.0                                       # a row that reads no master
    pair = Pair("p", "slave", nodes, normals, np.zeros(m), "master", hit, weights,
                master_normals=turned)
    held = {"master": np.arange(30)}
    condensed = CondensedBodies([slave, master], [pair], solver=solver, held=held)
    D_s, D_m = np.zeros((m, 36)), np.zeros((m, 30))
    for i in range(m):
        D_s[i, 3 * nodes[i]:3 * nodes[i] + 3] = -normals[i]
        for a, w in zip(hit[i], weights[i], strict=True):
            D_m[i, 3 * a:3 * a + 3] += w * turned[i]
    expected = (D_s @ np.linalg.solve(Ks.toarray(), D_s.T)
                + D_m @ np.linalg.solve(Km.toarray(), D_m.T))
    np.testing.assert_allclose(condensed.C, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    lam = rng.uniform(0.0, 5.0, m)
    u = condensed.displacements(lam)
    np.testing.assert_allclose(u["master"], np.linalg.solve(Km.toarray(), D_m.T @ lam),
                               atol=1e-12)
    again = CondensedBodies([slave, master], [pair], solver=solver, held=held, reuse=condensed)
    assert again.kept["master"].solve is condensed.kept["master"].solve  # no new factor
