"""`fecheck validate`: the report, its rows and values, and its failure handling."""

import csv
import shutil

import numpy as np

from fecheck.cli import main
from fecheck.validate import default_validation_dir

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _csv_rows(path):
    with open(path, newline="") as fh:
        return {r["quantity"]: r for r in csv.DictReader(fh)}


def test_quick_rigid_rows_reproduce_table_5_1_against_hand_statics(tmp_path, capsys):
    out = tmp_path / "val"
    assert main(["validate", "--quick", "--only", "rigid", "mesh", "--out", str(out)]) == 0
    # Independent reference (DESIGN §4): F_m + F_l = 800 - 2.0·9.81 and
    # -20.4·F_m + 28.3·F_l = 800·7.9 (moments about x = 0 of the reference point).
    f_m, f_l = np.linalg.solve([[1.0, 1.0], [-20.4, 28.3]], [800 - 19.62, 800 * 7.9])
    rows = _csv_rows(out / "table_5_1.csv")
    # Rounding of the thesis's 2 decimals: 0.01 N.
    assert abs(float(rows["medial force N"]["fecheck"]) - f_m) < 0.01
    assert abs(float(rows["lateral force N"]["fecheck"]) - f_l) < 0.01
    assert abs(float(rows["medial force N"]["thesis"]) - 323.71) < 1e-9
    report = (out / "report.md").read_text()
    for ref in ("Table 5.1", "Table 5.2", "Fig. 5.2", "Fig. 5.4", "Fig. 5.22", "Table 3.1",
                "Fig. 3.3"):
        assert f"### {ref}:" in report, ref
    assert "| Table 5.1 | `table_5_1` | reproduced |" in report
    assert "x = +7.9 mm" in report
    for png in out.glob("*.png"):
        assert png.read_bytes()[:8] == PNG_MAGIC, png
    assert "[1/2]" in capsys.readouterr().err


def test_fig_5_4_hand_check_matches_the_lever_rule(tmp_path):
    out = tmp_path / "val"
    assert main(["validate", "--quick", "--only", "rigid", "--out", str(out)]) == 0
    with open(out / "fig_5_4_data.csv", newline="") as fh:
        data = list(csv.DictReader(fh))
    for r in data:   # symmetric condyles ±25 mm, 800 N, no gravity: F2 = 800·(25 + s)/50
        s = float(r["shift_mm"])
        assert abs(float(r["F2_lateral_N"]) - 800 * (25 + s) / 50) < 1e-6
        assert abs(float(r["F1_medial_N"]) + float(r["F2_lateral_N"]) - 800) < 1e-6


def test_unknown_row_name_is_a_one_line_error(tmp_path, capsys):
    assert main(["validate", "--only", "no_such_row", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no_such_row" in err[0] and "rigid" in err[0]


def test_a_failing_script_becomes_a_failed_row_and_the_report_is_written(tmp_path):
    vdir = tmp_path / "validation"
    vdir.mkdir()
    for name in ("report.py", "thesis_values.py"):
        shutil.copy(default_validation_dir() / name, vdir / name)
    (vdir / "row_broken.py").write_text("def rows(quick, out):\n    raise ValueError('boom')\n")
    (vdir / "row_missing.py").write_text(
        "from report import guarded, require\n"
        "def rows(quick, out):\n"
        "    return [guarded('x', 'needs a module', 'Fig. 0', out,\n"
        "                    lambda: require('fecheck.no_such_module', 'nobody'))]\n")
    out = tmp_path / "out"
    assert main(["validate", "--dir", str(vdir), "--out", str(out)]) == 1
    report = (out / "report.md").read_text()
    assert "failed: ValueError: boom" in report
    assert "skipped: fecheck.no_such_module is not available yet (nobody)" in report
