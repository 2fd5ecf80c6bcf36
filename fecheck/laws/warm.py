"""Compile every contact and law kernel once, into numba's on-disk cache.

numba compiles a kernel at its first call in a process that finds no cached copy (a few
seconds each); the setup script runs this module once after installing, so that no
user's first run compiles anything. One small contact of each kind is evaluated through
the hot path (`fecheck.laws.fused`) and the full path, with each compiled law: a plane,
a sphere and a mesh master (its walked and its tree-queried evaluations), clipped and
whole-face areas, and a closed mesh master inside by its winding number.

    python -m fecheck.laws.warm
"""

from __future__ import annotations

import time

import numpy as np

from fecheck.contact import ContactPair, Plane, Sphere
from fecheck.laws.calibrated import Calibration, calibrated_params
from fecheck.laws.foundation import blankevoort_params
from fecheck.laws.fused import CompiledLaw, compiled_law, contact_wrench, linear_law
from fecheck.laws.kernel import BLANKEVOORT, CALIBRATED
from fecheck.laws.layer import face_elastic_foundation
from geometry.icosphere import icosphere


def _laws(n_faces: int) -> list[CompiledLaw]:
    cal = Calibration(5.0, 0.6)
    return [linear_law(1.0), face_elastic_foundation(np.ones(n_faces)),
            compiled_law(BLANKEVOORT, blankevoort_params(5.0, 0.3, 3.0)),
            compiled_law(CALIBRATED, calibrated_params(cal))]


def compile_kernels() -> float:
    """Evaluate one contact of each kind with each law (see the module); seconds taken."""
    t0 = time.perf_counter()
    slave = icosphere(10.0, 2)
    eye, zero = np.eye(3), np.zeros(3)
    cases = [(Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]), (eye, zero)),
             (Sphere([0.0, 0.0, -10.0], 10.5), (eye, zero)),
             (icosphere(12.0, 2), (eye, np.array([0.0, 0.0, -12.0])))]
    poses = [(eye, np.array([0.0, 0.0, 9.5])), (eye, np.array([0.0, 0.0, 9.45]))]
    for master, master_pose in cases:
        for area in ("clipped", "whole-face"):
            pair = ContactPair(slave, master, area=area)
            for law in _laws(slave.n_faces):
                for pose in poses:               # a rebuilt, then a reused candidate set
                    w = contact_wrench(pair, pose, master_pose, law)
                    law(pair.evaluate(pose, master_pose))
                    assert w.max_depth > 0, "the warm-up contacts must touch"
    # a closed master inside by its winding number (a meniscus): the winding tree's kernels
    pair = ContactPair(slave, icosphere(12.0, 2), mesh_sign="winding")
    pair.evaluate(poses[0], cases[2][1])
    return time.perf_counter() - t0


if __name__ == "__main__":
    print(f"fecheck: contact and law kernels ready ({compile_kernels():.1f} s)")
