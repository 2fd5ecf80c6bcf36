"""The meniscus solids of the FE with menisci (fecheck.fe.bodies.meniscus_solid): tetrahedra of the
packaged smith2019 menisci, their articular faces, horns and ligaments, and the fibre
direction, arc coordinate and hoop force on a torus segment whose answers are closed
forms."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

import fecheck.fe.bodies.meniscus_solid as ms
from fecheck.errors import FecheckError
from fecheck.scene.packaged import data_dir
from fecheck.scene.surfaces import read_surface
from geometry.distance import closest_distance
from geometry.mesh import TetMesh, TriMesh, is_closed

PACKAGED = "fecheck:knee/smith2019_menisci"
SIDES = ("medial", "lateral")
R, RHO, N_RING, N_ROUND = 15.0, 2.5, 56, 16
"""Torus segment: centreline radius and tube radius (mm), rings along the arc (5 deg apart)
and points round each circular section."""
CENTRE = np.array([-20.0, 2.0, 1.0])
TORI = {"opening +x": (math.radians(40.0), math.radians(320.0), 1.0),
        "opening -x": (math.radians(220.0), math.radians(500.0), -1.0)}
"""Torus segments from angle φ0 counter-clockwise to φ1 about the axis through CENTRE
along z, and +1 when the anterior tip (y > 0) is at φ0, -1 at φ1: the opening faces +x
(like a medial meniscus, the arc counter-clockwise) or -x (lateral, clockwise)."""
POLYGON_AREA = 0.5 * N_ROUND * RHO ** 2 * math.sin(2 * math.pi / N_ROUND)
"""Area of the faceted section at a ring, mm² (a regular 16-gon of circumradius RHO)."""


@functools.cache
def packaged(side: str) -> ms.MeniscusSolid:
    return ms.meniscus_solid(PACKAGED, side)


def torus_segment(phi0: float, phi1: float) -> TriMesh:
    """Closed outward surface of a torus segment (rings of N_ROUND points, fan caps)."""
    theta = np.linspace(phi0, phi1, N_RING + 1)
    psi = 2 * np.pi * np.arange(N_ROUND) / N_ROUND
    t, p = np.meshgrid(theta, psi, indexing="ij")
    radius = R + RHO * np.cos(p)
    pts = np.stack([radius * np.cos(t), radius * np.sin(t), RHO * np.sin(p)], -1).reshape(-1, 3)
    ends = np.array([[R * np.cos(phi0), R * np.sin(phi0), 0.0],
                     [R * np.cos(phi1), R * np.sin(phi1), 0.0]])
    points = np.vstack([pts, ends]) + CENTRE
    i, j = np.meshgrid(np.arange(N_RING), np.arange(N_ROUND), indexing="ij")
    a, b = i * N_ROUND + j, i * N_ROUND + (j + 1) % N_ROUND
    c, d = a + N_ROUND, b + N_ROUND
    tube = np.concatenate([np.stack([a, c, b], -1).reshape(-1, 3),
                           np.stack([b, c, d], -1).reshape(-1, 3)])
    j = np.arange(N_ROUND)
    last = N_RING * N_ROUND
    cap_a = np.column_stack([np.full(N_ROUND, len(pts)), (j + 1) % N_ROUND, j])
    cap_p = np.column_stack([np.full(N_ROUND, len(pts) + 1), last + j,
                             last + (j + 1) % N_ROUND])
    surface = TriMesh(points, np.concatenate([tube, cap_a, cap_p]))
    return surface if surface.signed_volume > 0 else TriMesh(points, surface.faces[:, ::-1])


@functools.cache
def torus_solid(opening: str = "opening +x") -> ms.MeniscusSolid:
    """A torus segment of `TORI` as a `MeniscusSolid` (mesh, centreline, fibres; no
    labels)."""
    mesh, _ = ms.solid_mesh(torus_segment(*TORI[opening][:2]), 1.25, "torus")
    boundary = mesh.boundaries["boundary"]
    line, fibre, arc = ms.centreline_fibres(mesh, boundary)
    none = np.zeros(len(boundary), dtype=int)
    return ms.MeniscusSolid("torus", mesh, boundary, none, none, fibre, arc, line, {})


def exact_hoop(x: np.ndarray, opening: str = "opening +x"
               ) -> tuple[np.ndarray, np.ndarray]:
    """(unit hoop directions (n, 3) from the anterior tip on, arc coordinates (n,)) of
    points x on a torus segment of `TORI`: ±e_θ = ±(-sin φ, cos φ, 0) and the angle from
    the anterior tip over the segment's 280 deg."""
    phi0, phi1, sign = TORI[opening]
    phi = phi0 + np.mod(np.arctan2(x[:, 1] - CENTRE[1], x[:, 0] - CENTRE[0]) - phi0,
                        2 * np.pi)
    arc = (phi - phi0) / (phi1 - phi0)
    return (sign * np.column_stack([-np.sin(phi), np.cos(phi), np.zeros_like(phi)]),
            arc if sign > 0 else 1.0 - arc)


