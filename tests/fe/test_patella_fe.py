"""The patella in the FE cross-check (`fecheck.fe.knee.patella_layer`): each rigid body of the
FE joint balances by hand statics, the FE patellofemoral force meets the EF's, the
generalised solver with independent bodies gives each body's one-body answer, what the
FE does not model with the patella is refused on one line, and the patella's femoral
indenter fades contact at the femoral sheet's rim as the EF does.

The knee is coarse (tibial sheets decimated to 1,500 faces, one element level through the
thickness) so the module runs in seconds; the patellar sheet is the EF's own."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from conftest import require_knee_data
from scipy.spatial.transform import Rotation

from fecheck.errors import FecheckError
from fecheck.fe.bodies.budget import MAX_DOFS, layer_dofs, prepared_for_size, sheet_dofs
from fecheck.fe.bodies.indenter import SphereIndenter
from fecheck.fe.bodies.pose import FramePose
from fecheck.fe.bodies.scene_bodies import scene_bodies
from fecheck.fe.bodies.settings import FESettings
from fecheck.fe.bodies.solid import layer_solid
from fecheck.fe.knee import registry
from fecheck.fe.knee.crosscheck import cross_check
from fecheck.fe.knee.patella_layer import PATELLA_KIND, patella_body
from fecheck.fe.solve.joint import ContactLayer, JointContact
from fecheck.model.assembly import applied_load, free_indices
from fecheck.model.patella import RIM_MM
from fecheck.model.run import ligament_springs
from fecheck.scene import load_scene
from fecheck.statics.newton import body_pose, pose, twist_basis
from geometry.plateau import plane_patch

PATELLA = "patella.dir='fecheck:knee/lenhart2015_patella'"
COARSE = [PATELLA, "scanned.decimate_faces=1500", "fe.layers=1"]
BALANCE_TOL = 1e-8
"""Largest free-DOF imbalance of a body over its load (the brief's bound; measured at
the coarse knee: 1e-15 to 1e-13)."""


def _scene(*extra: str):
    return load_scene("femur_tibia_ligaments", [*COARSE, *extra])


@pytest.fixture(scope="module")
def knee():
    require_knee_data()
    scene = _scene()
    return scene, cross_check(scene, log=None)


def _contact(chk, rot, t) -> tuple[np.ndarray, np.ndarray]:
    """The FE contact forces of one compartment on its body at (R, t): points (n, 3) and
    forces (n, 3), world."""
    x = chk.layer.surface.points @ rot.T + t
    return x, -chk.fe_force_N[:, None] * (chk.layer.solid.normals @ rot.T)


def _wrench(x: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Force and moment about the world origin of point forces f at x."""
    return np.concatenate([f.sum(axis=0), np.cross(x, f).sum(axis=0)])


def _pull(at: np.ndarray, toward: np.ndarray, tension: np.ndarray) -> np.ndarray:
    """Force and moment of tensions (n,) N at points `at` along the lines to `toward`."""
    d = toward - at
    return _wrench(at, tension[:, None] * d / np.linalg.norm(d, axis=1)[:, None])


def _hand_statics(scene, check) -> tuple[np.ndarray, np.ndarray]:
    """The total wrench on the patella (6,) and the generalised force on the tibia's free
    DOFs, each force along its line by hand: the FE contact forces, the bundle, tendon and
    quadriceps tensions along their lines, the tibia's load, gravity and bundles."""
    model = check.extra.model
    q = np.array([check.pose["fe"].q[i] for i in range(5)])
    theta = math.radians(scene["dofs.flexion_deg"])
    rot, t = pose(q, theta)
    prot, pt = body_pose(check.extra.q_fe)
    on_patella, on_tibia = np.zeros(6), np.zeros(6)
    for name, chk in check.compartments.items():
        if name == "patellofemoral":
            on_patella += _wrench(*_contact(chk, prot, pt))
        else:
            on_tibia += _wrench(*_contact(chk, rot, t))
    # quadriceps: each tension toward its femoral point
    quads = model.quadriceps
    x_q = quads.patella_points @ prot.T + pt
    on_patella += _pull(x_q, quads.femur_points, quads.tension_N)
    # patellofemoral bundles: patella point toward femur point
    pfl = model.femoral
    x_p = pfl.tibia_points @ prot.T + pt
    on_patella += _pull(x_p, pfl.femur_points, pfl.tensions(prot, pt))
    # tendon: equal and opposite on the patella and the tibia
    tendon = model.tendon
    x_t, x_pat = tendon.ends(((rot, t), (prot, pt)))
    tension = tendon.tensions(((rot, t), (prot, pt)))
    on_patella += _pull(x_pat, x_t, tension)
    on_tibia += _pull(x_t, x_pat, tension)
    on_tibia += sum(part(rot, t)[0] for part in [applied_load(scene), *ligament_springs(scene)])
    return on_patella, (twist_basis(q, theta).T @ on_tibia)[list(free_indices(scene))]


