"""`fecheck run`: table, JSON keys, CSV, plots, one-line errors and light imports."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fecheck.cli import main

SCENES = Path(__file__).resolve().parents[2] / "validation" / "scenes"


def test_run_writes_json_with_the_documented_keys(tmp_path, capsys):
    out = tmp_path / "r.json"
    assert main(["run", "--json", str(out), "--csv", str(tmp_path / "r.csv")]) == 0
    printed = capsys.readouterr().out
    assert "medial" in printed and "lateral" in printed and "force N" in printed
    data = json.loads(out.read_text())
    assert data["converged"] is True and data["iterations"] >= 1
    assert set(data["pose"]) == {"x_mm", "y_mm", "z_mm", "abduction_deg", "internal_deg",
                                 "adduction_deg", "internal_rotation_deg"}
    assert "varus" in data["pose_signs"]["adduction_deg"]
    for c in ("medial", "lateral"):
        assert {"force_N", "max_pressure_MPa", "mean_pressure_MPa", "area_mm2",
                "max_depth_mm", "torque_Nmm"} <= set(data["compartments"][c])
        # the `exact` block: closed-form EF at the solved force, deviation in %
        assert abs(data["exact"][c]["deviation_percent"]["area_mm2"]) < 1.0
    assert {"total", "solve"} <= set(data["timing_s"])
    assert data["timing_s"]["solve"] <= data["timing_s"]["total"]
    # the forces balance the load and the weight (800 − 19.62 N, vertical)
    total = sum(data["compartments"][c]["force_N"] for c in ("medial", "lateral"))
    assert total == pytest.approx(780.38, abs=0.05)
    with open(tmp_path / "r.csv") as fh:
        row = next(csv.DictReader(fh))
    assert float(row["medial_force_N"]) == pytest.approx(
        data["compartments"]["medial"]["force_N"], rel=1e-12)


def test_run_reports_ligament_forces(tmp_path):
    out = tmp_path / "r.json"
    assert main(["run", str(SCENES / "rigid_ligaments.toml"), "--json", str(out)]) == 0
    ligs = json.loads(out.read_text())["ligaments"]
    assert set(ligs) == {"ACL", "PCL", "MCL"}
    assert all(abs(v["force_N"]) < 1e-6 for v in ligs.values())


@pytest.mark.parametrize("args, words", [
    (["--set", "contact.poisson=0.5"], ["contact.poisson", "0.5"]),
    (["--set", "contact.youngs_MPa=-3"], ["contact.youngs_MPa"]),
    (["--set", "contact.thickness_mm=0"], ["contact.thickness_mm"]),
    (["--set", "load.force_N=nan"], ["NaN"]),
    (["--set", "contact.poison=0.4"], ["unknown scene key", "contact.poisson"]),
    (["no_such_scene.toml"], ["not found", "no_such_scene.toml"]),
])
def test_bad_input_exits_non_zero_with_one_line(args, words, capsys):
    assert main(["run", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("fecheck: error:") and "\n" not in err
    for word in words:
        assert word in err


def test_poisson_close_to_half_warns_on_one_line(capsys):
    # Hertz: the linear EF is refused past ν 0.49 (tests/cli/test_robust_inputs.py)
    assert main(["run", str(SCENES / "rigid.toml"), "--set", "contact.poisson=0.495",
                 "--set", "model.kind='sphere-plane'", "--set", "dofs.free=['z', 'abduction']",
                 "--set", "mesh.plateau_refine_mm=1.5", "--set", "contact.law='hertz'"]) == 0
    err = [line for line in capsys.readouterr().err.splitlines() if line]
    assert len(err) == 1 and err[0].startswith("fecheck: warning:") and "0.5" in err[0]


def test_run_says_it_leaves_the_patella_out(capsys):
    # the rigid model solves in milliseconds; patella.dir is read by `fecheck flex` alone
    assert main(["run", str(SCENES / "rigid.toml"), "--set",
                 "patella.dir='fecheck:knee/lenhart2015_patella'"]) == 0
    assert "note: patella.dir is read by `fecheck flex` only" in capsys.readouterr().out


def test_run_without_plot_does_not_import_pyvista():
    code = ("import sys; from fecheck.cli import main; "
            "rc = main(['run', '--set', 'mesh.plateau_refine_mm=1.5']); "
            "print('pyvista' in sys.modules, 'matplotlib' in sys.modules, rc)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip().splitlines()[-1]
    assert out == "False False 0"


def test_plot_writes_one_png_with_both_compartments(tmp_path):
    assert main(["run", "--plot", str(tmp_path), "--set", "mesh.plateau_refine_mm=1.5"]) == 0
    pngs = sorted(p.name for p in tmp_path.glob("*.png"))
    assert pngs == ["pressure_map.png"]
    assert all((tmp_path / p).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in pngs)


def test_compartment_force_is_given_as_vector_axial_component_and_magnitude():
    # on a 14-15° plateau the contact force leans off the tibia's axis: its axial part
    # (along R e_z, compressive +) is below its magnitude, and the vector's norm is it
    import math

    from fecheck.model.run import run_scene
    from fecheck.scene import load_scene
    from fecheck.statics.newton import pose

    scene_dir = Path(__file__).resolve().parents[2] / "validation" / "scenes"
    for name in ("inclined", "rigid"):
        scene = load_scene(scene_dir / f"{name}.toml")
        result = run_scene(scene)
        q = [result.pose[k] for k in ("x_mm", "y_mm", "z_mm")] + [
            math.radians(result.pose["abduction_deg"]), math.radians(result.pose["internal_deg"])]
        rot, _ = pose(q, math.radians(scene["dofs.flexion_deg"]))
        for comp in result.compartments.values():
            f = np.asarray(comp.force_vector_N)
            assert np.linalg.norm(f) == pytest.approx(comp.force_N, rel=1e-12)
            assert comp.axial_force_N == pytest.approx(-f @ rot[:, 2], rel=1e-12)
            if name == "inclined":
                assert comp.axial_force_N < 0.99 * comp.force_N
