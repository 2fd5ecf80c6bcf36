"""The FE of the knee with menisci with both cartilage layers deformable
(``fe.cartilage = "two-layer"``, `fecheck.fe.knee.knee_menisci`): without menisci it is the
joint solver of `fecheck.fe.solve.press` pressing the same tibial layers onto its own femoral
layers (another code path: its own pairing and condensation); with them, femur, femoral
layers and menisci balance and nothing penetrates. Coarse sheets (decimated: the
two-layer FE meshes the sheets as read)."""

from __future__ import annotations

import numpy as np
from menisci_helpers import assert_balanced

from fecheck.fe.knee import knee_menisci
from fecheck.scene import load_scene, with_values

COARSE = ["fe.cartilage=two-layer", "scanned.decimate_faces=1500"]
MENISCUS_MM = 2.5


def _layers(scene):
    from fecheck.fe.bodies.scene_bodies import scene_bodies
    from fecheck.fe.bodies.settings import FESettings
    from fecheck.fe.solve.press import build_layers

    plain = with_values(scene, menisci__dir="")
    return build_layers(scene_bodies(plain), scene["contact.youngs_MPa"],
                        scene["contact.poisson"], FESettings.from_scene(plain), lambda m: None)


def test_without_menisci_it_is_the_pressed_two_layer_joint():
    # With both menisci removed and the femur's rotation held, the femur presses the
    # tibial layers through femoral layers of its own: `fecheck.fe.solve.press`'s joint solver
    # with its femoral layers (built over the same candidates, so the same crop: the
    # candidate gap plus the knee FE's REACH_MM) gives the same force at every tibial
    # vertex (measured to 3.6e-7 of the peak: both stop at their own tolerances on the
    # femur's step and the pairing).
    from fecheck.fe.bodies.pose import FramePose
    from fecheck.fe.bodies.settings import FESettings
    from fecheck.fe.knee.femoral import FemoralBuilder, femoral_sheet
    from fecheck.fe.solve.press import push_drive, solve_pressed
    from fecheck.model.menisci import run_menisci
    from fecheck.statics.newton import body_pose

    bare = load_scene("femur_tibia_menisci", [*COARSE, "menisci.sides=[]"])
    layers = _layers(bare)
    ef = run_menisci(bare)
    r = knee_menisci.knee_menisci_fe(bare, ef=ef, layers=layers, hold_rotation=True)
    assert r.cartilage == "two-layer"
    assert r.max_penetration_mm <= 1e-6 and abs(r.balance_N) <= 1e-8 * r.load_N
    settings = FESettings.from_scene(bare)
    X_WT = FramePose(*body_pose(np.asarray(ef.menisci["poses"]["tibia"]["q"])))
    femoral = FemoralBuilder(femoral_sheet(bare, layers[0].indenter.mesh), settings,
                             lambda m: None)
    sol, _, _, worst = solve_pressed(layers, push_drive(X_WT, np.array([0.0, 0.0, -r.load_N])),
                                     settings.candidate_gap_mm + knee_menisci.REACH_MM,
                                     settings, lambda m: None, femoral)
    assert worst <= 1e-6
    for lay, ref in zip(layers, sol.layers, strict=True):
        assert ref.femur is not None
        mine = np.zeros(lay.surface.n_points)
        p = r.pairs[f"{lay.body.name} femur-tibia"]
        mine[p.nodes] = p.force_N
        assert np.abs(mine - ref.force_N).max() <= 1e-6 * ref.force_N.max()


def test_two_layers_with_menisci_balance_and_nothing_penetrates():
    # Femur (through its layers) and menisci balance to 1e-8 of the load in force and in
    # moment about its free abduction axis; every pair is complementary and no vertex
    # penetrates by more than 1e-6 mm (`menisci_helpers.assert_balanced`).
    scene = load_scene("femur_tibia_menisci", COARSE)
    r = knee_menisci.knee_menisci_fe(scene, meniscus_size_mm=MENISCUS_MM, layers=_layers(scene))
    assert_balanced(r)
    assert r.cartilage == "two-layer" and r.moment_balance_Nmm.shape == (1,)