@pytest.mark.parametrize("side", SIDES)
def test_packaged_meniscus_tetrahedra_fill_its_closed_volume(side):
    """Closed boundary, every tetrahedron positive, the tet volume within 1 % of the STL's
    (its own signed volume) and no sliver under 2 deg (3.0 / 3.9 deg measured; 0.3 / 0.8
    deg without Netgen's optimiser)."""
    solid = packaged(side)
    volume = ms.read_volume(data_dir(PACKAGED, "menisci.dir"), side)
    assert is_closed(solid.boundary_mesh)
    assert (solid.mesh.tet_volumes > 0).all()
    assert solid.mesh.volume == pytest.approx(volume.signed_volume, rel=0.01)
    assert solid.boundary_mesh.signed_volume == pytest.approx(solid.mesh.volume, rel=1e-9)
    assert solid.quality["min_dihedral_deg"] >= 2.0
    assert np.median(np.linalg.norm(np.diff(
        solid.mesh.points[solid.mesh.tets[:, :2]], axis=1)[:, 0], axis=1)) <= 1.25


def test_tet_quality_of_a_regular_tetrahedron():
    """Regular tetrahedron: every dihedral angle arccos(1/3) = 70.53 deg, γ = 1. The corner
    tetrahedron of legs 1, 2, 4 (its smallest dihedral angle on the edge between its
    first and third vertices): arccos(1 / √(1 + 1/4 + 1/16)) = 29.21 deg."""
    pts = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float)
    tets = np.array([[0, 1, 2, 3]])
    if TetMesh(pts, tets).tet_volumes[0] < 0:
        tets = tets[:, [1, 0, 2, 3]]
    q = ms.tet_quality(TetMesh(pts, tets))
    assert q["min_dihedral_deg"] == pytest.approx(math.degrees(math.acos(1 / 3)), abs=1e-9)
    assert q["min_gamma"] == pytest.approx(1.0, abs=1e-12)
    assert q["volume_mm3"] == pytest.approx(8 / 3, rel=1e-12)
    corner = np.array([[0, 2, 0], [1, 0, 0], [0, 0, 4], [0, 0, 0]], dtype=float)
    tets = np.array([[0, 1, 2, 3]])
    if TetMesh(corner, tets).tet_volumes[0] < 0:
        tets = tets[:, [0, 3, 2, 1]]
    q = ms.tet_quality(TetMesh(corner, tets))
    assert q["min_dihedral_deg"] == pytest.approx(
        math.degrees(math.acos(1 / math.sqrt(1 + 1 / 4 + 1 / 16))), abs=1e-9)


