"""Property-based checks (hypothesis) of the invariants of contact, laws and statics.

Each property is checked on a handful of drawn examples (`max_examples` small, no
deadline) so that the file stays within a few seconds.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from contact_helpers import central_difference
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from fecheck.contact import ContactPair, Plane, Sphere
from fecheck.laws import ef_stiffness, elastic_foundation
from fecheck.model.run import run_scene
from fecheck.reference.closed_forms import ef_sphere_plane
from fecheck.scene import load_scene
from fecheck.scene.knee import BASELINE_RIGHT
from fecheck.statics.load_control import load_controlled
from geometry.icosphere import icosphere
from geometry.plateau import plane_patch

R_MM = 25.5
K = ef_stiffness(20.0, 0.3, 6.0)
FEW = settings(max_examples=6, deadline=None)
UP = np.array([0.0, 0.0, 1.0])


def _sphere_over_patch(refine_mm: float = 0.5, refine_radius_mm: float = 12.0) -> ContactPair:
    """Analytic condyle sphere (radius 25.5 mm, resting on z = 0) over a meshed plateau."""
    patch = plane_patch((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), radius=refine_radius_mm + 3.0,
                        size=2.0, refine_point=(0.0, 0.0, 0.0), refine_size=refine_mm,
                        refine_radius=refine_radius_mm)
    return ContactPair(patch, Sphere((0.0, 0.0, R_MM), R_MM))


def _ef(surface):
    return elastic_foundation(surface, K)


def _solve(pair: ContactPair, force_N: float):
    """Load-controlled EF solve pushing the plateau up into the sphere: (result, δ mm)."""
    start = math.sqrt(force_N / (K * math.pi * R_MM))
    res, delta, _ = load_controlled(pair, _ef, UP, force_N, start)
    return res, delta


@pytest.fixture(scope="module")
def patch_pair() -> ContactPair:
    return _sphere_over_patch()


@pytest.fixture(scope="module")
def ico_pair() -> ContactPair:
    return ContactPair(icosphere(R_MM, 3, (0.0, 0.0, R_MM)), Plane([0, 0, 0], [0, 0, 1]))


rotations = st.tuples(*(st.floats(-math.pi, math.pi) for _ in range(3)))
shifts = st.tuples(*(st.floats(-200.0, 200.0) for _ in range(3)))


@FEW
@given(rotvec=rotations, shift=shifts, depth=st.floats(0.2, 1.5))
def test_contact_force_is_invariant_under_a_rigid_motion_of_both_bodies(
        ico_pair, rotvec, shift, depth):
    """Moving slave and master together by (Q, s) rotates the force by Q and moves the
    moment about the origin to Q M + s × Q F; area and depth do not change (to round-off:
    1e-9 relative, the coordinates are ~200 mm and the sums have ~100 terms)."""
    Q = Rotation.from_rotvec(rotvec).as_matrix()
    s = np.array(shift)
    slave = (Rotation.from_rotvec([0.02, -0.01, 0.0]).as_matrix(), np.array([0.3, 0, -depth]))
    base = _ef(ico_pair.evaluate(slave, (np.eye(3), np.zeros(3))))
    moved = _ef(ico_pair.evaluate((Q @ slave[0], Q @ slave[1] + s), (Q, s)))
    scale = np.linalg.norm(base.force)
    assert scale > 1.0
    np.testing.assert_allclose(moved.force, Q @ base.force, atol=1e-9 * scale)
    expected_moment = Q @ base.moment + np.cross(s, Q @ base.force)
    np.testing.assert_allclose(moved.moment, expected_moment,
                               atol=1e-9 * scale * (np.linalg.norm(s) + 100.0))
    assert moved.area == pytest.approx(base.area, rel=1e-9)
    assert moved.max_depth == pytest.approx(base.max_depth, rel=1e-9)


def _mirrored_landmarks() -> str:
    """BASELINE_RIGHT reflected through x = 0, as an inline TOML table (a left knee)."""
    def table(d):
        return "{" + ", ".join(f"{k} = [{-float(v[0])!r}, {float(v[1])!r}, {float(v[2])!r}]"
                               for k, v in d.items()) + "}"
    k = BASELINE_RIGHT
    return ("{" + f"condyle_center = {table(k.condyle_center)}, "
            f"contact_point = {table(k.contact_point)}, "
            f"femur_attachment = {table(k.femur_attachment)}, "
            f"tibia_attachment = {table(k.tibia_attachment)}" + "}")


@settings(max_examples=4, deadline=None)
@given(offset=st.floats(-8.0, 8.0), force=st.floats(200.0, 1500.0))
def test_mirrored_knee_gives_mirrored_forces(offset, force):
    """The right baseline knee with the load at x and its mirror image (a left knee, load
    at -x) give the same compartment forces, pressures and areas and the opposite
    abduction (a reflection through x = 0 flips rotations about y). The icosphere
    condyles (plane masters) are mirror-symmetric about x = 0 (the icosahedron has the
    coordinate planes as mirror planes, and midpoint refinement keeps them), so the two
    problems are mirror images exactly: agreement to the solver tolerance, 1e-6."""
    common = [f"load.force_N={force}", "contact.master=plateau"]
    right = run_scene(load_scene(overrides=common + [
        f"load.point_mm=[{7.9 + offset}, 12.8, -380.0]"]))
    left = run_scene(load_scene(overrides=common + [
        f"load.point_mm=[{-(7.9 + offset)}, 12.8, -380.0]", "knee.preset=custom",
        "knee.side=left", f"knee.landmarks={_mirrored_landmarks()}"]))
    assert right.converged and left.converged
    for c in ("medial", "lateral"):
        a, b = right.compartments[c], left.compartments[c]
        assert b.force_N == pytest.approx(a.force_N, rel=1e-6, abs=1e-6)
        assert b.area_mm2 == pytest.approx(a.area_mm2, rel=1e-6, abs=1e-6)
    assert left.pose["abduction_deg"] == pytest.approx(-right.pose["abduction_deg"],
                                                       rel=1e-6, abs=1e-9)
    assert left.pose["z_mm"] == pytest.approx(right.pose["z_mm"], rel=1e-6)


@FEW
@given(force=st.floats(2.0, 20.0))
def test_ef_depth_grows_as_the_square_root_of_the_load(force):
    """F = kπd²(R − d/3): for d ≪ R, d(4F)/d(F) = 2 up to the 1 + O(d/R) correction that
    the closed form carries. The solved approach δ must follow the closed-form ratio to
    0.5% (mesh 0.15 mm under the contact: the interpolation error of the depth field,
    h²/(8R), is ~0.1% of d) and lie within 2% of 2."""
    pair = _sphere_over_patch(refine_mm=0.15, refine_radius_mm=6.0)
    _, d1 = _solve(pair, force)
    _, d4 = _solve(pair, 4 * force)
    exact = (ef_sphere_plane(4 * force, R_MM, K)["max_depth_mm"]
             / ef_sphere_plane(force, R_MM, K)["max_depth_mm"])
    assert d4 / d1 == pytest.approx(exact, rel=5e-3)
    assert d4 / d1 == pytest.approx(2.0, rel=2e-2)


@FEW
@given(force=st.floats(50.0, 1500.0), factor=st.floats(1.05, 3.0))
def test_more_load_gives_more_contact_area_and_pressure(patch_pair, force, factor):
    """Area and peak pressure grow strictly with the load (A ∝ √F for small depth, so a
    5% load step moves the area by ≈ 2.5%, far above the solver tolerance)."""
    low, _ = _solve(patch_pair, force)
    high, _ = _solve(patch_pair, force * factor)
    assert high.area > low.area * (1 + 0.2 * (factor - 1))
    assert high.max_pressure > low.max_pressure


def _wrench(pair, pose):
    res = _ef(pair.evaluate(pose, (np.eye(3), np.zeros(3))))
    return np.concatenate([res.force, res.moment])


@FEW
@given(depth=st.floats(0.3, 1.5), tilt=st.tuples(st.floats(-0.05, 0.05), st.floats(-0.05, 0.05)),
       slide=st.tuples(st.floats(-2.0, 2.0), st.floats(-2.0, 2.0)))
def test_analytic_contact_tangent_matches_finite_differences(patch_pair, ico_pair, depth, tilt,
                                                            slide):
    """d[F, M]/dξ of the EF law (twist ξ of the slave) against central differences with
    h = 1e-6: they agree to 1e-5 relative (truncation O(h²) and round-off ~1e-16·|W|/h
    are both below 1e-7 of |T|), for a meshed plateau under an analytic sphere and for an
    icosphere over an analytic plane."""
    rot = Rotation.from_rotvec([tilt[0], tilt[1], 0.0]).as_matrix()
    for pair, sign in ((patch_pair, 1.0), (ico_pair, -1.0)):
        pose = (rot, np.array([slide[0], slide[1], sign * depth]))
        tangent = _ef(pair.evaluate(pose, (np.eye(3), np.zeros(3)))).tangent
        fd = central_difference(lambda p, pair=pair: _wrench(pair, p), pose, h=1e-6)
        assert np.linalg.norm(tangent) > 1.0
        assert np.linalg.norm(fd - tangent) <= 1e-5 * np.linalg.norm(tangent)
