"""What ships inside the package: the scanned knee's files (byte copies of the data set,
listed with their sha256), the scenes by name, and ``geometry.dir = "fecheck:..."``."""

from __future__ import annotations

import fnmatch
import hashlib
import json
import shutil
import sys
from pathlib import Path

import pytest
import tomllib
from conftest import REPO, SHARED_DATA

from fecheck.cli import main
from fecheck.errors import FecheckError
from fecheck.scene import load_scene
from fecheck.scene.packaged import description, scene_names
from fecheck.scene.surfaces import FILE_KEYS, file_path

sys.path.insert(0, str(REPO / "scripts"))
import package_knee_data  # noqa: E402  (scripts/ is not a package)

PACKAGED = REPO / "fecheck" / "data" / "knee" / "lenhart2015"
SOURCE = SHARED_DATA / "knee" / "lenhart2015"
MENISCI = REPO / "fecheck" / "data" / "knee" / "smith2019_menisci"
MENISCI_SOURCE = SHARED_DATA / "knee" / "smith2019_menisci"
PATELLA = REPO / "fecheck" / "data" / "knee" / "lenhart2015_patella"
PATELLA_SOURCE = SHARED_DATA / "knee" / "lenhart2015_patella"
PATELLA_README_SHA256 = {
    "lenhart2015_R_patella_bone.stl":
        "1ec2a99318eac215260669f60113532ab86f77a555566806cb2450f27f05b4ed",
    "lenhart2015_R_patella_cartilage.stl":
        "30b96c654ff44b8599cfeecbd32069d408aa5eac7c5eb081c8006b1bf938e6c3",
    "patellofemoral.json": "b0b0bc2280242ed2dc156ad4ebdb9f3f57645746060e52a5d7ff92c5e08d10d3",
}
"""The sha256 the patella data set's README lists for its files (copied from its text)."""
SCANNED = ("femur_tibia", "femur_tibia_ligaments", "sphere_tibia", "sphere_tibia_ligaments",
           "inclined_ligaments", "polynomial_ligaments")
"""The packaged scenes that read the scanned knee's files."""


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_packaged_files_are_exactly_those_of_the_manifest_with_its_hashes():
    lines = (PACKAGED / "SHA256SUMS").read_text().splitlines()
    listed = dict(reversed(line.split("  ")) for line in lines)
    assert sorted(listed) == sorted(package_knee_data.FILES)
    assert {p.name for p in PACKAGED.iterdir()} == set(listed) | {"SHA256SUMS"}
    for name, digest in listed.items():
        assert _sha256(PACKAGED / name) == digest, name
    assert package_knee_data.problems(PACKAGED, None) == []


def test_packaged_meshes_are_the_data_sets_own_files():
    """Each mesh has the sha256 the data set's own fits.json records for it, and the licence
    and NOTICE the data set requires travel with them."""
    record = json.loads((PACKAGED / "fits.json").read_text())["meshes"]
    meshes = [n for n in package_knee_data.FILES if n.endswith(".stl")]
    assert len(meshes) == 5
    for name in meshes:
        assert _sha256(PACKAGED / name) == record[name]["sha256"], name
    assert "Apache License" in (PACKAGED / "LICENSE").read_text()
    assert "OpenSim" in (PACKAGED / "NOTICE-opensim-core").read_text()


def test_packaged_menisci_are_the_data_sets_own_files():
    """The menisci package holds exactly its manifest, each file with the sha256 the data
    set's own menisci.json records for it, with its licence."""
    listed = package_knee_data.read_manifest(MENISCI)
    assert sorted(listed) == sorted(package_knee_data.MENISCI_FILES)
    assert package_knee_data.packaged_files(MENISCI) == set(listed) | {"SHA256SUMS"}
    assert package_knee_data.problems(MENISCI, None, package_knee_data.MENISCI_FILES) == []
    record = json.loads((MENISCI / "menisci.json").read_text())
    recorded = {**record["meshes"], **record["other_files"]}
    for name in listed:
        if name in recorded:
            assert _sha256(MENISCI / name) == recorded[name]["sha256"], name
    assert sum(name in recorded for name in listed) == 21    # 2 + 4 + 12 meshes, 3 others
    assert "Apache License" in (MENISCI / "LICENSE").read_text()


