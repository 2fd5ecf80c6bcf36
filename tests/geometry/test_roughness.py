"""How far a sheet departs from its smoothed copy (`geometry.roughness`), against closed
forms: a sinusoid of amplitude A on a plane has RMS A/√2 about it, a staircase of step h
jumps by h, a sphere patch is a quadric to fourth order and barely moves."""

from __future__ import annotations

import numpy as np
import pytest

from geometry.cache import STATS
from geometry.mesh import TriMesh
from geometry.roughness import roughness, roughness_report, sliver_count, smooth

A, WAVE = 0.1, 1.0          # sinusoid amplitude and wavelength, mm
STEP, TREAD = 0.5, 2.5      # staircase step and tread, mm
RADIUS = 3.0                # smoothing length, mm
R = 25.0                    # sphere radius, mm


def grid(height, half: float = 8.0, n: int = 48) -> TriMesh:
    """A square sheet z = height(x, y), spacing 2·half/n (mm), normals +z."""
    s = np.linspace(-half, half, n + 1)
    X, Y = np.meshgrid(s, s, indexing="ij")
    points = np.column_stack([X.ravel(), Y.ravel(), height(X, Y).ravel()])
    idx = np.arange(X.size).reshape(n + 1, n + 1)
    a, b, c, d = (idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(),
                  idx[:-1, 1:].ravel())
    return TriMesh(points, np.vstack([np.column_stack([a, b, c]), np.column_stack([a, c, d])]))


def sphere(x, y):
    return R - np.sqrt(R * R - x * x - y * y)


def test_a_sinusoid_departs_by_its_rms_and_has_no_terraces():
    # an oblique wave of 1.3 mm under a 3 mm disc (sampled at incommensurate phases): the
    # disc mean of A sin(kx) is A sin(kx)·2J1(kL)/kL, under 3 % of A, so RMS = A/√2 within
    # 6 % (measured +3.4 %); the staircase test's step detector must find no terraces
    c, s = np.cos(0.35), np.sin(0.35)
    r = roughness(grid(lambda x, y: A * np.sin(2 * np.pi * (c * x + s * y) / 1.3), half=6.0),
                  RADIUS)
    assert r.rms_mm == pytest.approx(A / np.sqrt(2), rel=0.06)
    assert r.max_mm == pytest.approx(A, rel=0.2)
    assert r.terrace_mm == 0.0


@pytest.mark.parametrize("skew", [0.0, 0.3])
def test_a_staircase_gives_its_step_height(skew):
    # steps of 0.5 mm every 2.5 mm along x (+ skew·y): the step is 0.5 mm (module
    # docstring: median step jump + median tread jump), the largest departure half a step
    mesh = grid(lambda x, y: STEP * np.floor((x + skew * y) / TREAD))
    r = roughness(mesh, RADIUS)
    assert r.terrace_mm == pytest.approx(STEP, rel=0.1)         # measured -4 %, -6 %
    inner = np.abs(mesh.points[:, :2]).max(axis=1) < 8.0 - RADIUS   # full discs only
    assert np.abs(r.residual_mm[inner]).max() == pytest.approx(STEP / 2, rel=0.25)
    assert r.rms_mm > 0.5 * STEP / np.sqrt(12)


def test_a_sphere_patch_is_smooth_and_stays_on_its_sphere():
    mesh = grid(sphere)
    r = roughness(mesh, RADIUS)
    assert r.rms_mm < 1e-3 and r.max_mm < 2e-3 and r.terrace_mm == 0.0
    out = smooth(mesh, RADIUS)
    dist = np.linalg.norm(out.points - (0.0, 0.0, R), axis=1)
    assert np.abs(dist - R).max() < 2e-3                     # a plane fit: 0.09 mm off


def test_the_same_sheet_measured_again_reads_its_fits_from_the_cache():
    """`fecheck knee import` and `fecheck fe` measure the same sheets: a copy of a measured
    sheet reads its quadric fits back (one cache hit, no build, the same values); another
    smoothing length fits anew."""
    mesh = grid(lambda x, y: 0.02 * x * y)
    first = roughness(mesh, RADIUS)
    hits, builds = STATS.hits, STATS.builds
    again = roughness(TriMesh(mesh.points.copy(), mesh.faces.copy()), RADIUS)
    assert (STATS.hits, STATS.builds) == (hits + 1, builds)
    assert np.array_equal(again.residual_mm, first.residual_mm)
    roughness(mesh, 2.0)
    assert (STATS.hits, STATS.builds) == (hits + 1, builds + 1)


def test_smoothing_removes_terraces_from_a_terraced_sphere():
    mesh = grid(lambda x, y: sphere(x, y) + STEP * np.floor(x / TREAD))
    raw = roughness(mesh, RADIUS)
    assert raw.terrace_mm == pytest.approx(STEP, rel=0.1)        # measured -7 %
    assert roughness(smooth(mesh, RADIUS), RADIUS).rms_mm < 0.3 * raw.rms_mm


def test_the_report_line_names_the_sheet_and_its_terraces():
    text = roughness_report(grid(lambda x, y: STEP * np.floor(x / TREAD)), "tibia", RADIUS)
    assert text.startswith("tibia: departs from its copy smoothed over 3.00 mm by RMS 0.1")
    step = float(text.split("terraces ")[1].split()[0])
    assert step == pytest.approx(STEP, rel=0.1) and "0 slivers of 4608 faces" in text


def test_slivers_are_counted_by_their_quality():
    # an equilateral triangle (quality 1), a right isosceles one (0.866) and two thin ones
    # of base 1: height 0.02 (quality 4√3·0.01/(1 + 2·0.2504) = 0.046) and 0.2 (0.438)
    pts = np.array([[0, 0, 0], [1, 0, 0], [0.5, np.sqrt(3) / 2, 0], [0, 1, 0],
                    [0.5, 0.02, 0], [0.5, 0.2, 0.0]], dtype=float)
    faces = np.array([[0, 1, 2], [0, 1, 3], [0, 1, 4], [0, 1, 5]])
    assert sliver_count(TriMesh(pts, faces)) == 1
