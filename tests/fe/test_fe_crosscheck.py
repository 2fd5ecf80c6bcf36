"""`fecheck fe` on the scene's own geometry: the general FE path against the converged
axisymmetric FE, hand statics of the whole joint, frictionless contact on slopes, the
scanned knee, and the scenes it must refuse.

References: the axisymmetric FE at the scene's fe.axisym_size_mm (converged: 0.1 mm is
within 0.3 % of 0.05 mm, tests/fe/test_fe_axisym.py), the scene's load and weight, the
plateau plane's normal.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from conftest import require_knee_data

from fecheck.errors import FecheckError
from fecheck.fe.knee.crosscheck import cross_check
from fecheck.model.assembly import applied_load, free_indices
from fecheck.scene import load_scene
from fecheck.scene.knee import plane_normal
from fecheck.statics.newton import pose, twist_basis

SCENES = Path(__file__).resolve().parents[2] / "validation" / "scenes"


def _fe_wrench(chk, rot: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(6,) FE contact wrench on the tibia about the world origin, from the vertex forces
    (each along minus its surface normal) at tibia pose (R, t)."""
    layer = chk.layer
    x = layer.surface.points @ rot.T + t
    f = -chk.fe_force_N[:, None] * (layer.solid.normals @ rot.T)
    return np.concatenate([f.sum(axis=0), np.cross(x, f).sum(axis=0)])


def _free_residual(scene, check) -> np.ndarray:
    """Generalised force on the scene's free DOFs at the FE pose: load, gravity and the FE
    contact forces (N, N·mm); zero at equilibrium."""
    q = _q(check.pose["fe"])
    theta = math.radians(scene["dofs.flexion_deg"])
    rot, t = pose(q, theta)
    total = applied_load(scene)(rot, t)[0] + sum(_fe_wrench(chk, rot, t)
                                                 for chk in check.compartments.values())
    return (twist_basis(q, theta).T @ total)[list(free_indices(scene))]


def _q(pose_dict: dict) -> np.ndarray:
    return np.array([pose_dict["x_mm"], pose_dict["y_mm"], pose_dict["z_mm"],
                     math.radians(pose_dict["abduction_deg"]),
                     math.radians(pose_dict["internal_deg"])])


@pytest.fixture(scope="module")
def baseline():
    scene = load_scene()
    return scene, cross_check(scene, log=None)


def test_general_path_matches_the_axisymmetric_reference_on_the_baseline(baseline):
    # acceptance: p_max within 1 %, area within 2 % at the default mesh (measured: medial
    # -0.06 % / +0.07 %, lateral -0.02 % / -1.1 %)
    _, check = baseline
    for chk in check.compartments.values():
        dev = chk.deviation()
        assert abs(dev["max_pressure"]) < 0.01
        assert abs(dev["area"]) < 0.02


def test_whole_joint_fe_balances_the_load_and_reports_its_own_split(baseline):
    scene, check = baseline
    residual = _free_residual(scene, check)
    scale = scene["load.force_N"]
    assert abs(residual[0]) < 1e-8 * scale                       # z force, N
    assert abs(residual[1]) < 1e-8 * scale * 100.0               # abduction moment, N·mm
    split = check.split("fe")
    assert sum(split.values()) == pytest.approx(1.0, abs=1e-12)
    assert 0.0 < split["medial"] < 1.0 and split != check.split("ef_model")
    for chk in check.compartments.values():
        assert chk.fe_force_N.min() >= 0.0                       # no tension
        assert chk.max_penetration_mm <= 1e-6


def test_fe_json_carries_geometry_mode_pose_and_both_sides(baseline):
    _, check = baseline
    data = check.as_dict()
    assert data["mode"] == "joint"
    geometry = data["fe_geometry"]
    assert geometry["tibial_surface"] == "plane" and geometry["thickness_source"] == "uniform"
    assert geometry["deformable_layers"] == 1
    assert geometry["dofs"] > geometry["nodes"] > 0 and geometry["elements"] > 0
    assert set(data["pose"]) == {"fe", "ef"}
    for comp in data["compartments"].values():
        for side in ("fe", "ef_model"):
            assert {"force_N", "axial_force_N", "max_pressure_MPa", "mean_pressure_MPa",
                    "area_mm2", "center_of_pressure_mm"} <= set(comp[side])
        assert comp["cop_distance_mm"] >= 0.0


