"""The menisci's shape (`fecheck.model.menisci_shape`) on synthetic geometry: a wedge
fitted between two known planes, the touching pose of two tilted plates, and a ring's
inner third resected; volumes against hand integrals."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fecheck.model import menisci_shape as shape
from geometry.mesh import TriMesh


def _grid(x0, x1, y0, y1, n, z, up=True) -> TriMesh:
    """A flat (or z(x, y)) sheet over [x0, x1] × [y0, y1], n × n vertices, normals up."""
    gx, gy = np.meshgrid(np.linspace(x0, x1, n), np.linspace(y0, y1, n))
    pts = np.column_stack([gx.ravel(), gy.ravel(), np.zeros(n * n)])
    pts[:, 2] = z(pts[:, 0], pts[:, 1])
    i = np.arange(n - 1)
    a = (i[:, None] * n + i[None, :]).ravel()
    faces = np.concatenate([np.column_stack([a, a + 1, a + n + 1]),
                            np.column_stack([a, a + n + 1, a + n])])
    return TriMesh(pts, faces if up else faces[:, ::-1])


def _wedge(bottom, top, n=21) -> TriMesh:
    """A closed wedge over [0, 10] × [-10, 10]: bottom z = bottom(x, y), top z =
    top(x, y), its walls with n levels of vertices; outward normals."""
    import trimesh

    box = trimesh.creation.box(bounds=[[0.0, -10.0, 0.0], [10.0, 10.0, 1.0]])
    for _ in range(3):
        box = box.subdivide()
    p = np.asarray(box.vertices, dtype=float).copy()
    t = p[:, 2]
    p[:, 2] = bottom(p[:, 0], p[:, 1]) + t * (top(p[:, 0], p[:, 1]) - bottom(p[:, 0], p[:, 1]))
    return TriMesh(p, np.asarray(box.faces))


def _bottom(x, y):
    return 0.5 + 0.0 * x


def _top(x, y):
    return 1.0 + 0.3 * x


def _femur(x, y):
    return 0.8 + 0.2 * x + 0.02 * y


def test_fit_seats_a_wedge_between_two_planes_and_its_volume_is_the_hand_integral():
    # A wedge 0.5 mm above the tibial plane z = 0, its top z = 1 + 0.3 x, its articular
    # sheets reaching 1 mm past it (tallest section 0.5 + 0.3·11 = 3.8 mm), the femoral
    # plane z = 0.8 + 0.2 x + 0.02 y (joint space at most 3.22 mm there, the top thinned to
    # 0.6 mm at least). After the fit its bottom lies on z = 0 and its top on the femoral
    # plane: the fields are linear, so the grid's bilinear interpolation is exact (to
    # rounding). Volume before ∫∫(0.5 + 0.3 x) = 400 mm³, after
    # ∫∫(0.8 + 0.2 x + 0.02 y) dx dy over [0, 10] × [-10, 10] = 360 mm³.
    volume = _wedge(_bottom, _top)
    inferior = _grid(-1.0, 11.0, -11.0, 11.0, 25, _bottom, up=False)     # past the rim
    superior = _grid(-1.0, 11.0, -11.0, 11.0, 25, _top)
    tibia = _grid(-20.0, 30.0, -30.0, 30.0, 11, lambda x, y: 0.0 * x)
    femur = _grid(-20.0, 30.0, -30.0, 30.0, 11, _femur, up=False)
    fit = shape.fit_fields(volume, inferior, superior, tibia, femur)
    moved = fit(volume.points)
    assert np.abs(moved[:, :2] - volume.points[:, :2]).max() == 0.0     # vertical only
    low = np.isclose(volume.points[:, 2], _bottom(*volume.points[:, :2].T), atol=1e-12)
    high = np.isclose(volume.points[:, 2], _top(*volume.points[:, :2].T), atol=1e-12)
    assert low.sum() >= 81 and high.sum() >= 81              # 9 × 9 vertices each
    assert np.abs(moved[low, 2]).max() <= 1e-9
    assert np.abs(moved[high, 2] - _femur(*moved[high, :2].T)).max() <= 1e-9
    assert volume.signed_volume == pytest.approx(400.0, rel=1e-12)
    assert TriMesh(moved, volume.faces).signed_volume == pytest.approx(360.0, rel=1e-9)
    # the relative height in the wedge is kept: a wall vertex a third of the way up
    # stays a third of the way up between the new bottom and top
    mid = ~low & ~high
    rel_before = (volume.points[mid, 2] - _bottom(*volume.points[mid, :2].T)) / (
        _top(*volume.points[mid, :2].T) - _bottom(*volume.points[mid, :2].T))
    rel_after = moved[mid, 2] / _femur(*moved[mid, :2].T)
    assert rel_after == pytest.approx(rel_before, abs=1e-9)


def test_fit_tapers_back_to_the_shipped_shape_past_the_cartilage():
    # A tibial sheet that ends at x = 5.1: past it the bottom's displacement (-0.5 mm)
    # fades as exp(-(d / TAPER_MM)²) with the distance d (mm) to the last grid point over
    # it, the grid point at x = 5 (the query points are grid points: exact).
    volume = _wedge(_bottom, _top)
    inferior = _grid(-1.0, 11.0, -11.0, 11.0, 25, _bottom, up=False)
    superior = _grid(-1.0, 11.0, -11.0, 11.0, 25, _top)
    tibia = _grid(-20.0, 5.1, -30.0, 30.0, 101, lambda x, y: 0.0 * x)
    femur = _grid(-20.0, 30.0, -30.0, 30.0, 11, _femur, up=False)
    fit = shape.fit_fields(volume, inferior, superior, tibia, femur)
    x = np.array([4.0, 6.0, 7.0, 9.0])
    p = np.column_stack([x, np.zeros(4), _bottom(x, 0.0)])
    d = np.maximum(x - 5.0, 0.0)
    expected = 0.5 - 0.5 * np.exp(-(d / shape.TAPER_MM) ** 2)
    assert fit(p)[:, 2] == pytest.approx(expected, abs=1e-9)
    # a femur that opens the joint beyond the wedge's tallest section (3.8 mm) is no
    # target: z_F = 1.2 + 0.25 x, rising 5 mm/mm more past x = 8 (joint space 3.2 mm at
    # x = 8, 4.5 mm at the next grid point); past x = 8 the top's displacement is the one
    # at x = 8, δ_t = 1.2 + 0.25·8 − (1 + 0.3·8) = −0.2 mm, tapered with the distance
    steep = _grid(-20.0, 30.0, -30.0, 30.0, 51, lambda x, y: 1.2 + 0.25 * x
                  + 5.0 * np.maximum(x - 8.0, 0.0), up=False)
    full = _grid(-20.0, 30.0, -30.0, 30.0, 11, lambda x, y: 0.0 * x)
    fit = shape.fit_fields(volume, inferior, superior, full, steep)
    q = np.array([[8.0, 0.0, _top(8.0, 0.0)], [9.0, 0.0, _top(9.0, 0.0)]])
    taper = math.exp(-(1.0 / shape.TAPER_MM) ** 2)
    assert fit(q)[:, 2] - q[:, 2] == pytest.approx([-0.2, -0.2 * taper], abs=1e-9)


def test_touching_pose_closes_both_compartments():
    # Two flat tibial plates at z = 0 (medial x < 0, lateral x > 0) and a femoral plane
    # z = 2 + 0.05 x above them: turning about y by α and dropping by δz closes both.
    # The least gaps are at the plates' inner and outer edges; by hand, with the femur
    # plane z = 2 + 0.05 x turned by α (z' ≈ z − α x) and dropped, both minima are zero
    # when the turned plane is level: α = atan(0.05) = 0.04996 rad, and the drop is its
    # height at x = 0 after the turn.
    tibia = {"medial": _grid(-30.0, -5.0, -15.0, 15.0, 11, lambda x, y: 0.0 * x),
             "lateral": _grid(5.0, 30.0, -15.0, 15.0, 11, lambda x, y: 0.0 * x)}
    femur = _grid(-40.0, 40.0, -30.0, 30.0, 41, lambda x, y: 2.0 + 0.05 * x, up=False)
    moved, alpha, dz = shape.touching_femur(femur, tibia, turn=True)
    assert alpha == pytest.approx(math.atan(0.05), abs=1e-6)
    for c in ("medial", "lateral"):
        top = shape.vertical_height(moved, tibia[c].points[:, :2], from_above=False)
        assert np.nanmin(top) == pytest.approx(0.0, abs=shape.TOUCH_TOL_MM)
    # abduction fixed: the femur only drops, until the nearer (medial) plate touches
    moved, alpha, dz = shape.touching_femur(femur, tibia, turn=False)
    assert alpha == 0.0 and dz == pytest.approx(2.0 - 0.05 * 30.0, abs=1e-9)


def _ring(r0=10.0, r1=20.0, h=2.0, n_phi=55, n_r=13, sweep=1.5 * math.pi) -> TriMesh:
    """A closed flat ring sector (radii r0-r1, height h, angles 0-sweep): its rectangular
    section, with n_r vertices along each radial edge, swept over n_phi angles, the two
    ends closed by fans from the section's mean point; outward normals."""
    phi = np.linspace(0.0, sweep, n_phi)
    r = np.linspace(r0, r1, n_r)
    outline = np.concatenate([np.column_stack([r, np.zeros(n_r)]),
                              np.column_stack([np.full(3, r1), [h / 3, h / 2, 2 * h / 3]]),
                              np.column_stack([r[::-1], np.full(n_r, h)]),
                              np.column_stack([np.full(3, r0), [2 * h / 3, h / 2, h / 3]])])
    m = len(outline)
    pts = np.concatenate([np.column_stack([outline[:, 0] * np.cos(f),
                                           outline[:, 0] * np.sin(f), outline[:, 1]])
                          for f in phi])
    j = np.arange(m)
    faces = []
    for k in range(n_phi - 1):
        a, b = k * m + j, k * m + (j + 1) % m
        faces += [np.column_stack([a, a + m, b]), np.column_stack([b, a + m, b + m])]
    ends = []
    for k, flip in ((0, True), (n_phi - 1, False)):
        fan = np.column_stack([np.full(m, len(pts) + len(ends)), k * m + j,
                               k * m + (j + 1) % m])
        ends.append(pts[k * m:(k + 1) * m].mean(axis=0))
        faces.append(fan[:, ::-1] if flip else fan)
    mesh = TriMesh(np.concatenate([pts, np.array(ends)]), np.concatenate(faces))
    if mesh.signed_volume < 0:
        mesh = TriMesh(mesh.points, mesh.faces[:, ::-1])
    return mesh