def test_each_body_balances_by_hand_statics(knee):
    scene, check = knee
    on_patella, on_tibia = _hand_statics(scene, check)
    quads = float(check.extra.model.quadriceps.tension_N.sum())
    scale = np.repeat([quads, 100.0 * quads], 3)                  # N, and N·mm over 100 mm
    assert np.abs(on_patella / scale).max() < BALANCE_TOL
    free = np.array(list(free_indices(scene)))
    tibia_scale = np.where(free < 3, 1.0, 100.0) * scene["load.force_N"]
    assert np.abs(on_tibia / tibia_scale).max() < BALANCE_TOL
    # the patella is loaded: the quadriceps press it on the trochlea
    pf = check.compartments["patellofemoral"]
    assert pf.fe.force_N > 0.3 * quads
    assert pf.max_penetration_mm <= 1e-6 and pf.fe_force_N.min() >= 0.0


def test_the_fe_patellofemoral_force_meets_the_efs(knee):
    # the PF force is the patella's statics (quadriceps, tendon, bundles): FE and EF differ
    # only by how far the poses differ (measured at the coarse knee 0.0-0.1 %, at the
    # default knee 0.0-0.3 % over 0-90°); area and p_max differ as for the tibia (the EF
    # column has no shear spread: FE area 35-40 % smaller, p_max 50 % higher at 0°)
    _, check = knee
    pf = check.compartments["patellofemoral"]
    assert pf.fe.force_N == pytest.approx(pf.ef_model.force_N, rel=0.01)
    assert pf.cop_distance_mm < 1.0
    assert 0.4 < pf.fe.area_mm2 / pf.ef_model.area_mm2 < 1.0
    # and the split stays tibial: the PF force is not in it
    assert set(check.split("fe")) == {"medial", "lateral"}
    assert sum(check.split("fe").values()) == pytest.approx(1.0, abs=1e-12)


def _press(loads: list[float]):
    """The same layer on a flat patch pressed by a sphere, once per load, each layer on its
    own rigid body translating along z: the generalised solver with len(loads) bodies."""
    surface = plane_patch((0.0, 0.0, 0.0), np.array([0.0, 0.0, 1.0]), radius=10.0, size=1.0)
    sphere = SphereIndenter(np.array([0.0, 0.0, 20.0]), 20.0)
    cand = np.flatnonzero(sphere.gap(surface.points, surface.vertex_normals).gap_mm < 1.0)
    names = [f"B{i}" for i in range(len(loads))]
    joint = JointContact([ContactLayer(n, layer_solid(surface, 2.0, 10.0, 0.3, layers=1),
                                       sphere, cand, body=n) for n in names])
    k = len(loads)
    up = np.array([0.0, 0.0, 1.0])

    def poses(q):
        return tuple(FramePose(np.eye(3), q[i] * up, "W", n) for i, n in enumerate(names))

    def bases(q):
        b = np.zeros((k, 6, k))
        for i in range(k):
            b[i, 2, i] = 1.0
        return b

    return joint.solve(poses, bases, lambda q: np.asarray(loads), np.zeros(k))


def test_independent_bodies_each_get_the_one_body_answer():
    one = _press([40.0])
    two = _press([40.0, 90.0])
    # hand statics: each body carries its own load
    for sol, loads in ((one, [40.0]), (two, [40.0, 90.0])):
        for layer, load in zip(sol.layers, loads, strict=True):
            assert layer.force_N.sum() == pytest.approx(load, rel=1e-10)
    # the first body of the pair answers as the lone body: same forces, same pose
    assert np.allclose(two.layers[0].force_N, one.layers[0].force_N, rtol=0, atol=1e-9)
    assert two.q[0] == pytest.approx(one.q[0], abs=1e-10)
    # the heavier body presses deeper
    assert two.q[1] > two.q[0] > 0.0


@pytest.mark.parametrize("override, message", [
    ("fe.cartilage='two-layer'", "fe.cartilage = 'series'"),
    ("fe.mode='compartment'", "fe.mode = 'joint'"),
    ("fe.prepare='on'", "fe.prepare = 'auto' or 'off'"),
])
def test_what_the_fe_does_not_model_with_the_patella_is_refused(override, message):
    require_knee_data()
    with pytest.raises(FecheckError, match=message) as err:
        cross_check(_scene(override), log=None)
    assert "\n" not in str(err.value)


