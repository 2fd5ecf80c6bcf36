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
