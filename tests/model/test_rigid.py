"""Rigid model (thesis §5.1): Table 5.1, Fig. 5.4 hand check, Table 5.2, mechanisms."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fecheck.errors import FecheckError
from fecheck.model.run import run_scene
from fecheck.scene import load_scene
from fecheck.scene.knee import Knee
from fecheck.statics.rigid import solve_rigid, unit_wrench

SCENES = Path(__file__).resolve().parents[2] / "validation" / "scenes"
UP = np.array([0.0, 0.0, 1.0])


def test_rigid_scene_reproduces_table_5_1():
    r = run_scene(load_scene(SCENES / "rigid.toml"))
    assert r.compartments["medial"].force_N == pytest.approx(323.71, abs=0.01)
    assert r.compartments["lateral"].force_N == pytest.approx(456.67, abs=0.01)


def test_rigid_split_solves_the_two_equilibrium_equations_of_design_4():
    # F_m + F_l = 800 − 2.0·9.81 and −20.4 F_m + 28.3 F_l = 800·7.9 (moments about y)
    a = np.array([[1.0, 1.0], [-20.4, 28.3]])
    f_m, f_l = np.linalg.solve(a, [800 - 19.62, 800 * 7.9])
    r = run_scene(load_scene(SCENES / "rigid.toml"))
    assert r.compartments["medial"].force_N == pytest.approx(f_m, rel=1e-12)
    assert r.compartments["lateral"].force_N == pytest.approx(f_l, rel=1e-12)


def _symmetric_knee() -> Knee:
    z = np.zeros(3)
    return Knee("right", {"medial": np.array([-25.0, 0.0, 30.0]),
                          "lateral": np.array([25.0, 0.0, 30.0])},
                {"medial": np.array([-25.0, 0.0, 0.0]), "lateral": np.array([25.0, 0.0, 0.0])},
                {n: z for n in ("ACL", "PCL", "MCL")}, {n: z for n in ("ACL", "PCL", "MCL")})


def test_fig_5_4_hand_check_symmetric_condyles():
    # Δx = 25 mm, r = 30 mm, 800 N at +3.5 mm, no gravity: F1·28.5 = F2·21.5 → 344 / 456 N
    load = unit_wrench(np.array([3.5, 0.0, -380.0]), UP) * 800.0
    sol = solve_rigid(_symmetric_knee(), {"medial": UP, "lateral": UP}, load, np.zeros(5),
                      (0, 1, 2, 3, 4))
    assert sol.contact_force_N["medial"] == pytest.approx(800 * 21.5 / 50, rel=1e-12)
    assert sol.contact_force_N["lateral"] == pytest.approx(800 * 28.5 / 50, rel=1e-12)
    assert (round(sol.contact_force_N["medial"]), round(sol.contact_force_N["lateral"])) == \
        (344, 456)


def test_ligament_rods_carry_no_load_table_5_2():
    r = run_scene(load_scene(SCENES / "rigid_ligaments.toml"))
    assert r.compartments["medial"].force_N == pytest.approx(323.71, abs=0.01)
    for lig in r.ligaments.values():
        assert abs(lig.force_N) < 1e-6
    assert r.ligaments["MCL"].length_mm == pytest.approx(84.82, abs=0.05)


def test_load_at_3_95_mm_equalises_the_rigid_split():
    r = run_scene(load_scene(SCENES / "rigid.toml", ["load.point_mm=[3.95, 12.8, -380.0]"]))
    f_m, f_l = r.compartments["medial"].force_N, r.compartments["lateral"].force_N
    assert abs(f_m - f_l) < 0.01 * (f_m + f_l) / 2


def test_a_load_nothing_resists_is_an_error():
    with pytest.raises(FecheckError, match=r"cannot carry the load in DOFs \['x', 'internal'\]"):
        run_scene(load_scene(SCENES / "rigid.toml", ["load.direction=[0.3, 0.0, 1.0]"]))


def test_rods_on_too_few_dofs_are_statically_indeterminate():
    with pytest.raises(FecheckError, match="statically indeterminate"):
        run_scene(load_scene(SCENES / "rigid_ligaments.toml", ["dofs.free=['z', 'abduction']"]))


def test_equal_force_rods_follow_fig_5_12():
    # Fig. 5.12 / thesis §5.2: with equal condyle forces the rods carry the imbalance:
    # small near the contact points' midpoint x = 3.95 mm (not zero: the weight acts at
    # x = 0), MCL in compression and ACL, PCL in tension when the load moves medially,
    # the reverse laterally; linear in the load point (linear statics).
    forces = {}
    for x in (-0.1, 3.9, 7.9):
        r = run_scene(load_scene(SCENES / "equal_force.toml",
                                 [f"load.point_mm=[{x}, 12.8, -380.0]"]))
        assert r.compartments["medial"].force_N == r.compartments["lateral"].force_N
        forces[x] = {k: v.force_N for k, v in r.ligaments.items()}
    assert forces[-0.1]["MCL"] < 0 < forces[7.9]["MCL"]
    for lig in ("ACL", "PCL"):
        assert forces[-0.1][lig] > 0 > forces[7.9][lig]
        assert abs(forces[3.9][lig]) < 0.05 * abs(forces[7.9][lig])
        mid = 0.5 * (forces[-0.1][lig] + forces[7.9][lig])
        assert forces[3.9][lig] == pytest.approx(mid, abs=1e-9 * abs(forces[7.9][lig]))