@pytest.mark.skipif(not MENISCI_SOURCE.is_dir(), reason=f"no data set at {MENISCI_SOURCE}")
def test_the_menisci_source_still_has_the_packaged_hashes():
    assert package_knee_data.problems(MENISCI, MENISCI_SOURCE,
                                      package_knee_data.MENISCI_FILES) == []


def test_packaged_patella_is_the_data_sets_own_files():
    """The patella package holds exactly its manifest; its meshes and bundles have the
    sha256 its README lists, with the licence and NOTICE."""
    listed = package_knee_data.read_manifest(PATELLA)
    assert sorted(listed) == sorted(package_knee_data.PATELLA_FILES)
    assert package_knee_data.packaged_files(PATELLA) == set(listed) | {"SHA256SUMS"}
    assert package_knee_data.problems(PATELLA, None, package_knee_data.PATELLA_FILES) == []
    for name, digest in PATELLA_README_SHA256.items():
        assert _sha256(PATELLA / name) == digest, name
        assert digest in (PATELLA / "README.md").read_text()
    assert "Apache License" in (PATELLA / "LICENSE").read_text()
    assert "OpenSim" in (PATELLA / "NOTICE-opensim-core").read_text()


@pytest.mark.skipif(not PATELLA_SOURCE.is_dir(), reason=f"no data set at {PATELLA_SOURCE}")
def test_the_patella_source_still_has_the_packaged_hashes():
    assert package_knee_data.problems(PATELLA, PATELLA_SOURCE,
                                      package_knee_data.PATELLA_FILES) == []


def test_the_check_reports_a_changed_file(tmp_path):
    copy = tmp_path / "lenhart2015"
    shutil.copytree(PACKAGED, copy)
    assert package_knee_data.problems(copy, None) == []
    data = bytearray((copy / "ligaments.json").read_bytes())
    data[100] ^= 1
    (copy / "ligaments.json").write_bytes(bytes(data))
    (copy / "extra.stl").write_bytes(b"")
    found = package_knee_data.problems(copy, None)
    assert len(found) == 2
    assert "ligaments.json: packaged file sha256 differs" in found[1]
    assert "extra.stl: in " in found[0]


@pytest.mark.skipif(not SOURCE.is_dir(), reason=f"no data set source at {SOURCE}")
def test_the_source_still_has_the_hashes_the_package_was_built_from():
    assert package_knee_data.problems(PACKAGED, SOURCE) == []


@pytest.mark.parametrize("name", SCANNED)
def test_scanned_scenes_read_only_packaged_files(name):
    scene = load_scene(name)
    assert scene["geometry.dir"] == "fecheck:knee/lenhart2015"
    listed = set(package_knee_data.FILES)
    read = [file_path(scene, key) for key in FILE_KEYS if file_path(scene, key) is not None]
    assert read
    for path in read:
        assert path.parent == PACKAGED and path.name in listed and path.is_file(), path


def test_pyproject_packages_every_data_file_and_scene():
    """setuptools copies into the wheel the package data its globs name."""
    globs = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"][
        "package-data"]["fecheck"]
    shipped = [p.relative_to(REPO / "fecheck").as_posix()
               for p in [*PACKAGED.iterdir(), *(p for p in MENISCI.rglob("*") if p.is_file()),
                         *PATELLA.iterdir(),
                         *(REPO / "fecheck" / "scenes").glob("*.toml")]]
    missing = [f for f in shipped if not any(fnmatch.fnmatch(f, g) for g in globs)]
    assert not missing


