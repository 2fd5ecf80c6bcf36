"""The FE of the knee with menisci with both cartilage layers deformable
(``fe.cartilage = "two-layer"``, `fecheck.fe.knee_menisci`): without menisci it is the
joint solver of `fecheck.fe.press` pressing the same tibial layers onto its own femoral
layers (another code path: its own pairing and condensation); with them, femur, femoral
layers and menisci balance and nothing penetrates. Coarse sheets (decimated: the
two-layer FE meshes the sheets as read)."""

from __future__ import annotations

import numpy as np
import pytest

from fecheck.fe import knee_menisci
from fecheck.scene import load_scene, with_values

COARSE = ["fe.cartilage=two-layer", "scanned.decimate_faces=1500"]
MENISCUS_MM = 2.5


def _layers(scene):
    from fecheck.fe.bodies import scene_bodies
    from fecheck.fe.press import build_layers
    from fecheck.fe.settings import FESettings

    plain = with_values(scene, menisci__dir="")
    return build_layers(scene_bodies(plain), scene["contact.youngs_MPa"],
                        scene["contact.poisson"], FESettings.from_scene(plain), lambda m: None)


def test_without_menisci_it_is_the_pressed_two_layer_joint():
    # With both menisci removed and the femur's rotation held, the femur presses the
    # tibial layers through femoral layers of its own: `fecheck.fe.press`'s joint solver
    # with its femoral layers (built over the same candidates, so the same crop) gives
    # the same force at every tibial vertex (measured to 3.2e-7 of the peak: both stop at
    # their own tolerances on the femur's step and the pairing).
    from fecheck.fe.femoral import FemoralBuilder, femoral_sheet
    from fecheck.fe.press import push_drive, solve_pressed
    from fecheck.fe.settings import FESettings
    from fecheck.model.menisci import run_menisci
    from fecheck.statics.newton import body_pose

    bare = load_scene("femur_tibia_menisci", [*COARSE, "menisci.sides=[]"])
    layers = _layers(bare)
    ef = run_menisci(bare)
    r = knee_menisci.knee_menisci_fe(bare, ef=ef, layers=layers, hold_rotation=True)
    assert r.cartilage == "two-layer"
    assert r.max_penetration_mm <= 1e-6 and abs(r.balance_N) <= 1e-8 * r.load_N
    settings = FESettings.from_scene(bare)
    rot, t = body_pose(np.asarray(ef.menisci["poses"]["tibia"]["q"]))
    femoral = FemoralBuilder(femoral_sheet(bare, layers[0].indenter.mesh), settings,
                             lambda m: None)
    sol, _, _, worst = solve_pressed(layers, push_drive(rot, t, np.array([0.0, 0.0, -r.load_N])),
                                     settings.candidate_gap_mm, settings, lambda m: None,
                                     femoral)
    assert worst <= 1e-6
    for lay, ref in zip(layers, sol.layers, strict=True):
        assert ref.femur is not None
        mine = np.zeros(lay.surface.n_points)
        p = r.pairs[f"{lay.body.name} femur-tibia"]
        mine[p.nodes] = p.force_N
        assert np.abs(mine - ref.force_N).max() <= 1e-6 * ref.force_N.max()


def test_two_layers_with_menisci_balance_and_nothing_penetrates():
    # Femur (through its layers), menisci and femoral layers balance to 1e-8 of the load,
    # in force along the femur's axis and in moment about its free abduction axis; every
    # pair is complementary and no vertex penetrates by more than 1e-6 mm.
    scene = load_scene("femur_tibia_menisci", COARSE)
    r = knee_menisci.knee_menisci_fe(scene, meniscus_size_mm=MENISCUS_MM, layers=_layers(scene))
    load = r.load_N
    assert abs(r.balance_N) <= 1e-8 * load
    assert np.abs(r.moment_balance_Nmm).max() <= 1e-8 * load
    assert 0.0 <= r.max_penetration_mm <= 1e-6
    femur = sum(float(p.force_N @ (p.normals @ -r.axis)) for name, p in r.pairs.items()
                if "femur" in name)
    assert femur == pytest.approx(load, abs=1e-8 * load)
    for side in ("medial", "lateral"):
        up, down = r.pairs[f"{side} femur-meniscus"], r.pairs[f"{side} meniscus-tibia"]
        on_meniscus = (-up.force_N @ up.normals + down.force_N @ down.normals
                       + r.spring_force_N[side])
        assert np.abs(on_meniscus).max() <= 1e-8 * load
        assert up.force_N.sum() > 0 and down.force_N.sum() > 0
    for p in r.pairs.values():
        assert p.force_N.min() >= 0.0 and p.gap_mm.min() >= -1e-6
        assert np.abs(p.force_N * p.gap_mm).max() <= 1e-6 * p.force_N.max()
