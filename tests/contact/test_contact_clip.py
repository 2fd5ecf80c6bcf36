"""Exact clipping of a linear depth field on a triangle."""

import numpy as np
import pytest

from fecheck.contact.clip import clipped_quadrature, whole_face_quadrature


def _positive_part_integrals(d):
    """Closed forms of (∫ [d>0] dA, ∫ max(d, 0) dA) / A for a linear field on a triangle.

    With one vertex i positive: fraction d_i² / ((d_i - d_j)(d_i - d_k)) and integral
    d_i³ / (3 (d_i - d_j)(d_i - d_k)); with two positive, the complement of the lone
    negative vertex's part, subtracted from the whole (mean d/3·Σ).
    """
    pos = d > 0
    if pos.all():
        return 1.0, d.sum() / 3.0

    def single(i):
        j, k = (i + 1) % 3, (i + 2) % 3
        den = (d[i] - d[j]) * (d[i] - d[k])
        return d[i] ** 2 / den, d[i] ** 3 / (3 * den)

    if pos.sum() == 1:
        return single(int(np.argmax(pos)))
    frac, integral = single(int(np.argmin(pos)))
    return 1.0 - frac, d.sum() / 3.0 - integral


@pytest.mark.parametrize("seed", range(5))
def test_clipped_area_and_depth_integral_match_closed_forms(seed):
    rng = np.random.default_rng(seed)
    depth = rng.normal(size=(400, 3))
    depth[:20, 0] = 0.0                                      # vertices exactly at zero
    depth = depth[(depth > 0).any(axis=1)]
    qp_face, bary, qfrac = clipped_quadrature(depth)
    area = np.bincount(qp_face, qfrac, minlength=len(depth))
    integral = np.bincount(qp_face, qfrac * np.einsum("qi,qi->q", bary, depth[qp_face]),
                           minlength=len(depth))
    ref = np.array([_positive_part_integrals(d) for d in depth])
    np.testing.assert_allclose(area, ref[:, 0], rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(integral, ref[:, 1], rtol=1e-11, atol=1e-14)


def test_rule_is_exact_for_quadratic_integrands():
    # ∫ d² dA over the positive part: compare with a 4^7-subtriangle centroid rule
    # refined reference; the degree-2 rule is exact, the reference converges like h².
    depth = np.array([[1.3, -0.4, 0.7]])
    _, bary, qfrac = clipped_quadrature(depth)
    exact = (qfrac * (bary @ depth[0]) ** 2).sum()
    n = 400
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    keep = i + j < n
    b1, b2 = (i[keep] + 1 / 3) / n, (j[keep] + 1 / 3) / n
    b1u, b2u = (i[keep] + 2 / 3) / n, (j[keep] + 2 / 3) / n
    up = i[keep] + j[keep] < n - 1
    pts = np.concatenate([np.column_stack([1 - b1 - b2, b1, b2]),
                          np.column_stack([1 - b1u - b2u, b1u, b2u])[up]])
    vals = np.maximum(pts @ depth[0], 0) ** 2
    reference = vals.sum() / n**2
    assert exact == pytest.approx(reference, rel=2e-4)   # reference error ~ 1/n²


def test_whole_faces_cover_each_face_once():
    qp_face, bary, qfrac = whole_face_quadrature(4)
    np.testing.assert_allclose(np.bincount(qp_face, qfrac), 1.0)
    np.testing.assert_allclose(bary.sum(axis=1), 1.0)