def test_the_smooth_baseline_peak_is_no_spike_and_the_json_carries_three_scales(baseline):
    # a sphere on a flat plateau disc: no spike, no roughness; the disc mean of a
    # Hertz-like p0·sqrt(1 - r²/a²) over radius L is p0·(2a²/3L²)(1 - (1 - L²/a²)^1.5),
    # within 3 % of the smoothed peak (a from the FE area)
    _, check = baseline
    data = check.as_dict()
    for name, chk in check.compartments.items():
        peaks, rough = data["compartments"][name]["fe_peaks"], \
            data["compartments"][name]["tibial_roughness"]
        assert not peaks["lone_spike"] and not peaks["on_rough_feature"]
        assert peaks["vertex_MPa"] == chk.fe.max_pressure_MPa
        assert peaks["vertex_MPa"] < 1.2 * peaks["neighbour_MPa"]
        a2, L2 = chk.fe.area_mm2 / math.pi, peaks["smoothing_length_mm"] ** 2
        disc = 2 * a2 / (3 * L2) * (1 - (1 - L2 / a2) ** 1.5)
        assert peaks["smoothed_MPa"] == pytest.approx(disc * peaks["vertex_MPa"], rel=0.03)
        assert peaks["face_MPa"] <= peaks["vertex_MPa"]
        assert rough["rms_mm"] < 1e-6 and rough["terrace_mm"] == 0.0


def test_frictionless_on_an_inclined_plateau():
    # every contact force acts along the plateau's normal: the compartment resultant has
    # no component along the slope (a sheared layer would carry ~26 % of it there)
    scene = load_scene(SCENES / "inclined.toml", ["fe.layers=1"])
    check = cross_check(scene, mode="compartment", log=None)
    rot, _ = pose(_q(check.pose["ef"]), math.radians(scene["dofs.flexion_deg"]))
    for name, chk in check.compartments.items():
        normal = rot @ plane_normal(scene[f"plateau.{name}_angles_deg"])
        force = chk.fe.force_vector_N
        tangential = force - (force @ normal) * normal
        assert np.linalg.norm(tangential) < 1e-9 * np.linalg.norm(force)
        # compartment mode: the FE carries the EF compartment force, same line
        assert force == pytest.approx(chk.ef_model.force_vector_N, rel=1e-9, abs=1e-9)


def test_scanned_femur_tibia_runs_on_its_own_surfaces():
    require_knee_data()
    scene = load_scene(SCENES / "femur_tibia.toml", ["scanned.decimate_faces=1500"])
    check = cross_check(scene, log=None)
    assert check.geometry["tibial_surface"] == ("mesh:lenhart2015_R_tibia_cartilage_medial.stl"
                                                " + mesh:lenhart2015_R_tibia_cartilage_"
                                                "lateral.stl")
    assert check.geometry["femoral_surface"] == "mesh:lenhart2015_R_femur_cartilage.stl"
    assert check.geometry["thickness_source"] == "bone-distance"
    assert any("series thickness" in note for note in check.notes)
    residual = _free_residual(scene, check)
    assert abs(residual[0]) < 1e-8 * scene["load.force_N"]
    for chk in check.compartments.values():
        assert chk.fe_force_N.min() >= 0.0
        assert chk.max_penetration_mm <= 1e-6
        assert chk.fe.max_pressure_MPa > 0 and chk.fe.area_mm2 > 0


@pytest.mark.parametrize("scene, overrides, message", [
    ("rigid.toml", [], "no cartilage"),
    ("baseline.toml", ["constraints.equal_forces=true"], "constraints.equal_forces"),
    ("equal_force.toml", [], "no cartilage"),
    ("baseline.toml", ["ligaments.model='rod'"], "ligaments.model = 'rod'"),
    ("baseline.toml", ["fe.mode='both'"], "fe.mode"),
])
def test_scenes_the_fe_cannot_model_faithfully_are_refused(scene, overrides, message):
    with pytest.raises(FecheckError, match=message.replace(".", r"\.").replace("(", r"\(")):
        cross_check(load_scene(SCENES / scene, overrides), log=None)


def test_automatic_levels_thicken_for_a_nearly_incompressible_layer():
    from fecheck.fe.bodies.settings import FESettings

    assert FESettings().levels(0.3) == 2 and FESettings().levels(0.49) == 3
    assert FESettings(layers=4).levels(0.49) == 4