def test_validation_scenes_are_links_to_the_packaged_scenes():
    """One copy of each scene: validation/scenes/X.toml links to fecheck/scenes/X.toml."""
    links = sorted((REPO / "validation" / "scenes").glob("*.toml"))
    assert [p.stem for p in links] == scene_names()
    for link in links:
        assert link.is_symlink()
        assert link.resolve() == REPO / "fecheck" / "scenes" / link.name


def test_unknown_packaged_data_set_is_refused_when_the_scene_loads():
    with pytest.raises(FecheckError, match=r"geometry.dir = 'fecheck:knee/nope' names no data "
                       r"set packaged with fecheck \(packaged: fecheck:knee/lenhart2015, "
                       r"fecheck:knee/smith2019_menisci, fecheck:knee/lenhart2015_patella\)"):
        load_scene("femur_tibia", ["geometry.dir='fecheck:knee/nope'"])


def test_set_geometry_dir_reads_the_same_file_names_elsewhere(tmp_path):
    scene = load_scene("femur_tibia", [f"geometry.dir='{tmp_path}'"])
    assert file_path(scene, "femur") == tmp_path / "lenhart2015_R_femur_cartilage.stl"


def test_scene_names_aliases_and_paths(tmp_path, monkeypatch):
    scenes = REPO / "fecheck" / "scenes"
    assert load_scene("femur_tibia").source == str(scenes / "femur_tibia.toml")
    assert load_scene("scanned-knee").source == str(scenes / "femur_tibia.toml")
    assert load_scene("additional-left").source == str(scenes / "additional_left.toml")
    monkeypatch.chdir(tmp_path)
    (tmp_path / "femur_tibia").write_text('name = "mine"\n')   # an existing file wins
    assert load_scene("femur_tibia")["name"] == "mine"
    with pytest.raises(FecheckError, match=r"^no scene file or packaged scene named 'knee'; "
                       r"packaged scenes: additional_left, baseline, .*, volumetric \(aliases: "
                       r"scanned-knee = femur_tibia\)"):
        load_scene("knee")
    with pytest.raises(FecheckError, match=r"^scene file not found: rigid.toml"):
        load_scene("rigid.toml")                          # a path, not a name


def test_run_a_packaged_scene_by_name(tmp_path, capsys):
    """The rigid scene gives thesis Table 5.1: medial 323.71 N, lateral 456.67 N."""
    out = tmp_path / "r.json"
    assert main(["run", "rigid", "--json", str(out)]) == 0
    forces = json.loads(out.read_text())["compartments"]
    assert forces["medial"]["force_N"] == pytest.approx(323.71, abs=0.01)
    assert forces["lateral"]["force_N"] == pytest.approx(456.67, abs=0.01)


def test_scenes_lists_every_packaged_scene_with_its_headline(capsys):
    assert main(["scenes"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in lines] == scene_names()
    assert "femur_tibia (scanned-knee)  Scanned femur on scanned tibia (thesis §5.2.3, " \
           "Table 5.11)" in lines
    assert any(line.startswith("rigid ") and line.endswith("  Rigid model (thesis §5.1, "
                                                           "Table 5.1)") for line in lines)
    assert main(["scenes", "--paths"]) == 0
    paths = [Path(p) for p in capsys.readouterr().out.splitlines()]
    assert paths == sorted((REPO / "fecheck" / "scenes").glob("*.toml"))


def test_description_is_the_headline_of_the_leading_comment(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text("# Short: a colon this early goes on (thesis §1: x): the rest. Next\n"
                     "# sentence.\nname = 's'\n")
    assert description(scene) == "Short: a colon this early goes on (thesis §1: x)"
    scene.write_text("# " + "word " * 40 + "\nname = 's'\n")
    assert description(scene) == ("word " * 20).strip() + " …"
    scene.write_text("name = 's'\n")
    assert description(scene) == ""
