"""The scanned knee's population keys: cartilage thickness and ligament bundle factors."""

from __future__ import annotations

import json

import numpy as np
import pytest

from fecheck.model.run import run_scene
from fecheck.model.scanned import bundle_springs
from fecheck.scene import load_scene
from fecheck.scene.packaged import data_dir

QUICK = ["scanned.decimate_faces=1500"]


def test_bundle_factors_scale_every_bundle_of_the_file():
    scene = load_scene("femur_tibia_ligaments", ["scanned.ligament_stiffness_scale=1.2",
                                                 "scanned.ligament_slack_scale=0.98"])
    raw = json.loads((data_dir("fecheck:knee/lenhart2015") / "ligaments.json").read_text())
    names, springs = bundle_springs(scene)
    assert len(springs) == len(raw) == 55
    by_name = {b["name"]: b["parameters"] for b in raw}
    for name, spring in zip(names, springs, strict=True):
        p = by_name[name]
        assert spring.stiffness_N == pytest.approx(1.2 * p["linear_stiffness"]["value"])
        assert spring.slack_length_mm == pytest.approx(
            0.98 * 1000.0 * p["slack_length"]["value"])


def test_thickness_factor_equals_the_inverse_modulus_factor_of_the_linear_ef():
    # the linear EF's stiffness is E(1 − ν)/((1 + ν)(1 − 2ν) h): twice the thickness is
    # half the modulus, face by face, so the equilibria are the same
    thick = run_scene(load_scene("femur_tibia_ligaments",
                                 [*QUICK, "scanned.thickness_scale=2.0"]))
    soft = run_scene(load_scene("femur_tibia_ligaments", [*QUICK, "contact.youngs_MPa=10.0"]))
    base = run_scene(load_scene("femur_tibia_ligaments", QUICK))
    for c in ("medial", "lateral"):
        a, b = thick.compartments[c], soft.compartments[c]
        assert a.force_N == pytest.approx(b.force_N, rel=1e-6)
        assert a.max_pressure_MPa == pytest.approx(b.max_pressure_MPa, rel=1e-6)
        assert a.max_pressure_MPa < base.compartments[c].max_pressure_MPa
    assert np.allclose(thick.pose.q, soft.pose.q, atol=1e-7)