@pytest.mark.parametrize("side", SIDES)
@pytest.mark.parametrize("label,face", [(ms.SUPERIOR, "superior"), (ms.INFERIOR, "inferior")])
def test_labelled_faces_cover_the_packaged_articular_surfaces(side, label, face):
    """The faces labelled superior / inferior cover at least 99 % of the packaged surface
    (its faces whose closest boundary face carries the label) and exceed its area by at
    most 4 % (the volume's rougher surface: 2.0-3.0 % measured; 7-11 % when faces past the
    surface's rim are let in), and by at most 2 % projected on the plateau (0.5-1.3 %)."""
    solid = packaged(side)
    sheet = read_surface(data_dir(PACKAGED, "menisci.dir")
                         / f"smith2019_R_meniscus_{side}_{face}.stl")
    _, nearest = closest_distance(sheet.face_centroids, solid.boundary_mesh)
    covered = sheet.face_areas[solid.face_label[nearest] == label].sum() / sheet.area
    assert covered >= 0.99
    area = solid.area_mm2(label)
    assert sheet.area <= area <= 1.04 * sheet.area

    def projected(points, faces):
        t = points[faces]
        return 0.5 * np.abs(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])[:, 2]).sum()

    assert projected(solid.mesh.points, solid.faces(label)) == pytest.approx(
        projected(sheet.points, sheet.faces), rel=0.02)


@pytest.mark.parametrize("side,tips,stiffness", [
    ("medial", ((-10.5, 20.4, 3.4), (-6.0, -9.2, 2.5)), (6.1, 7.1, 11.9, 13.2)),
    ("lateral", ((12.6, 12.9, 1.6), (6.4, -3.7, 5.5)), (13.2, 11.4, 8.6, 8.1))])
def test_horns_and_their_root_ligaments(side, tips, stiffness):
    """The arc runs from the anterior horn's end to the posterior one's (the data set
    README's end centroids, the mean of the volume's vertices within 4 deg of each edge of
    the C's opening; within 1.5 mm, 0.8-1.4 mm measured); the anterior horn's
    nodes lie in the first third of the arc and the posterior's in the last, each on a
    face off the femoral surface; each horn carries its two root bundles with the README's
    k/l0 (N/mm) and a node within 1.5 mm of the bundle's meniscal point (README: within
    0.9 mm of the surface)."""
    solid = packaged(side)
    for arc, tip in zip((0.0, 1.0), tips, strict=True):
        assert np.linalg.norm(solid.centreline.at(arc)[0] - tip) <= 1.5
    held = np.unique(solid.boundary[solid.face_label != ms.SUPERIOR])
    node_arc = {h: solid.centreline.arc[solid.centreline.closest(solid.mesh.points[
        solid.horns[h].nodes])] for h in ("anterior", "posterior")}
    assert np.median(node_arc["anterior"]) < 1 / 3 < 2 / 3 < np.median(node_arc["posterior"])
    ligaments = solid.horns["anterior"].ligaments + solid.horns["posterior"].ligaments
    assert [lig.name.split("_")[-1] for lig in ligaments] == ["AHORN1", "AHORN2", "PHORN1",
                                                              "PHORN2"]
    assert [lig.stiffness_N_per_mm for lig in ligaments] == pytest.approx(stiffness, abs=0.06)
    for horn in solid.horns.values():
        assert len(horn.nodes) > 50
        assert np.isin(horn.nodes, held).all()
        for lig in horn.ligaments:
            gap = np.linalg.norm(solid.mesh.points[lig.node] - lig.meniscus_mm)
            assert gap == pytest.approx(lig.node_distance_mm, abs=1e-9) and gap <= 1.5


@pytest.mark.parametrize("opening", TORI)
def test_torus_fibres_follow_the_hoop_direction(opening):
    """On a torus segment (either way round) every element's fibre is the closed-form hoop direction
    e_θ = (-sin φ, cos φ, 0) at its centroid to within 1 deg (0.70 deg measured, at the
    tips, where the fitted series ends) and to 0.25 deg between arc 0.1 and 0.9 (0.17 deg;
    sign: from the anterior tip on), and its arc coordinate is (φ - 40°) / 280° to within
    0.002 (0.0007)."""
    solid = torus_solid(opening)
    e, arc = exact_hoop(solid.mesh.points[solid.mesh.tets].mean(axis=1), opening)
    cos = np.einsum("ij,ij->i", solid.fibre, e)
    error_deg = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    assert error_deg.max() <= 1.0
    assert error_deg[(arc > 0.1) & (arc < 0.9)].max() <= 0.25
    assert np.abs(solid.arc - arc).max() <= 0.002


