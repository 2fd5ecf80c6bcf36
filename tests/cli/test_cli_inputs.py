"""Bad CLI input gives one line `fecheck: error: ...` naming the cause, exit code 2, and
never a traceback: unreadable scene files, wrong values and wrong types."""

from __future__ import annotations

import os

import pytest

from fecheck.cli import main


def _binary(tmp_path):
    path = tmp_path / "x.toml"
    path.write_bytes(b"\x96\xff\x00" + os.urandom(256))
    return [str(path)]


def _write(name: str, text: str):
    def make(tmp_path):
        path = tmp_path / name
        path.write_text(text)
        return [str(path)]

    return make


_RIGHT_LANDMARKS = ("{condyle_center = {medial = [-20.4, 12.8, 16.8], lateral = [28.3, 12.8, "
                    "25.8]}, contact_point = {medial = [-20.4, 12.8, -8.7], lateral = [28.3, "
                    "12.8, -6.0]}, femur_attachment = {ACL = [17.0, 31.4, 20.4], PCL = [-7.9, "
                    "21.3, 8.8], MCL = [-38.0, 13.8, 11.2]}, tibia_attachment = {ACL = [0, 0, "
                    "0], PCL = [18.3, 35.5, -21.3], MCL = [-3.0, -1.0, -64.6]}}")
"""The baseline right knee (thesis Table B.1) as a knee.landmarks table."""

CASES = {
    "binary file": (_binary, ["x.toml", "not a text file", "UTF-8"]),
    "directory": (lambda tmp_path: [str(tmp_path)], ["is a directory", "scene TOML file"]),
    "missing file": (lambda tmp_path: [str(tmp_path / "nope.toml")],
                     ["not found", "nope.toml"]),
    "empty free DOFs": (lambda tmp_path: ["--set", "dofs.free=[]"],
                        ["dofs.free is empty", "at least one"]),
    "word for a number": (lambda tmp_path: ["--set", "contact.poisson=abc"],
                          ["contact.poisson must be a number", "'abc'"]),
    "unknown key": (lambda tmp_path: ["--set", "no.such.key=1"],
                    ["unknown scene key 'no.such.key'", "fecheck keys"]),
    "section as a value": (lambda tmp_path: ["--set", "contact=3"],
                           ["contact is a section", "contact.law"]),
    "number for a string": (_write("n.toml", "name = 3\n"), ["n.toml", "name must be a string"]),
    "table for a string": (_write("t.toml", "[contact.law]\nx = 1\n"),
                           ["t.toml", "contact.law must be a string, got a table"]),
    "value for a section": (_write("s.toml", "contact = 3\n"), ["s.toml", "contact is a section"]),
    "string landmark": (_write("k.toml", '[knee]\npreset = "custom"\n'
                               '[knee.landmarks.condyle_center]\nmedial = "abc"\n'),
                        ["knee.landmarks.condyle_center.medial", "3 numbers"]),
    "empty file": (_write("e.toml", ""), ["scene", "e.toml is empty: it sets no key",
                                          "no scene file to run the baseline"]),
    "comments only": (_write("c.toml", "# all commented out\n# name = 'x'\n"),
                      ["c.toml is empty but for comments"]),
    "landmarks of the other side": (
        lambda tmp_path: ["--set", "knee.preset=custom", "--set", "knee.side=left",
                          "--set", f"knee.landmarks={_RIGHT_LANDMARKS}"],
        ["knee.side = 'left' puts the medial compartment at +x", "medial condyle centre at "
         "x = -20.4 mm and the lateral at +28.3 mm, as in a right knee"]),
    "empty polynomial rows": (_write("p.toml", '[plateau]\nkind = "polynomial"\n'
                                     'medial_coefficients = [[]]\n'
                                     'lateral_coefficients = [[]]\n'),
                              ["plateau.medial_coefficients", "rectangular list"]),
}


@pytest.mark.parametrize("case", list(CASES))
def test_bad_input_is_one_line_naming_the_cause(case, tmp_path, capsys):
    make, words = CASES[case]
    assert main(["run", *make(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("fecheck: error: "), err
    for word in words:
        assert word in lines[0]


def test_the_fe_verb_reports_an_empty_free_dof_list_too(capsys):
    assert main(["fe", "--set", "dofs.free=[]"]) == 2
    assert capsys.readouterr().err.startswith("fecheck: error: --set on ")


def test_an_unknown_keys_prefix_names_the_sections(capsys):
    assert main(["keys", "no_such_section"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "no scene key starts with 'no_such_section'" in err
    assert "contact" in err


def _one_error_line(capsys) -> str:
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err and captured.out == ""     # nothing ran first
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("fecheck: error: "), captured.err
    return lines[0]


def test_a_stress_selection_matching_no_case_is_an_error_before_any_case(capsys, monkeypatch):
    import fecheck.studies.stress as stress

    def run_case(case, timeout_s, runner=None):
        raise AssertionError("a case ran")
    monkeypatch.setattr(stress, "run_case", run_case)
    assert main(["stress", "--only", "zzzz"]) == 2
    line = _one_error_line(capsys)
    assert "no stress case matches 'zzzz'" in line and "case names begin with: baseline" in line
    assert main(["stress", "--only", "Mesh: NaN"]) == 2               # names are case-sensitive
    assert "did you mean 'mesh: nan vertex'?" in _one_error_line(capsys)
    assert main(["stress", "--quick", "--only", "poisson 0.2"]) == 2  # a full-matrix case
    assert "drop --quick" in _one_error_line(capsys)


@pytest.mark.parametrize("value", ["0", "-1", "nan", "inf", "abc"])
def test_a_stress_timeout_must_be_a_positive_number_of_seconds(capsys, value):
    with pytest.raises(SystemExit) as stop:
        main(["stress", f"--timeout={value}", "--only", "E nan"])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert f"argument --timeout: must be a positive number of seconds, got '{value}'" in err


def test_mesh_info_on_a_folder_says_it_is_a_folder(tmp_path, capsys):
    assert main(["mesh", "info", str(tmp_path)]) == 2
    assert f"{tmp_path} is a folder, not a mesh file" in _one_error_line(capsys)


def test_a_side_against_the_presets_knee_names_the_conflict():
    from fecheck.scene import load_scene
    from fecheck.scene.relevance import InertKeyWarning

    with pytest.warns(InertKeyWarning, match=r"knee.side has no effect: knee.preset = "
                                             r"'baseline-right' is a right knee .*for a left "
                                             r"knee: knee.preset = 'custom'"):
        load_scene(overrides=["knee.side=left"])
