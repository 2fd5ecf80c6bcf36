"""The femoral layer of the two-layer FE with menisci (`fecheck.fe.knee.knee_menisci`) where the
femur's contact moves beyond the first candidates: a candidate whose normal meets the
femoral sheet outside the layer grows the layer there (`_grown_femoral`), one whose normal
meets no femoral cartilage is left out (`OFF_SHEET`). Coarse sheets, the EF's meniscus
layer rigid (1e6 MPa): from that EF pose the femur travels far (measured with 1.25 mm
meniscus tetrahedra: 0.96 mm and 0.43°), and before these two the FE stopped ("misses the
femoral layer built over the first candidates")."""

from __future__ import annotations

import numpy as np
import pytest
from menisci_helpers import assert_balanced

from fecheck.fe.knee import knee_menisci
from fecheck.scene import load_scene, with_values

SETS = ["fe.cartilage=two-layer", "scanned.decimate_faces=1500", "menisci.youngs_MPa=1e6"]
MENISCUS_MM = 2.5
GROWN = "grown over the sheet"
LEFT_OUT = "left out of the femur pairs"


@pytest.fixture(scope="module")
def knee():
    """(scene, its EF run, its tibial layers): shared by the FE runs below."""
    from fecheck.fe.bodies.scene_bodies import scene_bodies
    from fecheck.fe.bodies.settings import FESettings
    from fecheck.fe.solve.press import build_layers
    from fecheck.model.menisci import run_menisci

    scene = load_scene("femur_tibia_menisci", SETS)
    plain = with_values(scene, menisci__dir="")
    layers = build_layers(scene_bodies(plain), scene["contact.youngs_MPa"],
                          scene["contact.poisson"], FESettings.from_scene(plain),
                          lambda m: None)
    return scene, run_menisci(scene), layers


def _fe(knee, messages: list[str]):
    scene, ef, layers = knee
    return knee_menisci.knee_menisci_fe(scene, meniscus_size_mm=MENISCUS_MM, ef=ef,
                                        layers=layers, log=messages.append)


def _forces(r) -> dict[str, np.ndarray]:
    """Per pair the contact force (N) on each slave node up to the largest it paired (0 on
    those it did not)."""
    out = {}
    for name, p in r.pairs.items():
        f = np.zeros(int(p.nodes.max(initial=-1)) + 1)
        f[p.nodes] = p.force_N
        out[name] = f
    return out


@pytest.mark.slow
def test_candidates_beyond_the_first_layer_are_paired_or_left_out(knee):
    # The femur moves far enough that rim candidates' normals leave the femoral sheet:
    # they are left out (infinite gap), and the answer balances in force and moment to
    # 1e-8 of the load with nothing penetrating (`menisci_helpers.assert_balanced`).
    messages: list[str] = []
    r = _fe(knee, messages)
    assert any(LEFT_OUT in m for m in messages)
    assert_balanced(r)
    assert r.cartilage == "two-layer"


@pytest.mark.slow
def test_a_grown_femoral_layer_answers_as_one_built_wide(knee, monkeypatch):
    # Built first over the vertices within 0.1 mm of the femur only (REACH_MM -0.4 under
    # the 0.5 mm candidate gap), the layer misses later candidates and grows; built over
    # those within 3.5 mm at once, it never grows. Both balance, and each pair's nodal
    # contact forces agree to 1e-2 of its largest, its total to 2e-3: the two layers end
    # at other cut walls (6 mm beyond the points they were built over,
    # `fecheck.fe.knee.femoral.CROP_MM`), which moves the contact a little. Measured: grown
    # against wide 5.7e-3 (nodal, medial femur-meniscus) and 6.4e-4 (total, medial
    # femur-tibia); two wide layers (3.5 and 5.5 mm) differ by 5.7e-3 and 1.5e-4.
    messages: list[str] = []
    monkeypatch.setattr(knee_menisci, "REACH_MM", -0.4)
    grown = _fe(knee, messages)
    assert any(GROWN in m for m in messages)
    assert_balanced(grown)
    messages.clear()
    monkeypatch.setattr(knee_menisci, "REACH_MM", 3.0)
    wide = _fe(knee, messages)
    assert not any(GROWN in m for m in messages)
    assert_balanced(wide)
    a, b = _forces(grown), _forces(wide)
    assert a.keys() == b.keys()
    for name in a:
        n = max(len(a[name]), len(b[name]))
        fa, fb = np.pad(a[name], (0, n - len(a[name]))), np.pad(b[name], (0, n - len(b[name])))
        assert np.abs(fa - fb).max() <= 1e-2 * fb.max(), name
        assert fa.sum() == pytest.approx(fb.sum(), rel=2e-3), name