@pytest.mark.parametrize("arc", [0.25, 0.5, 0.75])
def test_torus_hoop_force_in_uniform_hoop_stress_is_stress_times_area(arc):
    """Uniform hoop stress σ0 e_θ⊗e_θ (e_θ exact at each centroid): the hoop force through
    the section at arc 0.25 / 0.5 / 0.75 (ring angles 110 / 180 / 250 deg) is σ0 times the
    section's area, the regular 16-gon's, within 0.5 % (the plane's tilt from the fitted
    centreline, the elements' 3 deg spread of e_θ about the plane's normal)."""
    solid = torus_solid()
    e, _ = exact_hoop(solid.mesh.points[solid.mesh.tets].mean(axis=1))
    sigma0 = 3.0
    out = ms.hoop_force(solid, sigma0 * np.einsum("ni,nj->nij", e, e), arcs=(arc,))
    assert out.section_area_mm2[0] == pytest.approx(POLYGON_AREA, rel=0.005)
    assert out.force_N[0] == pytest.approx(sigma0 * POLYGON_AREA, rel=0.005)


def test_torus_hoop_stress_along_the_arc():
    """A hoop stress rising linearly along the arc, σ0 (1 + 2 s) e_θ⊗e_θ, is returned bin by
    bin as σ0 (1 + 2 s_bin) at the bin centres, within 1 %."""
    solid = torus_solid()
    e, arc = exact_hoop(solid.mesh.points[solid.mesh.tets].mean(axis=1))
    out = ms.hoop_force(solid, 2.0 * (1 + 2 * arc)[:, None, None]
                        * np.einsum("ni,nj->nij", e, e), bins=10)
    assert out.hoop_stress_MPa == pytest.approx(2.0 * (1 + 2 * out.arc), rel=0.01)


def test_plane_section_of_a_unit_cube_is_its_face_area():
    """The six-tetrahedron unit cube cut at z = 0.3 (one and two vertices above in its
    tetrahedra) and at a 45 deg plane through its centre: areas 1 and √2."""
    pts = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    tets = np.array([[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7],
                     [0, 4, 6, 7]])
    mesh = TetMesh(pts, tets)
    everything = np.arange(6)
    _, area = ms.section(mesh, np.array([0.5, 0.5, 0.3]), np.array([0.0, 0.0, 1.0]),
                         everything)
    assert area.sum() == pytest.approx(1.0, rel=1e-12)
    n = np.array([1.0, 0.0, 1.0]) / math.sqrt(2)
    _, area = ms.section(mesh, np.full(3, 0.5), n, everything)
    assert area.sum() == pytest.approx(math.sqrt(2), rel=1e-12)


def test_a_scene_names_the_menisci_folder():
    """A scene's menisci.dir gives the same solid as the folder's name (read from the
    cache: the same tetrahedra), the menisci as shipped (not fitted to the joint)."""
    from fecheck.scene.load import load_scene

    scene = load_scene("femur_tibia_menisci", ["menisci.fit=as-shipped"])
    solid = ms.meniscus_solid(scene, "lateral")
    assert np.array_equal(solid.mesh.tets, packaged("lateral").mesh.tets)
    assert np.array_equal(solid.face_label, packaged("lateral").face_label)


def test_refusals_come_before_any_meshing(monkeypatch):
    """An unknown side, a size out of range and a stress of the wrong shape are refused on
    one line, before a mesh is built."""
    def never(*args, **kwargs):
        raise AssertionError("meshed")

    solid = torus_solid()
    monkeypatch.setattr(ms, "solid_mesh", never)
    with pytest.raises(FecheckError, match="'medial' or 'lateral'"):
        ms.meniscus_solid(PACKAGED, "central")
    with pytest.raises(FecheckError, match="from 0.2 to 5 mm"):
        ms.meniscus_solid(PACKAGED, "medial", size_mm=50.0)
    with pytest.raises(FecheckError, match=r"\(\d+, 3, 3\) MPa"):
        ms.hoop_force(solid, np.zeros((3, 3, 3)))
    with pytest.raises(FecheckError, match="strictly between 0"):
        ms.hoop_force(solid, np.zeros((len(solid.mesh.tets), 3, 3)), arcs=(1.0,))