def _rim_distance(mesh, points: np.ndarray) -> np.ndarray:
    """Exact distance (mm) of points (n, 3) to the mesh's boundary edges (an edge of one
    face), point to segment."""
    e = np.sort(mesh.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    edges, counts = np.unique(e, axis=0, return_counts=True)
    a, b = mesh.points[edges[counts == 1, 0]], mesh.points[edges[counts == 1, 1]]
    ab = b - a
    t = np.einsum("nej,ej->ne", points[:, None] - a, ab) / np.einsum("ej,ej->e", ab, ab)
    foot = a + np.clip(t, 0.0, 1.0)[..., None] * ab
    return np.linalg.norm(points[:, None] - foot, axis=2).min(axis=1)


def _smoothstep(phi: np.ndarray) -> np.ndarray:
    x = np.clip(phi / RIM_MM, 0.0, 1.0)
    return 3.0 * x**2 - 2.0 * x**3


RIM_W_TOL = 0.12
"""|w(φ) - w(exact distance)| allowed: the FE's φ is the EF's, interpolated over the face
from its corners' distances to rim samples 1/8 of an edge apart (measured on the femoral
sheet, 1.9 mm edges, at the centroids of its 669 faces 0.1-1.9 mm from the rim: φ within
0.14 mm, w within 0.097); without the fade w would read 1 (up to 0.99 off)."""


def test_the_patellar_femoral_indenter_fades_at_the_rim_as_the_ef(knee):
    # a patellar vertex 0.3 mm inside the femoral sheet at a face's centroid, its ray along
    # the face normal: away from the rim its gap is -0.3 mm; within RIM_MM of the open rim
    # the EF's faded depth, w(φ)·(-0.3) with w = 3x² - 2x³, x = φ/RIM_MM (0 at the rim);
    # an open gap is kept; the twist row is the faded gap's derivative (central differences)
    scene, check = knee
    indenter = patella_body(scene, check.extra.model).indenter
    mesh = indenter.mesh
    y = mesh.points[mesh.faces].mean(axis=1)
    phi = _rim_distance(mesh, y)
    band = np.flatnonzero((phi > 0.1) & (phi < RIM_MM - 0.1))
    inner = np.flatnonzero(phi > RIM_MM + 0.5)
    m = mesh.face_normals
    depth = 0.3
    for faces, w in ((band, _smoothstep(phi[band])), (inner, np.ones(len(inner)))):
        pts, nrm = y[faces] - depth * m[faces], -m[faces]
        gap = indenter.gap(pts, nrm)
        assert np.abs(gap.gap_mm / -depth - w).max() < RIM_W_TOL
        assert np.all(indenter.gap(y[faces] + depth * m[faces], nrm).gap_mm
                      == pytest.approx(depth, abs=1e-9))
    assert np.abs(gap.gap_mm + depth).max() < 1e-9                 # the inner faces: no fade
    # the twist rows of the band's faded gaps
    pts, nrm = y[band] - depth * m[band], -m[band]
    rows = indenter.gap(pts, nrm).twist
    h = 1e-5
    for k, xi in enumerate(np.eye(6)):
        def moved(step, xi=xi):
            # the body turned by the rotation vector step·ω and shifted by step·v
            rot = Rotation.from_rotvec(step * xi[3:]).as_matrix()
            return indenter.gap(pts @ rot.T + step * xi[:3], nrm @ rot.T).gap_mm
        fd = (moved(h) - moved(-h)) / (2 * h)
        assert np.abs(fd - rows[:, k]).max() < 1e-5 * max(1.0, np.abs(rows[:, k]).max())


def test_fe_prepare_auto_leaves_the_patellar_sheet_as_it_is(knee):
    # refined twice the coarse knee's layers pass MAX_DOFS, where 'auto' prepares a mesh
    # sheet that gets smaller prepared, as the patellar one would; it is kept (a prepared
    # sheet and its femoral surface are cut for a tibial sheet)
    scene, check = knee
    bodies = [*scene_bodies(scene), patella_body(scene, check.extra.model)]
    settings = FESettings.from_scene(scene, refine=2)
    levels = settings.levels(scene["contact.poisson"])
    assert sum(layer_dofs(b.surface, 2, levels) for b in bodies) > MAX_DOFS
    assert sheet_dofs(bodies[-1].surface, settings, levels, True) < layer_dofs(
        bodies[-1].surface, 2, levels)                 # preparing would make it smaller
    assert prepared_for_size(bodies, settings, levels)[-1] is False


def test_a_scene_with_two_bodies_beyond_the_tibia_is_refused_on_one_line(monkeypatch):
    # the FE joint solves one body beyond the tibia: a second kind the scene also has is
    # named in a one-line refusal, not solved as if it were absent
    scene = _scene()
    assert registry.scene_body(scene) is PATELLA_KIND
    monkeypatch.setattr(registry, "BODIES",
                        (PATELLA_KIND, dataclasses.replace(PATELLA_KIND, name="tray")))
    with pytest.raises(FecheckError, match="patella and tray") as err:
        registry.scene_body(scene)
    assert "\n" not in str(err.value)
    assert registry.scene_body(load_scene("femur_tibia_ligaments")) is None
