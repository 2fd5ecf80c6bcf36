"""Inputs a tester and real data tried: each answered before any work by one line naming
the cause and the fix (exit 2), never a traceback, an exhausted memory or minutes of
silence. Sizes are counted before anything is made (angles, sweep points, faces)."""

from __future__ import annotations

import json
import math
import time

import pytest

from fecheck.cli import main, negative_value_hint
from fecheck.errors import FecheckError
from fecheck.studies.flex import MAX_ANGLES, given_axis, parse_angles
from fecheck.studies.sweep import MAX_POINTS, parse_values


def _error(capsys) -> str:
    """The one error line of a refused command (no traceback)."""
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.startswith("fecheck")]
    assert lines, err
    return lines[-1]


# ------------------------------------------------------------------ sizes before work
def test_flex_angles_are_counted_before_any_is_made():
    """0:160:1e-7 would be 1.6e9 angles (13 GB for the array alone, killed at 23 GB): it is
    refused at once with the step that fits; the cap's own edge is exact."""
    start = time.perf_counter()
    with pytest.raises(FecheckError, match=r"1,600,000,001 angles.*STEP >= 0\.081"):
        parse_angles("0:160:1e-7")
    assert time.perf_counter() - start < 0.5
    # 0.081 is the proposed step: it must fit, and 0.08 (2,001 angles) must not
    assert len(parse_angles("0:160:0.081")) == math.floor(160 / 0.081) + 1 <= MAX_ANGLES
    with pytest.raises(FecheckError, match="2,001 angles"):
        parse_angles("0:160:0.08")
    assert len(parse_angles("-30:160:0.1")) == 1901          # 0.1° over the whole range fits


@pytest.mark.parametrize("text", ["0:inf:10", "-inf:0:1", "0:10:inf", "nan", "0,nan,10",
                                  "0:nan:1"])
def test_flex_angles_that_are_not_finite_are_refused(text):
    with pytest.raises(FecheckError, match="--angles"):
        parse_angles(text)


def test_flex_nan_axis_point_is_refused_before_the_scene(capsys):
    assert main(["flex", "femur_tibia_ligaments", "--axis-point", "nan,0,0",
                 "--axis-dir", "1,0,0", "--angles", "0:0:1"]) == 2
    assert "--axis-point 'nan,0,0': give three finite numbers" in _error(capsys)


def test_a_flexion_axis_refusal_prints_its_angle_and_limit_apart():
    """78.47° from x is past the limit acos(0.2) = 78.46°: the message must not print
    both as "78°"."""
    a = math.radians(78.47)
    with pytest.raises(FecheckError, match=r"78\.47° .* more than the 78\.46° allowed"):
        given_axis([0.0, 0.0, 0.0], [math.cos(a), math.sin(a), 0.0])
    a = math.radians(78.45)
    assert given_axis([0.0, 0.0, 0.0], [math.cos(a), math.sin(a), 0.0]).direction[0] > 0


def test_sweep_points_are_counted_before_any_is_made(capsys):
    """10:20:100000000 took 4 GB and 300 s of silence: refused at once (exit 2)."""
    start = time.perf_counter()
    assert main(["sweep", "baseline", "--param", "contact.youngs_MPa",
                 "--values", "10:20:100000000"]) == 2
    assert time.perf_counter() - start < 5.0
    assert f"100,000,000 points, more than the {MAX_POINTS:,}" in _error(capsys)
    assert len(parse_values(f"0:1:{MAX_POINTS}")) == MAX_POINTS
    with pytest.raises(FecheckError, match="values listed"):
        parse_values(",".join(["1"] * (MAX_POINTS + 1)))
    with pytest.raises(FecheckError, match="finite"):
        parse_values("10:inf:3")


# ------------------------------------------------------------------ one-line errors
@pytest.mark.parametrize("argv, option", [
    (["flex", "femur_tibia_ligaments", "--angles", "-10:0:5"], "--angles=-10:0:5"),
    (["flex", "femur_tibia_ligaments", "--axis-point", "-0.48,0,0", "--axis-dir", "1,0,0"],
     "--axis-point=-0.48,0,0"),
    (["sweep", "--param", "load.point_mm[0]", "--values", "-1:1:3"], "--values=-1:1:3"),
])
def test_a_negative_value_read_as_an_option_gets_the_equals_hint(argv, option, capsys):
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    assert f"write {option}" in capsys.readouterr().err


def test_the_equals_hint_is_only_given_before_a_negative_value():
    assert negative_value_hint("argument --set: expected one argument", ["run", "--set"]) == ""
    assert negative_value_hint("argument --angles: expected one argument",
                               ["flex", "--angles", "--json", "x"]) == ""


def test_a_calibration_file_without_a_compartment_names_it(tmp_path, capsys):
    path = tmp_path / "cal.json"
    path.write_text(json.dumps({"version": 1, "compartments": {"medial": {"C": 5.0,
                                                                          "n": 1.0}}}))
    assert main(["run", "scanned-knee", "--set", "contact.law=ef-calibrated",
                 "--set", f"contact.calibration='{path}'",
                 "--set", "scanned.decimate_faces=1500"]) == 2
    line = _error(capsys)
    assert "holds no lateral compartment (it has medial)" in line
    assert "fecheck calibrate" in line


def test_a_menisci_dir_without_its_files_names_them(capsys):
    assert main(["run", "femur_tibia_menisci", "--set",
                 "menisci.dir='fecheck:knee/lenhart2015'"]) == 2
    line = _error(capsys)
    assert "holds no menisci.json, meniscal_ligaments.json" in line
    assert "fecheck:knee/smith2019_menisci" in line


@pytest.mark.parametrize("argv", [
    lambda d: ["knee", "import", "--femur", str(d), "--tibia", str(d), "-o", str(d / "k.toml")],
    lambda d: ["run", "scanned-knee", "--set", f"geometry.tibia='{d}'"],
    lambda d: ["run", "scanned-knee", "--set", "contact.law=ef-calibrated",
               "--set", f"contact.calibration='{d}'"],
])
def test_a_directory_given_for_a_file_says_so(argv, tmp_path, capsys):
    folder = tmp_path / "meshes"
    folder.mkdir()
    assert main(argv(folder)) == 2
    line = _error(capsys)
    assert f"{folder} is a directory" in line and "not found" not in line
