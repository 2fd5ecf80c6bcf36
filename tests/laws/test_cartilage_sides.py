"""Per-side cartilage: the femoral layer's share of a uniform thickness and its own
material (``contact.femoral_share``, ``contact.femoral_youngs_MPa``,
``contact.femoral_poisson``), read by the linear EF and the two-layer FE alike.

References: two foundations in series under one pressure p (hand computation):
k = 1/(h_t/c_t + h_f/c_f), c = (1−ν)E/((1+ν)(1−2ν)), each layer compressing p·h/c; and the
1D column law of a thin bonded layer, compression = p·h/M with M the same constrained
modulus, so a femoral layer twice as stiff as an equal tibial one takes 1/3 of the
approach.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fecheck.contact.analytic import Plane
from fecheck.contact.pair import ContactPair
from fecheck.errors import FecheckError
from fecheck.fe.bodies.indenter import MeshIndenter
from fecheck.fe.bodies.pose import FramePose
from fecheck.fe.bodies.scene_bodies import _tibial_thickness
from fecheck.fe.bodies.solid import layer_solid
from fecheck.fe.knee import crosscheck
from fecheck.fe.knee.femoral import femoral_sheet
from fecheck.fe.solve.joint import ContactLayer, FemoralLayer, JointContact
from fecheck.laws import layer
from fecheck.laws.materials import ef_stiffness
from fecheck.laws.registry import LawInputs, spec_of
from fecheck.model.results import CompartmentResult
from fecheck.model.sides import split, with_layer_compression
from fecheck.scene import load_scene
from fecheck.scene.load import validate
from geometry.mesh import TriMesh
from geometry.plateau import plane_patch

# tibial E 20 MPa ν 0.3, femoral E 40 MPa ν 0.45, 6 mm in all, 30 % of it femoral
APART = {"contact": {"youngs_MPa": 20.0, "poisson": 0.3, "thickness_mm": 6.0,
                     "femoral_share": 0.3, "femoral_youngs_MPa": 40.0,
                     "femoral_poisson": 0.45}}
C_T = 0.7 * 20.0 / (1.3 * 0.4)            # 26.923 MPa, by hand
C_F = 0.55 * 40.0 / (1.45 * 0.1)          # 151.72 MPa
H_T, H_F = 4.2, 1.8                       # mm


def _flat_sheet(n: int, half: float) -> TriMesh:
    """An (n x n)-cell flat sheet over [-half, half]² at z = 0, normals up (mm)."""
    x = np.linspace(-half, half, n + 1)
    X, Y = np.meshgrid(x, x, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)])
    i = np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]
    a, b, c, d = i, i + (n + 1), i + (n + 2), i + 1
    faces = np.vstack([np.column_stack([a.ravel(), b.ravel(), c.ravel()]),
                       np.column_stack([a.ravel(), c.ravel(), d.ravel()])])
    return TriMesh(pts, faces)


def test_flat_on_flat_ef_takes_the_two_layers_in_series():
    """A flat 12 x 12 mm sheet 0.05 mm deep under a flat master: uniform pressure
    p = k·δ with k = 1/(h_t/c_t + h_f/c_f) = 5.957 N/mm³ (hand), force p·A."""
    scene = validate(APART)
    k_hand = 1.0 / (H_T / C_T + H_F / C_F)
    assert k_hand == pytest.approx(5.9572, rel=1e-4)
    depth = 0.05
    sheet = _flat_sheet(6, 6.0)
    pair = ContactPair(sheet, Plane([0.0, 0.0, depth], [0.0, 0.0, 1.0]))
    eye, zero = np.eye(3), np.zeros(3)
    surface = pair.evaluate((eye, zero), (eye, zero))
    law = spec_of(scene).build(LawInputs(scene))(math.nan, "medial")
    res = law(surface)
    assert res.force[2] == pytest.approx(k_hand * depth * 144.0, rel=1e-12)
    assert res.max_pressure == pytest.approx(k_hand * depth, rel=1e-12)
    assert spec_of(scene).stiffness(scene) == pytest.approx(k_hand, rel=1e-12)


def test_per_face_layers_in_series_use_each_face_thickness():
    """Bone-distance thicknesses per face: the equivalent tibial-material thickness gives
    k_f = c_t/h_eq = 1/(h_t/c_t + h_f/c_f) face by face (hand)."""
    sides = layer.sides(validate(APART))
    h_t, h_f = np.array([1.0, 2.5, 0.7]), np.array([2.0, 1.1, 3.0])
    k = layer.face_ef_stiffness(sides.equivalent_thickness(h_t, h_f), 20.0, 0.3)
    np.testing.assert_allclose(k, 1.0 / (h_t / C_T + h_f / C_F), rtol=1e-12)


def test_the_scanned_ef_takes_the_bone_distance_sides_in_series(monkeypatch):
    """With a femoral material of its own the scanned EF's per-face thickness is the
    equivalent h_t + h_f·c_t/c_f of the two sides (hand), not their plain sum."""
    from fecheck.model import scanned

    h_t, h_f = np.array([1.0, 2.5]), np.array([2.0, 1.1])
    monkeypatch.setattr(scanned, "_side_thicknesses", lambda scene: {"medial": (h_t, h_f)})
    scene = validate({**APART, "scanned": {"thickness": "bone-distance"}})
    np.testing.assert_allclose(scanned._face_thickness(scene, "medial"),
                               h_t + h_f * C_T / C_F, rtol=1e-12)


def test_a_sphere_plane_run_reports_each_layer():
    """The baseline (condyle spheres on flat layers) with the layers apart: the solved
    depth is the EF cap's at k = 1/(h_t/c_t + h_f/c_f) (hand k; cap F = k·πd²(R − d/3),
    measured +0.2 %, the mesh's), and the layers share each face's depth 0.8235 : 0.1765
    (δ_t/δ = (h_t/c_t)/(h_t/c_t + h_f/c_f), femoral ν 0.3 here)."""
    from fecheck.model.condyles import scene_knee
    from fecheck.model.run import run_scene
    from fecheck.reference.closed_forms import ef_cap_depth

    scene = load_scene("baseline", ["contact.femoral_share=0.3",
                                    "contact.femoral_youngs_MPa=40.0"])
    c_f = 0.7 * 40.0 / (1.3 * 0.4)
    k = 1.0 / (H_T / C_T + H_F / c_f)
    ratio = (H_T / C_T) / (H_T / C_T + H_F / c_f)
    assert ratio == pytest.approx(0.8235, abs=1e-4)
    run = run_scene(scene)
    knee = scene_knee(scene)
    for name, res in run.compartments.items():
        d = ef_cap_depth(res.force_N, knee.radius_mm(name), k)
        assert res.max_depth_mm == pytest.approx(d, rel=0.005)
        t, f = res.as_dict()["tibial_compression_mm"], res.as_dict()["femoral_compression_mm"]
        assert t / (t + f) == pytest.approx(ratio, rel=1e-12)
        assert 0.99 * res.max_depth_mm < t + f <= res.max_depth_mm


def test_the_depth_splits_by_the_layers_compliances():
    """δ_t/δ = (h_t/c_t)/(h_t/c_t + h_f/c_f) = 0.9293; each layer compresses p·h/c under
    the common pressure p = k·δ (hand)."""
    sides = layer.sides(validate(APART))
    ratio = sides.tibial_ratio(*layer.uniform_sides(validate(APART)))
    assert ratio == pytest.approx(0.92933, rel=1e-4)
    depth = np.array([0.0, 0.02, 0.05, 0.03])
    res = CompartmentResult(1.0, 1.0, 1.0, 1.0, 0.05, 0.0, np.zeros(3), face_depth_mm=depth)
    out = split(res, ratio)
    p = 0.05 / (H_T / C_T + H_F / C_F)
    assert out.tibial_compression_mm == pytest.approx(p * H_T / C_T, rel=1e-12)
    assert out.femoral_compression_mm == pytest.approx(p * H_F / C_F, rel=1e-12)
    d = out.as_dict()
    assert d["tibial_compression_mm"] + d["femoral_compression_mm"] == pytest.approx(0.05)


def test_defaults_give_one_material_and_no_split():
    """Unset keys: the EF stiffness is today's c/h bit for bit (the layers in series,
    c/(h/2 + h/2·c/c), differ from it in the last bit for some E, ν, h), the run result
    is untouched and its JSON has no new field."""
    scene = validate({})
    sides = layer.sides(scene)
    assert not sides.given and not sides.own_material
    for e, nu, h in ((20.0, 0.3, 6.0), (20.0, 0.3, 0.9), (13.0, 0.49, 4.1), (5.0, 0.45, 2.3)):
        one = validate({"contact": {"youngs_MPa": e, "poisson": nu, "thickness_mm": h}})
        assert spec_of(one).stiffness(one) == ef_stiffness(e, nu, h)    # today's k, exactly
    res = CompartmentResult(1.0, 1.0, 1.0, 1.0, 0.05, 0.0, np.zeros(3),
                            face_depth_mm=np.array([0.05]))
    assert "tibial_compression_mm" not in res.as_dict()

    class Run:
        compartments = {"medial": res}

    run = Run()
    assert with_layer_compression(scene, run) is run
    shared = validate({"contact": {"femoral_share": 0.25}})
    assert layer.sides(shared).given
    assert layer.sides(shared).tibial_ratio(*layer.uniform_sides(shared)) == 0.75


def test_the_two_layer_fe_reads_the_same_keys():
    """The femoral sheet gets share·h and the femoral material; the tibial layer the
    rest of h; unset, half of h each and one material."""
    sheet = _flat_sheet(2, 5.0)
    apart = validate(APART)
    fem = femoral_sheet(apart, sheet)
    np.testing.assert_allclose(fem.thickness_mm, 1.8)
    assert (fem.youngs_MPa, fem.poisson) == (40.0, 0.45)
    np.testing.assert_allclose(_tibial_thickness(apart, sheet), 4.2)
    same = femoral_sheet(validate({}), sheet)
    np.testing.assert_allclose(same.thickness_mm, 3.0)
    assert (same.youngs_MPa, same.poisson) == (20.0, 0.3)
    np.testing.assert_allclose(_tibial_thickness(validate({}), sheet), 3.0)


def test_the_series_fe_refuses_a_femoral_material_before_the_ef_run(monkeypatch):
    def no_ef_run(*args, **kwargs):
        raise AssertionError("the EF run started before the refusal")

    monkeypatch.setattr(crosscheck, "_ef_run", no_ef_run)
    scene = load_scene("femur_tibia", ["contact.femoral_youngs_MPa=40.0"])
    with pytest.raises(FecheckError, match="contact.femoral_youngs_MPa.*'two-layer'"):
        crosscheck.cross_check(scene, log=None)


def _disc(radius_mm: float, size: float, down: bool, turn_deg: float = 0.0) -> TriMesh:
    """A flat disc at z = 0, normals up (or `down`), turned `turn_deg` about z."""
    disc = plane_patch((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), radius=radius_mm, size=size,
                       refine_point=(0.0, 0.0, 0.0), refine_size=size,
                       refine_radius=radius_mm)
    c, s = math.cos(math.radians(turn_deg)), math.sin(math.radians(turn_deg))
    pts = disc.points @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]).T
    return TriMesh(pts, disc.faces[:, ::-1] if down else disc.faces)


def test_a_femoral_layer_twice_as_stiff_takes_a_third_of_the_approach():
    """Flat thin layers (0.5 mm on discs of 7 and 8 mm radius, meshes turned 17 deg), tibial
    E 20 MPa, femoral 40 MPa, both ν 0.3, pressed with 60 N. Within 3 mm of the centre (8
    thicknesses from the rim) each layer is a 1D column: its area-averaged compression is
    p·h/M with p the mean contact pressure there (measured +0.04 % tibial, −0.6 % femoral)
    and the femoral layer gives 1/3 of the two (measured 0.3320). A single vertex is no
    measure: the contact forces sit on the surface's corner vertices of quadratic
    elements 0.6 mm apart, and their local dimples are 10-15 % of a 0.5 mm column."""
    h, e_t, e_f, nu, r = 0.5, 20.0, 40.0, 0.3, 3.0
    m_t = e_t * (1 - nu) / ((1 + nu) * (1 - 2 * nu))          # 26.92 MPa
    tibial = _disc(7.0, 0.6, down=False)
    femoral = _disc(8.0, 0.6, down=True, turn_deg=17.0)
    tib = layer_solid(tibial, h, e_t, nu, layers=2, ratio=1.0)
    fem = layer_solid(femoral, h, e_f, nu, layers=2, ratio=1.0)
    indenter = MeshIndenter(femoral)
    gap, face, _ = indenter.hits(tibial.points, tib.normals)
    cand = np.flatnonzero(gap.gap_mm < 0.5)
    femur = FemoralLayer("femur", fem, np.unique(femoral.faces[face[cand]]))
    joint = JointContact([ContactLayer("tibia", tib, indenter, cand, femur)])
    up = np.array([0.0, 0.0, 1.0])
    sol = joint.solve(lambda q: FramePose(np.eye(3), q[0] * up),
                      lambda q: np.concatenate([up, np.zeros(3)])[:, None],
                      lambda q: np.array([60.0]), np.zeros(1))
    lc = sol.layers[0]
    w_t = tib.tributary_mm2 * (np.linalg.norm(tibial.points[:, :2], axis=1) < r)
    w_f = fem.tributary_mm2 * (np.linalg.norm(femoral.points[:, :2], axis=1) < r)
    tibial_give = -(w_t @ (tib.normal_rows @ lc.u)) / w_t.sum()
    femoral_give = -(w_f @ (fem.normal_rows @ lc.femoral_u)) / w_f.sum()
    p = (w_t @ (lc.force_N / tib.tributary_mm2)) / w_t.sum()
    assert lc.active[w_t > 0].all()
    assert tibial_give == pytest.approx(p * h / m_t, rel=0.01)
    assert femoral_give == pytest.approx(p * h / (2.0 * m_t), rel=0.01)
    assert femoral_give / (tibial_give + femoral_give) == pytest.approx(1.0 / 3.0, rel=0.01)


def test_a_calibration_fingerprint_tells_the_femoral_layer_apart():
    """A calibration fitted with a femoral cartilage of its own does not carry to a scene
    with another one; scenes that leave the keys alone keep their fingerprint (the same
    sha256 as without the keys: the keys' defaults are not hashed)."""
    import hashlib
    import json

    from fecheck.model.fingerprint import MATERIAL_KEYS, SHAPE_SECTIONS, scene_fingerprint
    from fecheck.scene.schema import SCHEMA

    base = load_scene("baseline")
    keys = [*MATERIAL_KEYS, *(k for k in SCHEMA if k.startswith(SHAPE_SECTIONS))]
    before = hashlib.sha256(json.dumps({k: base[k] for k in keys}, sort_keys=True,
                                       default=str).encode()).hexdigest()
    assert scene_fingerprint(base) == before
    prints = {scene_fingerprint(load_scene("baseline", over)) for over in (
        [], ["contact.femoral_youngs_MPa=40.0"], ["contact.femoral_poisson=0.45"],
        ["contact.femoral_share=0.3"])}
    assert len(prints) == 4
