"""Checks shared by the tests of the FE with menisci (`fecheck.fe.knee.knee_menisci`)."""

from __future__ import annotations

import numpy as np
import pytest


def assert_balanced(r) -> None:
    """The femur's contact forces (femur-tibia and femur-meniscus pairs, summed here along
    the axis it is pushed along) balance the load, and each meniscus's contact forces and
    horn springs cancel, to 1e-8 of the load, each meniscus carrying some; every pair is
    complementary with no gap below -1e-6 mm, and no vertex outside the pairs penetrates
    either; the femur's moment about each free rotation balances to 1e-8 of the load x
    1 mm."""
    load = r.load_N
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
    assert 0.0 <= r.max_penetration_mm <= 1e-6
    assert abs(r.balance_N) <= 1e-8 * load
    assert np.abs(r.moment_balance_Nmm).max() <= 1e-8 * load
