"""The statics' hot path (`fecheck.laws.fused`) gives the full path's force, moment,
tangent, area and depth (the law on a `ContactSurface`) to 1e-12, for every compiled
master and law, from a rebuilt and from a reused candidate set."""

import numpy as np
import pytest

from fecheck.contact import ContactPair, Plane, Sphere
from fecheck.laws import blankevoort_params, blankevoort_pressure, foundation
from fecheck.laws.calibrated import Calibration, calibrated_params, calibrated_pressure
from fecheck.laws.fused import (
    CompiledLaw,
    HotPath,
    Wrench,
    compiled_law,
    contact_wrench,
    linear_law,
)
from fecheck.laws.kernel import BLANKEVOORT, CALIBRATED
from fecheck.laws.layer import face_elastic_foundation
from fecheck.statics.frames import rotation
from geometry.icosphere import icosphere
from geometry.plateau import plane_patch

CAL = Calibration(5.3, 0.57)
LAWS = {
    "linear": lambda n: linear_law(4.487),
    "blankevoort": lambda n: compiled_law(
        BLANKEVOORT, blankevoort_params(5.0, 0.45, 3.0),
        lambda s: foundation(s, blankevoort_pressure(5.0, 0.45, 3.0))),
    "calibrated": lambda n: compiled_law(
        CALIBRATED, calibrated_params(CAL), lambda s: foundation(s, calibrated_pressure(CAL))),
    "per-face": lambda n: face_elastic_foundation(np.linspace(2.0, 6.0, n)),
}


def _same(fast, res):
    """Equal to 1e-12 of each quantity's scale (moments: |F| times the 50 mm the
    points are from the origin, as a symmetric contact's moment is round-off)."""
    scale = np.abs(res.tangent).max()
    force = np.abs(res.force).max()
    np.testing.assert_allclose(fast.force, res.force, rtol=1e-12, atol=1e-12 * force)
    np.testing.assert_allclose(fast.moment, res.moment, rtol=1e-12,
                               atol=1e-12 * max(np.abs(res.moment).max(), 50.0 * force))
    np.testing.assert_allclose(fast.tangent, res.tangent, rtol=1e-12, atol=1e-12 * scale)
    assert fast.area == pytest.approx(res.area, rel=1e-12)
    assert fast.max_depth == res.max_depth


def _check(pair, poses, law, master_pose):
    for pose in poses:                  # the first rebuilds the set, the others reuse it
        fast = contact_wrench(pair, pose, master_pose, law)
        full = law(pair.evaluate(pose, master_pose))
        assert np.linalg.norm(full.force) > 1.0
        _same(fast, full)


@pytest.mark.parametrize("name", sorted(LAWS))
@pytest.mark.parametrize("area", ["clipped", "whole-face"])
def test_plane_master(name, area):
    mesh = icosphere(25.5, 3)
    pair = ContactPair(mesh, Plane([0.0, 0.0, 0.0], [0.1, 0.0, 1.0]), area=area)
    poses = [(rotation(0.02 * i, -0.01, 0.03), np.array([0.1, 0.0, 24.3 + 0.05 * i]))
             for i in range(3)]
    _check(pair, poses, LAWS[name](mesh.n_faces), (np.eye(3), np.zeros(3)))


@pytest.mark.parametrize("name", sorted(LAWS))
def test_sphere_master_over_a_plateau(name):
    plate = plane_patch([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], radius=20.0, size=1.0)
    pair = ContactPair(plate, Sphere([0.0, 0.0, 30.0], 31.0))
    poses = [(rotation(0.01 * i, 0.02, 0.0), np.array([0.2, -0.1, 0.05 * i]))
             for i in range(3)]
    _check(pair, poses, LAWS[name](plate.n_faces), (np.eye(3), np.zeros(3)))


@pytest.mark.parametrize("name", ["linear", "calibrated", "per-face"])
def test_mesh_master_walked_and_rebuilt(name):
    slave = icosphere(25.5, 3)
    master = icosphere(30.0, 4)
    pair = ContactPair(slave, master)
    master_pose = (np.eye(3), np.array([0.0, 0.0, -30.0 - 24.5]))
    poses = [(rotation(0.0, 0.01 * i, 0.0), np.array([0.0, 0.02 * i, 0.0])) for i in range(4)]
    _check(pair, poses, LAWS[name](slave.n_faces), master_pose)


