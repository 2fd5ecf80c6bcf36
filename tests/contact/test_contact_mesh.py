"""Mesh masters (libigl AABB), open meshes, and the thesis's own algorithms."""


import numpy as np
import pytest
from contact_helpers import IDENTITY, box, crop, volume

from fecheck.contact import ContactPair, Plane
from fecheck.errors import FecheckError
from geometry.icosphere import icosphere
from geometry.mesh import TriMesh
from geometry.plateau import plane_patch

R = 31.8
CONDYLE = icosphere(R, 4)
POSE = (np.eye(3), np.array([0.3, 0.2, R - 1.0]))
BOX = box([-40.0, -40.0, -20.0], [40.0, 40.0, 0.0])        # closed master, top at z = 0
SHEET = plane_patch([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], radius=40.0, size=4.0)   # open


def _centroids(mesh, s):
    return np.sort(np.round(mesh.face_centroids[s.face], 9), axis=0)


def test_open_slave_and_open_master_give_the_closed_result():
    lower = crop(CONDYLE, lambda c: c[:, 2] < -R / 2)       # open cap of the condyle
    closed = ContactPair(CONDYLE, BOX).evaluate(POSE, IDENTITY)
    opened = ContactPair(lower, SHEET).evaluate(POSE, IDENTITY)
    assert closed.n_faces > 50
    np.testing.assert_allclose(_centroids(lower, opened), _centroids(CONDYLE, closed))
    np.testing.assert_allclose(np.sort(opened.qp_depth), np.sort(closed.qp_depth), atol=1e-9)
    assert opened.area == pytest.approx(closed.area, rel=1e-12)


@pytest.mark.parametrize("method", ["ray-parity", "fcl"])
def test_methods_that_need_a_closed_master_refuse_an_open_one(method):
    # ray parity lets rays escape through an open sheet (it found under half the contact
    # faces) and FCL's penetration of an open sheet converged to 63 MPa where the answer
    # is 13.6: both refuse it, naming the method that works, which does find the contact
    with pytest.raises(FecheckError, match="needs a closed master mesh.*use 'bvh'"):
        ContactPair(CONDYLE, SHEET, method=method)
    assert ContactPair(CONDYLE, SHEET).evaluate(POSE, IDENTITY).n_faces > 50


def test_mesh_master_matches_the_analytic_plane_on_a_flat_master():
    # The box's top face is the plane z = 0: closest-point depths are the plane depths.
    plane = ContactPair(CONDYLE, Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0])).evaluate(POSE, IDENTITY)
    mesh = ContactPair(CONDYLE, BOX).evaluate(POSE, IDENTITY)
    np.testing.assert_array_equal(np.sort(mesh.face), np.sort(plane.face))
    np.testing.assert_allclose(np.sort(mesh.vertex_depth.ravel()),
                               np.sort(plane.vertex_depth.ravel()), atol=1e-9)
    # Same ∫d dA up to the projection: mesh masters weigh the slave face's own area.
    assert volume(mesh) >= volume(plane)
    assert volume(mesh) == pytest.approx(volume(plane), rel=0.02)


def test_winding_number_sign_agrees_with_the_face_side_on_a_closed_master():
    a = ContactPair(CONDYLE, BOX, mesh_sign="winding").evaluate(POSE, IDENTITY)
    b = ContactPair(CONDYLE, BOX).evaluate(POSE, IDENTITY)
    np.testing.assert_array_equal(a.face, b.face)
    np.testing.assert_allclose(a.qp_depth, b.qp_depth, atol=1e-12)
    with pytest.raises(FecheckError, match="closed"):
        ContactPair(CONDYLE, SHEET, mesh_sign="winding")


@pytest.mark.parametrize("sign", ["normal", "winding"])
def test_inside_out_closed_master_is_refused_naming_the_fix(sign):
    # Inverted, the box's normals point inwards: with sign="normal" every slave vertex
    # would read as inside (force at zero approach), with "winding" none would.
    inverted = TriMesh(BOX.points, BOX.faces[:, ::-1])
    assert inverted.signed_volume == pytest.approx(-80.0 * 80.0 * 20.0)
    with pytest.raises(FecheckError, match="inside out.*flip its face winding"):
        ContactPair(CONDYLE, inverted, mesh_sign=sign)
    # an open sheet has no inside-out test: either winding is a valid one-sided master
    ContactPair(CONDYLE, TriMesh(SHEET.points, SHEET.faces[:, ::-1]))


def test_fcl_per_face_depth_is_the_deepest_vertex_depth():
    # python-fcl's GJK/EPA against the convex box gives, per slave triangle, the
    # penetration of its deepest vertex: an independent check of our vertex depths and
    # of the thesis's counting (same faces, whole areas).
    fcl_surface = ContactPair(CONDYLE, BOX, method="fcl").evaluate(POSE, IDENTITY)
    ours = ContactPair(CONDYLE, Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
                       area="whole-face").evaluate(POSE, IDENTITY)
    order_f, order_o = np.argsort(fcl_surface.face), np.argsort(ours.face)
    np.testing.assert_array_equal(fcl_surface.face[order_f], ours.face[order_o])
    np.testing.assert_allclose(fcl_surface.vertex_depth[order_f, 0],
                               ours.vertex_depth[order_o].max(axis=1), atol=1e-6)
    np.testing.assert_allclose(fcl_surface.area, CONDYLE.face_areas[ours.face].sum(),
                               rtol=1e-12)


def test_a_tree_query_takes_the_last_ones_answers_for_the_same_points_and_asks_the_rest():
    """`MeshMaster.tree_closest` (the full evaluation after a broad-phase rebuild asks again
    for the rebuild's points): the rows bitwise equal to the last query's take its answers,
    which are igl's for them (whatever the caller did to the arrays it was given), and only
    the other rows reach the tree."""
    from fecheck.contact.mesh_master import MeshMaster

    master = MeshMaster(icosphere(25.5, 3))
    rng = np.random.default_rng(4)
    first = rng.normal(scale=20.0, size=(200, 3))
    later = np.concatenate([first[150:], rng.normal(scale=20.0, size=(30, 3)), first[:20]])
    tree, asked = master._tree, []

    class Counting:
        def squared_distance(self, V, F, P):
            asked.append(len(P))
            return tree.squared_distance(V, F, P)

    master._tree = Counting()
    for a in master.tree_closest(first):
        a[...] = -1                                 # a caller's walk changes its arrays
    got = master.tree_closest(later)
    assert asked == [200, 30]
    for a, b in zip(got, tree.squared_distance(master._V, master._F, later), strict=True):
        np.testing.assert_array_equal(a, b)
