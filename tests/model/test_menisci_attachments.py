"""Meniscectomy, root tears and the horn attachments as scene keys
(`fecheck.model.menisci`, `fecheck.statics.root_spring`, `fecheck.fe.knee.knee_menisci`): the
root spring against its closed form and finite differences, the roots' points and
directions against the ligaments file read here, and a rigid shift of an FE meniscus
against the roots' stiffness matrices."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from fecheck.fe.bodies.meniscus_solid import meniscus_solid
from fecheck.fe.knee import meniscus_body
from fecheck.model import menisci
from fecheck.scene import load_scene
from fecheck.scene.packaged import data_dir
from fecheck.statics.newton import body_pose
from fecheck.statics.root_spring import TRANSVERSE_FRACTION, RootSpring

FOLDER = data_dir("fecheck:knee/smith2019_menisci", "menisci.dir")
SHIPPED = ["menisci.fit=as-shipped"]


def _roots(side: str) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """{horn: (mean tibial point, mean meniscal point)} of the side's AHORN / PHORN
    bundles, read here from the file."""
    items = json.loads((FOLDER / "meniscal_ligaments.json").read_text())["ligaments"]
    out = {}
    for horn, group in (("anterior", "AHORN"), ("posterior", "PHORN")):
        pts = np.array([it["points_mm"] for it in items
                        if it["meniscus"] == side and it["group"] == group])
        out[horn] = (pts[:, 0].mean(axis=0), pts[:, 1].mean(axis=0))
    return out


def test_root_spring_force_is_the_closed_form_and_its_tangent_the_difference_quotient():
    # A root along e = (3, 0, 4)/5, k = 2000 N/mm: the meniscus moved by d = (0.01, 0.02,
    # -0.005) mm takes f = −k (e·d) e − 0.01 k (d − (e·d) e); its tension k (e·d).
    e = np.array([0.6, 0.0, 0.8])
    p = np.array([1.0, 2.0, 3.0])
    spring = RootSpring(0, p, 1, p.copy(), 5.0 * e, 2000.0)
    d = np.array([0.01, 0.02, -0.005])
    poses = [(np.eye(3), np.zeros(3)), (np.eye(3), d)]
    along = e @ d
    expected = -2000.0 * along * e - TRANSVERSE_FRACTION * 2000.0 * (d - along * e)
    assert spring.force(poses) == pytest.approx(expected, rel=1e-12)
    assert spring.tension(poses) == pytest.approx(2000.0 * along, rel=1e-12)
    _, w, dw = spring([(np.eye(3), np.zeros(3)), (np.eye(3), d)])
    assert w[6:9] == pytest.approx(expected, rel=1e-12) and w[:3] == pytest.approx(-expected)
    # tangent against central differences of the wrench in the meniscus's twist
    q = np.r_[d, 0.0, 0.0, 0.0]
    h = 1e-6
    for j in range(6):
        step = np.zeros(6)
        step[j] = h
        plus = spring([(np.eye(3), np.zeros(3)), body_pose(q + step)])[1]
        minus = spring([(np.eye(3), np.zeros(3)), body_pose(q - step)])[1]
        if j < 3:                                      # translations: the twist's part
            assert (plus - minus) / (2 * h) == pytest.approx(dw[:, 6 + j], abs=1e-4)


def test_removed_menisci_and_torn_roots_leave_the_model():
    # menisci.remove drops the meniscus; menisci.torn_roots drops that horn's spring; the
    # others sit at the horn's mean meniscal root point, along the mean tibial → meniscal
    # line, at menisci.root_N_per_mm.
    scene = load_scene("femur_tibia_menisci",
                       SHIPPED + ["menisci.remove=['medial']",
                                  "menisci.torn_roots=['lateral-posterior']"])
    assert menisci.present_sides(scene) == ("lateral",)
    problem, _, springs, _, sides, _ = menisci.build_problem(scene)
    assert sides == ("lateral",) and [b.name for b in problem.bodies][2:] == [
        "lateral meniscus"]
    assert sorted(springs) == ["lateral anterior root"]
    spring = springs["lateral anterior root"]
    tibial, meniscal = _roots("lateral")["anterior"]
    assert spring.meniscus_point == pytest.approx(meniscal, abs=1e-12)
    unit = (meniscal - tibial) / np.linalg.norm(meniscal - tibial)
    assert spring.direction / np.linalg.norm(spring.direction) == pytest.approx(unit)
    assert spring.stiffness_N_per_mm == 2000.0


def test_the_data_bundles_are_an_option_that_warns():
    # menisci.roots = 'bundles': the four AHORN / PHORN bundles of a side, with a warning;
    # coronary and transverse ligaments only when asked for.
    scene = load_scene("femur_tibia_menisci", SHIPPED + ["menisci.roots=bundles"])
    with pytest.warns(UserWarning, match="EF model's placeholders"):
        springs = menisci.build_problem(scene)[2]
    assert sorted(springs) == sorted(
        f"meniscus_{s}_{g}{i}" for s in ("medial", "lateral") for g in ("AHORN", "PHORN")
        for i in (1, 2))
    scene = load_scene("femur_tibia_menisci", SHIPPED + ["menisci.coronary=true",
                                                        "menisci.transverse=true"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        springs = menisci.build_problem(scene)[2]
    assert len(springs) == 4 + 6 + 1                  # roots, COR bundles, transverse


def test_fe_root_springs_hold_a_rigid_shift_along_the_roots():
    # A rigid shift d of the FE meniscus strains nothing: its energy is the roots' alone,
    # dᵀ Σ_h k (e_h e_hᵀ + 0.01 (I − e_h e_hᵀ)) d, e_h read here from the ligaments file;
    # a torn posterior root leaves the anterior one's.
    solid = meniscus_solid("fecheck:knee/smith2019_menisci", "medial", 2.5)
    roots = _roots("medial")

    def matrix(horn):
        tibial, meniscal = roots[horn]
        e = (meniscal - tibial) / np.linalg.norm(meniscal - tibial)
        return 2000.0 * (np.outer(e, e) + TRANSVERSE_FRACTION * (np.eye(3) - np.outer(e, e)))

    for torn in ((), ("posterior",)):
        horns = meniscus_body.horn_matrices(solid, "springs", 2000.0, torn)
        assert sorted(horns) == sorted({"anterior", "posterior"} - set(torn))
        basis, K = meniscus_body.meniscus_stiffness(solid, solid.mesh.points, solid.fibre,
                                                   horns)
        for d in (np.array([1.0, 0.0, 0.0]), np.array([0.3, -0.5, 0.8])):
            u = np.zeros(basis.N)
            for c in range(3):
                u[basis.nodal_dofs[c]] = u[basis.edge_dofs[c]] = d[c]
            expected = sum(d @ matrix(h) @ d for h in horns)
            assert u @ K @ u == pytest.approx(expected, rel=1e-8)


def test_resected_tetrahedra_leave_a_closed_outward_boundary():
    # A 2 × 1 × 1 mm block of 12 tetrahedra (two cubes, six each): cutting the tets whose
    # centroid has x < 1 leaves the second cube, 1 mm³, bounded by 12 outward triangles
    # whose enclosed (signed) volume is the tets' volume.
    import trimesh

    from fecheck.fe.bodies.meniscus_solid import resect
    from geometry.mesh import TetMesh, TriMesh

    cube = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                     [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], dtype=float)
    six = np.array([[0, 1, 2, 6], [0, 2, 3, 6], [0, 3, 7, 6], [0, 7, 4, 6], [0, 4, 5, 6],
                    [0, 5, 1, 6]])
    points = np.vstack([cube, cube + [1.0, 0.0, 0.0]])
    mesh = TetMesh(points, np.vstack([six, six + 8]))
    out = resect(mesh, lambda c: c[:, 0] < 1.0)
    assert len(out.tets) == 6 and len(out.points) == 8
    assert np.abs(out.tet_volumes).sum() == pytest.approx(1.0, rel=1e-12)
    surface = TriMesh(out.points, out.boundaries["boundary"])
    assert len(surface.faces) == 12
    assert surface.signed_volume == pytest.approx(1.0, rel=1e-12)
    assert trimesh.Trimesh(out.points, surface.faces, process=False).is_watertight