def test_no_contact_and_a_wrong_face_count():
    mesh = icosphere(25.5, 2)
    pair = ContactPair(mesh, Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]))
    far = (np.eye(3), np.array([0.0, 0.0, 40.0]))
    w = contact_wrench(pair, far, (np.eye(3), np.zeros(3)), linear_law(1.0))
    assert w.area == 0.0 and w.max_depth == 0.0 and not w.tangent.any()
    wrong = face_elastic_foundation(np.ones(mesh.n_faces + 1))
    assert isinstance(wrong, CompiledLaw)
    with pytest.raises(Exception, match="face stiffnesses"):
        contact_wrench(pair, far, (np.eye(3), np.zeros(3)), wrong)


def test_a_bound_hot_path_takes_poses_of_any_array_kind():
    """The bound path calls the compiled function without numba's per-call typing, so the
    poses must reach it converted to contiguous float arrays: lists, integer, read-only,
    Fortran-ordered and strided poses give the float poses' wrench, bit for bit."""
    pair = ContactPair(icosphere(25.5, 3), Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]))
    hot = HotPath(pair, linear_law(1.12))
    R, t, master = np.eye(3), np.array([0.0, 0.0, 24.5]), (np.eye(3), np.zeros(3))
    ref = hot.evaluate((R, t), master)
    assert ref.force[2] > 50.0
    frozen_R, frozen_t = R.copy(), t.copy()
    frozen_R.flags.writeable = frozen_t.flags.writeable = False
    kinds = [(R.tolist(), t.tolist()), (np.eye(3, dtype=int), t), (frozen_R, frozen_t),
             (np.asfortranarray(R), t), (np.eye(6)[::2, ::2], np.repeat(t, 2)[::2])]
    for pose in kinds:
        pair.cache.reset()
        assert np.array_equal(hot.evaluate(pose, master).packed, ref.packed)


@pytest.mark.parametrize("area", ["clipped", "whole-face"])
def test_plane_linear_law_rebuilt_every_call_equals_the_full_path(area):
    """The plane's linear-law pass (`plane_linear_wrench`) on a set rebuilt at every call
    as ranks only: equal to the full path (which then gathers that set's face data) at
    poses more than the margin apart, with a moved master; the same wrench from a set
    that is reused instead."""
    mesh = icosphere(25.5, 3)
    plane = Plane([0.0, 0.0, 0.0], [0.1, -0.05, 1.0])
    scratch, reused = (ContactPair(mesh, plane, area=area) for _ in range(2))
    law = linear_law(1.12)
    hot, hot_reused = HotPath(scratch, law), HotPath(reused, law)
    master = (rotation(0.05, 0.1, -0.2), np.array([1.0, -2.0, 0.5]))
    for i in range(4):
        pose = (master[0] @ rotation(0.03 * i, -0.02, 0.04 * i),
                master[1] + master[0] @ np.array([3.0 * i, -2.5 * i, 24.2 + 0.1 * i]))
        scratch.cache.reset()
        fast = Wrench(hot.evaluate(pose, master).packed.copy())
        assert scratch.cache.n_rebuilds == i + 1
        _same(fast, law(scratch.evaluate(pose, master)))
        assert scratch.cache.n_rebuilds == i + 1             # the full path reused the set
        _same(hot_reused.evaluate(pose, master), law(scratch.evaluate(pose, master)))


def test_a_rank_only_rebuild_gathers_the_tree_query_when_asked():
    """After the compiled path rebuilt the set as ranks only, the cache's `current` set is
    the tree's region query (`PointTree.faces_in`) at that relative pose, array for array."""
    mesh = icosphere(25.5, 4)
    pair = ContactPair(mesh, Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]))
    hot = HotPath(pair, linear_law(1.12))
    for i in range(3):
        R, t = rotation(0.1 * i, 0.05, -0.1 * i), np.array([4.0 * i, 0.0, 24.0])
        pair.cache.reset()
        hot.evaluate((R, t), (np.eye(3), np.zeros(3)))
        kind, params = pair.cache.region
        expected = pair.cache.tree.faces_in(kind, params, R, t)
        for got, want in zip(pair.cache.current, expected, strict=True):
            np.testing.assert_array_equal(got, want)
        assert 0 < expected[0].size < mesh.n_faces / 4
