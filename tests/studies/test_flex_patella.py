"""`fecheck flex` with the patella (patella.dir): its columns in the table, CSV and JSON,
its surfaces and bundles in the VTK series, the refusals, and the tibiofemoral run without
it untouched."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from fecheck.model import patella
from fecheck.scene import load_scene
from fecheck.studies import flex

PATELLA = "--set=patella.dir='fecheck:knee/lenhart2015_patella'"
KNEE = ["femur_tibia_ligaments", "--set", "scanned.decimate_faces=3000", "--set",
        "scanned.thickness='uniform'", "--set", "load.frame='tibia'", "--set",
        "load.force_N=30.0", "--axis-point=-1.757,-0.150,22.272", "--axis-dir=1,0,0"]


def _main(argv):
    from fecheck.cli import main

    return main(["flex", *KNEE, *argv])


def test_cli_reports_the_patella_per_angle_and_writes_it_to_vtk(tmp_path, capsys):
    pv = pytest.importorskip("pyvista")
    code = _main([PATELLA, "--angles", "0:2:1", "--json", str(tmp_path / "f.json"),
                  "--vtk", str(tmp_path / "vtk")])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "patella per angle: pf_flex°" in out
    assert [float(line.split()[0]) for line in out.splitlines()[-3:]] == [0.0, 1.0, 2.0]
    doc = json.loads((tmp_path / "f.json").read_text())
    first = doc["angles"][0]
    for key in (*patella.PF_COORDINATES, "PF_force_N", "PF_area_mm2", "PF_max_pressure_MPa",
                "PF_cop_x_mm", "PF_cop_y_mm", "PF_cop_z_mm", "PT_N", "lPFL_N", "mPFL_N",
                "quadriceps_N"):
        assert np.isfinite(first[key]), key
    assert len(first["patella_ligaments_N"]) == 20
    assert first["quadriceps_N"] == pytest.approx(111.442)
    assert sum(first["quadriceps_muscles_N"].values()) == pytest.approx(111.442)
    assert "pf_flex_deg" in doc["signs"]
    # the patella sits on the trochlea: anterior of the tibial plateau, above it
    assert first["PF_cop_y_mm"] > 30.0 and first["PF_force_N"] > 50.0
    estimate = float(re.search(r"at most ([0-9.]+) MB", err).group(1))
    assert _main(["--angles", "0:2:1", "--vtk", str(tmp_path / "bare")]) == 0
    bare = float(re.search(r"at most ([0-9.]+) MB", capsys.readouterr()[1]).group(1))
    patella_mb = sum(f.stat().st_size for f in (tmp_path / "vtk").glob("patella_*")) / 1e6
    assert patella_mb <= estimate - bare + 0.1     # the estimate counts the patella's files
    names = {p.name for p in (tmp_path / "vtk").iterdir()}
    assert {f"patella_{i:03d}.vtu" for i in range(3)} <= names
    assert {f"patella_ligaments_{i:03d}.vtu" for i in range(3)} <= names
    reader = pv.get_reader(str(tmp_path / "vtk" / "flex.pvd"))
    reader.set_active_time_value(2.0)
    parts = reader.read()
    assert len(parts) == 5
    lines = parts[4]
    assert lines.n_cells == 20
    assert np.allclose(sorted(lines.cell_data["tension_N"]),
                       sorted(doc["angles"][2]["patella_ligaments_N"].values()))
    face = parts[3].cell_data["pressure_MPa"]          # face-averaged, at most the peak
    assert 0.5 * doc["angles"][2]["PF_max_pressure_MPa"] < face.max()
    assert face.max() <= doc["angles"][2]["PF_max_pressure_MPa"]
    assert np.all(face[parts[3].cell_data["part"] == 1] == 0.0)


def test_fe_at_with_the_patella_reports_the_patellofemoral_contact(tmp_path, capsys):
    # one element level through the thickness keeps it quick; the PF force is the
    # patella's statics, so FE and EF meet closely (tests/fe/test_patella_fe.py)
    path = tmp_path / "flex.json"
    code = _main([PATELLA, "--set=fe.layers=1", "--angles", "0:30:30", "--fe-at", "30",
                  "--json", str(path)])
    _, err = capsys.readouterr()
    assert code == 0, err
    assert re.search(r"30° PF +force", err)
    row, = json.loads(path.read_text())["fe"]
    assert row["flexion_deg"] == 30.0
    assert row["balance"] < 1e-8 and row["patella_balance"] < 1e-8
    assert row["PF_fe_force_N"] == pytest.approx(row["PF_ef_force_N"], rel=0.01)
    assert row["PF_fe_area_mm2"] > 0 and row["PF_fe_p_max_MPa"] > 0
    assert {"medial_fe_split", "lateral_fe_split"} <= set(row)
    assert "patellofemoral_fe_split" not in row


def test_no_quadriceps_force_is_refused_on_one_line(capsys):
    code = _main([PATELLA, "--set=patella.quadriceps_N=0.0", "--angles", "0"])
    _, err = capsys.readouterr()
    assert code == 2
    assert "patella.quadriceps_N" in err and "Traceback" not in err


def test_a_left_knee_with_the_patella_is_refused():
    from fecheck.errors import FecheckError

    with pytest.raises(FecheckError, match="the patella data and its pf_r coordinates are a "
                                           "right knee's"):
        patella.build_patella({"knee.side": "left",
                               "patella.dir": "fecheck:knee/lenhart2015_patella"})


def test_a_missing_patella_folder_is_refused_on_one_line(tmp_path, capsys):
    code = _main([f"--set=patella.dir='{tmp_path}'", "--angles", "0"])
    _, err = capsys.readouterr()
    assert code == 2
    assert "holds no lenhart2015_R_patella_cartilage.stl" in err


def test_without_the_patella_the_tibiofemoral_run_never_enters_its_code(monkeypatch):
    """patella.dir unset (every existing scene): the patella is neither built nor solved,
    so the tibiofemoral path and its numbers are those of the run without the key; the
    rows carry no patella column."""
    def refuse(*args, **kwargs):
        raise AssertionError("the patella's code ran")

    monkeypatch.setattr(flex, "build_patella", refuse)
    monkeypatch.setattr(patella, "solve_knee", refuse)
    scene = load_scene("femur_tibia_ligaments", ["scanned.decimate_faces=3000"])
    assert scene["patella.dir"] == ""
    run = flex.run_flex(scene, [0.0, 1.0], flex.given_axis((-1.757, -0.150, 22.272),
                                                           (1.0, 0.0, 0.0)))
    assert run.stopped is None and run.patella is None
    row = run.points[1].row()
    assert not [k for k in row if k.startswith(("pf_", "PF_", "quadriceps"))]


def test_an_angle_beyond_one_steps_reach_is_approached_in_one_degree_steps(monkeypatch):
    """From 30° to 60° in one step the patella leaves the trochlea and the solve stops at
    60°; approached in `flex.SUBSTEP_DEG` steps from 30°, 60° is solved at the equilibrium
    a 1° sweep finds there (the same path, to the solver's round-off)."""
    scene = load_scene("femur_tibia_ligaments", [
        "patella.dir='fecheck:knee/lenhart2015_patella'", "load.frame='tibia'",
        "load.force_N=30.0"])
    axis = flex.given_axis((-1.757, -0.150, 22.272), (1.0, 0.0, 0.0))
    jumped = flex.run_flex(scene, [0.0, 30.0, 60.0], axis)
    swept = flex.run_flex(scene, np.arange(0.0, 61.0), axis)
    assert jumped.stopped is None and swept.stopped is None
    assert [p.flexion_deg for p in jumped.points] == [0.0, 30.0, 60.0]
    np.testing.assert_allclose(jumped.points[-1].q, swept.points[-1].q, rtol=0, atol=1e-9)
    np.testing.assert_allclose(jumped.points[-1].patella.q, swept.points[-1].patella.q,
                               rtol=0, atol=1e-9)
    monkeypatch.setattr(flex, "SUBSTEP_DEG", 90.0)
    direct = flex.run_flex(scene, [0.0, 30.0, 60.0], axis)
    assert direct.stopped.startswith("flexion 60°") and len(direct.points) == 2
