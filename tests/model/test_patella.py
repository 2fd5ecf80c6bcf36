"""The patellofemoral joint in the EF (`fecheck.model.patella`): the source model's pf_r
coordinates, the vectorised tendon and quadriceps wrenches against one-at-a-time
references and finite differences, and the force balance of the coupled tibia-patella
solve on the scanned knee."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from fecheck.model import patella
from fecheck.scene import load_scene
from fecheck.scene.packaged import data_dir
from fecheck.statics.ligaments import BodySpring
from fecheck.statics.newton import point_force
from geometry.io import load_mesh

FOLDER = data_dir("fecheck:knee/lenhart2015_patella", "patella.dir")
A = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
"""OpenSim (x anterior, y superior, z right) → knee frame (x right, y anterior, z superior),
the lenhart2015 README's matrix M."""
O_MM = np.array([-1.756628, -0.149547, 22.271913])


def _rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _kabsch(x0: np.ndarray, x1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rigid (R, t) with x1 = R·x0 + t (least squares)."""
    c0, c1 = x0.mean(0), x1.mean(0)
    u, _, vt = np.linalg.svd((x1 - c1).T @ (x0 - c0))
    d = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))])
    rot = u @ d @ vt
    return rot, c1 - rot @ c0


def _posed(flex_deg, rot_deg, tilt_deg, t_mm) -> tuple[np.ndarray, np.ndarray]:
    """The patella's body pose (R, t) that puts pf_r at these coordinates, by the joint's
    own definition: a patella_r point p sits at T + Rz(-flex)·Rx(rot)·Ry(tilt)·p in
    femur_distal_r, mapped to the knee frame by M; the data's points are at flex = rot =
    tilt = 0, T = (53, 5, 4) mm. Fitted to the cartilage's vertices."""
    x0 = load_mesh(FOLDER / patella.CARTILAGE).points
    p = (x0 - O_MM) @ A - np.array([53.0, 5.0, 4.0])          # patella_r, mm
    r = _rz(-math.radians(flex_deg)) @ _rx(math.radians(rot_deg)) @ _ry(math.radians(tilt_deg))
    x1 = (np.asarray(t_mm) + p @ r.T) @ A.T + O_MM
    return _kabsch(x0, x1)


def test_the_data_pose_has_the_source_models_default_coordinates():
    """The data README: pf_tx 53, pf_ty 5, pf_tz 4 mm, rotations 0 (fitted to the
    cartilage's vertices, so to ~1e-10)."""
    got = patella.pf_coordinates(*_posed(0.0, 0.0, 0.0, (53.0, 5.0, 4.0)))
    want = dict(zip(patella.PF_COORDINATES, (0.0, 0.0, 0.0, 53.0, 5.0, 4.0), strict=True))
    assert got == pytest.approx(want, abs=1e-8)
    assert patella.pf_coordinates(np.eye(3), np.zeros(3)) == pytest.approx(want, abs=1e-12)


@pytest.mark.parametrize("coords", [(30.0, 4.0, -7.0, 40.0, -20.0, 6.0),
                                    (-10.0, -3.0, 12.0, 55.0, 9.0, 1.5),
                                    (85.0, 8.0, 5.0, 10.0, -30.0, 5.5)])
def test_a_posed_patella_reads_back_its_coordinates(coords):
    got = patella.pf_coordinates(*_posed(coords[0], coords[1], coords[2], coords[3:]))
    assert list(got.values()) == pytest.approx(list(coords), abs=1e-8)


def test_patellar_flexion_has_the_knees_sense():
    """Sign: the patella turned with the tibia's flexion (fecheck's Rx(-φ) about the
    femoral x axis, the ankle moving posterior) reads +φ of pf_flex (the source runs'
    pf_flex rises with knee flexion), and its tilt and rotation stay 0."""
    phi = math.radians(25.0)
    got = patella.pf_coordinates(_rx(-phi), np.zeros(3))
    assert got["pf_flex_deg"] == pytest.approx(25.0, abs=1e-10)
    assert got["pf_rot_deg"] == pytest.approx(0.0, abs=1e-10)
    assert got["pf_tilt_deg"] == pytest.approx(0.0, abs=1e-10)


def _poses(seed: int):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(2):
        v = rng.normal(size=3) * 0.01
        out.append((_rx(v[0]) @ _ry(v[1]) @ _rz(v[2]), rng.normal(size=3) * 0.3))
    return out


def _tendon():
    doc = json.loads((FOLDER / patella.BUNDLES).read_text())
    rows = [b for b in doc["ligaments"] if "tibia" in b["points_bone"]]
    pts = [dict(zip(b["points_bone"], np.asarray(b["points_mm"]), strict=True)) for b in rows]
    slack = np.array([b["derived"]["slack_length_mm"] for b in rows]) * 0.97   # all taut
    k = np.array([b["parameters"]["linear_stiffness"]["value"] for b in rows])
    springs = patella.TwoBodySprings(0, np.array([p["tibia"] for p in pts]), 1,
                                     np.array([p["patella"] for p in pts]), slack, k,
                                     np.full(len(rows), 0.06))
    single = [BodySpring(0, p["tibia"], 1, p["patella"], s, kk, 0.06)
              for p, s, kk in zip(pts, slack, k, strict=True)]
    return springs, single


def test_the_vectorised_tendon_is_the_sum_of_its_bundles():
    springs, single = _tendon()
    poses = _poses(1)
    bodies, w, dw = springs(poses)
    ref = [s(poses) for s in single]
    assert bodies == (0, 1)
    assert np.all(springs.tensions(poses) > 5.0)           # every bundle pulls
    assert np.allclose(w, sum(r[1] for r in ref), rtol=1e-12, atol=1e-9)
    assert np.allclose(dw, sum(r[2] for r in ref), rtol=1e-12, atol=1e-7)
    assert springs.tensions(poses) == pytest.approx([s.tension(poses) for s in single])


def _moved(pose, xi):
    """The pose moved by a small twist ξ = (v, ω) about the world origin."""
    from scipy.spatial.transform import Rotation

    r = Rotation.from_rotvec(xi[3:]).as_matrix()
    return r @ pose[0], r @ pose[1] + xi[:3]


def test_the_quadriceps_tangent_is_the_derivative_of_its_wrench():
    """dW/dξ against central differences (h = 1e-6 mm or rad: error ~1e-6 of the entries)."""
    quads = patella.Quadriceps(("a", "b"), np.array([[3.0, 52.0, 42.0], [14.0, 54.5, 42.4]]),
                               np.array([[25.0, 36.0, 203.0], [37.0, 30.0, 156.0]]),
                               np.array([40.0, 70.0]))
    pose = _poses(2)[0]
    w, dw = quads(*pose)
    x, u = quads.lines(*pose)
    assert np.allclose(w[:3], (quads.tension_N[:, None] * u).sum(0), rtol=1e-12)
    h = 1e-6
    num = np.column_stack([(quads(*_moved(pose, h * e))[0] - quads(*_moved(pose, -h * e))[0])
                           / (2 * h) for e in np.eye(6)])
    assert np.allclose(dw, num, rtol=1e-5, atol=1e-4 * np.abs(dw).max())


def test_point_forces_is_the_sum_of_point_force():
    rng = np.random.default_rng(3)
    x, f, jac = rng.normal(size=(4, 3)) * 30, rng.normal(size=(4, 3)), rng.normal(size=(4, 3, 3))
    w, dw = patella.point_forces(x, f, jac)
    ref = [point_force(x[i], f[i], jac[i]) for i in range(4)]
    assert np.allclose(w, sum(r[0] for r in ref))
    assert np.allclose(dw, sum(r[1] for r in ref))


def test_the_coupled_solve_balances_each_body():
    """Hand statics at 0° on the scanned knee (decimated, uniform layer): the patella's
    contact, its femoral bundles, the tendon's pull and the quadriceps add up to zero, and
    the tibia's contact, load, gravity, bundles and the tendon's pull too, each part
    evaluated here on its own, to 1e-8 of the load (the solver's tolerance)."""
    from fecheck.model.assembly import applied_load
    from fecheck.model.scanned import build_compartments, bundle_parts, bundle_springs
    from fecheck.studies.flex import axis_rotation

    scene = load_scene("femur_tibia_ligaments",
                       ["patella.dir='fecheck:knee/lenhart2015_patella'",
                        "scanned.thickness='uniform'", "scanned.decimate_faces=3000",
                        "load.frame='tibia'", "load.force_N=30.0",
                        "ligaments.wrap=false"])     # the hand statics' straight bundles
    comps = build_compartments(scene)
    _, springs = bundle_springs(scene)
    model = patella.build_patella(scene)
    eq, state = patella.solve_knee(scene, comps, bundle_parts(springs), model, None, None,
                                   (0.0, axis_rotation(np.array([1.0, 0.0, 0.0]))))
    assert eq.solution.converged
    tib, pat = (eq.rot, eq.t), (state.rot, state.t)
    tendon = [BodySpring(0, a, 1, b, s, k, e) for a, b, s, k, e in zip(
        model.tendon.points_a, model.tendon.points_b, model.tendon.slack_mm,
        model.tendon.stiffness_N, model.tendon.transition_strain, strict=True)]
    pull = sum(s([tib, pat])[1] for s in tendon)
    x, u = model.quadriceps.lines(*pat)
    f_quad = model.quadriceps.tension_N[:, None] * u
    quad = np.concatenate([f_quad.sum(0), np.cross(x, f_quad).sum(0)])
    _, contact, _ = model.compartment.evaluate(*pat)
    on_patella = contact + model.femoral(*pat)[0] + quad + pull[6:]
    scale = max(1.0, scene["load.force_N"], scene["tibia.mass_kg"] * 9.81)   # N
    assert np.abs(on_patella[:3]).max() < 1e-8 * scale
    assert np.abs(on_patella[3:]).max() < 1e-8 * scale * 50.0 * 3   # N·mm, 50 mm scale
    on_tibia = (sum(eq.wrenches) + applied_load(scene)(*tib)[0]
                + sum(s(*tib)[0] for s in springs) + pull[:6])
    assert np.abs(on_tibia[:3]).max() < 1e-8 * scale     # the flexion moment is driven
    assert np.linalg.norm(contact[:3]) > 0.5 * model.quadriceps.tension_N.sum()