def test_partial_meniscectomy_keeps_the_outer_two_thirds_of_a_ring():
    # A flat ring sector r 10-20 mm, 2 mm high, 270 deg in 54 segments: the inner third
    # (r < 13.33) collapses onto r = 13.33 at each vertex's angle, the rest stays. By
    # hand the kept volume is the polygonal annulus between the radii 13.33 and 20: per
    # segment ½ sin Δφ (R² − r²) times the height (the end caps are flat fans).
    ring = _ring()
    cut = shape.partial_map(ring)
    cut = shape.PartialMap(np.zeros(2), cut.angles, np.full(len(cut.angles), 10.0),
                           np.full(len(cut.angles), 20.0))
    out = cut(ring.points)
    r_cut = 10.0 + 10.0 / 3.0
    radius = np.linalg.norm(out[:, :2], axis=1)
    before = np.linalg.norm(ring.points[:, :2], axis=1)
    inner = before < r_cut - 1e-9
    assert radius[inner] == pytest.approx(r_cut, rel=1e-12)
    assert np.abs(out[~inner] - ring.points[~inner]).max() <= 1e-12
    assert np.abs(out[:, 2] - ring.points[:, 2]).max() == 0.0
    dphi = 1.5 * math.pi / 54
    expected = 2.0 * 54 * 0.5 * math.sin(dphi) * (20.0 ** 2 - r_cut ** 2)
    assert TriMesh(out, ring.faces).signed_volume == pytest.approx(expected, rel=1e-9)
    # the rim radii found from the vertices are the ring's (its radii bins hold 10 and 20)
    found = shape.partial_map(ring)
    off = float(np.linalg.norm(found.centre)) + 1e-9
    assert np.abs(found.r_in - 10.0).max() <= off and np.abs(found.r_out - 20.0).max() <= off
