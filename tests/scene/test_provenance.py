"""Provenance of result files and `fecheck run --from`: the version, the resolved scene,
the inputs' sha256 and the times are recorded; a recorded run replays to the same
numbers; a changed input stops the replay."""

from __future__ import annotations

import hashlib
import json
import shutil
from importlib.metadata import version
from pathlib import Path

import pytest

from fecheck.cli import main
from fecheck.scene import load_scene, packaged_scene_path
from fecheck.scene.packaged import data_dir
from fecheck.scene.provenance import changed_inputs, input_files, provenance

OVERRIDES = ["contact.poisson=0.35", "load.force_N=650"]


def _numbers(data: dict) -> dict:
    """A run JSON without what differs between two runs of one scene: times and the
    command that made it."""
    return {k: v for k, v in data.items() if k not in ("timing_s", "provenance")}


@pytest.fixture(scope="module")
def modified_run(tmp_path_factory) -> tuple[Path, dict]:
    out = tmp_path_factory.mktemp("from") / "r.json"
    args = ["run", "baseline", "--json", str(out)]
    for o in OVERRIDES:
        args += ["--set", o]
    assert main(args) == 0
    return out, json.loads(out.read_text())


def test_a_run_json_records_version_scene_inputs_and_times(modified_run):
    _, data = modified_run
    prov = data["provenance"]
    assert prov["fecheck_version"] == version("fecheck")
    assert prov["command"][:3] == ["fecheck", "run", "baseline"]
    scene = prov["scene"]
    assert scene["set_keys"] == ["contact.poisson", "load.force_N"]
    assert scene["overrides"] == OVERRIDES
    file_values = load_scene("baseline").values
    for key, value in scene["values"].items():
        expected = {"contact.poisson": 0.35, "load.force_N": 650}.get(key, file_values[key])
        if expected == float("inf"):                     # strict JSON: no Infinity token
            expected = "inf"
        assert value == (list(expected) if isinstance(expected, tuple) else expected), key
    assert set(scene["values"]) == set(file_values)
    toml = packaged_scene_path("baseline")
    assert prov["input_files"] == [{"role": "scene", "path": str(toml.resolve()),
                                    "sha256": hashlib.sha256(toml.read_bytes()).hexdigest()}]
    assert prov["wall_s"] >= data["timing_s"]["total"] > 0
    assert prov["cpu_s"] > 0


def test_a_modified_run_is_labelled_modified(modified_run):
    _, data = modified_run
    assert data["scene"] == ("baseline (modified: contact.poisson=0.35, load.force_N=650)")
    assert load_scene("baseline").label == "baseline"


def test_run_from_a_result_reproduces_every_number(modified_run, tmp_path):
    path, first = modified_run
    again = tmp_path / "again.json"
    assert main(["run", "--from", str(path), "--json", str(again)]) == 0
    second = json.loads(again.read_text())
    assert _numbers(second) == _numbers(first)
    assert second["provenance"]["scene"] == first["provenance"]["scene"]
    # the overrides matter: the unmodified baseline gives other numbers
    plain = tmp_path / "plain.json"
    assert main(["run", "baseline", "--json", str(plain)]) == 0
    assert _numbers(json.loads(plain.read_text()))["compartments"] != first["compartments"]


def test_run_from_refuses_a_scene_or_set_beside_it(modified_run, capsys):
    path, _ = modified_run
    assert main(["run", "baseline", "--from", str(path)]) == 2
    assert main(["run", "--from", str(path), "--set", "contact.poisson=0.3"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert all("--from" in line and "no SCENE and no --set" in line for line in err)


def test_run_from_a_json_without_provenance_is_one_line(tmp_path, capsys):
    old = tmp_path / "old.json"
    old.write_text(json.dumps({"scene": "baseline", "converged": True}))
    assert main(["run", "--from", str(old)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "no recorded scene" in err


def _own_knee(tmp_path: Path) -> Path:
    """A copy of the packaged scanned knee's files, for a scene that reads them there."""
    folder = tmp_path / "knee"
    shutil.copytree(data_dir("fecheck:knee/lenhart2015"), folder)
    return folder


def test_input_files_are_the_meshes_the_scene_reads(tmp_path):
    folder = _own_knee(tmp_path)
    scene = load_scene("scanned-knee", [f"geometry.dir={json.dumps(str(folder))}"])
    roles = {role: path for role, path in input_files(scene)}
    for key in ("femur", "tibia", "tibia_lateral"):
        assert roles[f"geometry.{key}"] == (folder / scene[f"geometry.{key}"]).resolve()
    assert roles["scene"] == packaged_scene_path("femur_tibia").resolve()
    menisci = load_scene("femur_tibia_menisci")
    files = [p for role, p in input_files(menisci) if role == "menisci.dir"]
    assert data_dir("fecheck:knee/smith2019_menisci") / "menisci.json" in files
    assert not any(p.name in ("README.md", "LICENSE") for p in files)
    knee = load_scene("femur_tibia_ligaments",
                      ["patella.dir='fecheck:knee/lenhart2015_patella'"])
    files = {p.name for role, p in input_files(knee) if role == "patella.dir"}
    assert files == {"lenhart2015_R_patella_cartilage.stl", "lenhart2015_R_patella_bone.stl",
                     "patellofemoral.json"}
    assert not [r for r, _ in input_files(load_scene("femur_tibia_ligaments"))
                if r == "patella.dir"]


def test_a_changed_input_stops_the_replay(tmp_path, capsys):
    folder = _own_knee(tmp_path)
    scene = load_scene("scanned-knee", [f"geometry.dir={json.dumps(str(folder))}"])
    result = {"provenance": provenance(scene)}
    assert changed_inputs(result, scene) == []
    femur = folder / scene["geometry.femur"]
    femur.write_bytes(femur.read_bytes() + b"\n")
    changed = changed_inputs(result, scene)
    assert len(changed) == 1 and str(femur.resolve()) in changed[0]
    path = tmp_path / "r.json"
    path.write_text(json.dumps(result))
    assert main(["run", "--from", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "changed (sha256" in err and femur.name in err


def test_mesh_info_json_carries_each_file_hash(tmp_path):
    stl = data_dir("fecheck:knee/lenhart2015") / "lenhart2015_R_tibia_cartilage_medial.stl"
    out = tmp_path / "info.json"
    assert main(["mesh", "info", str(stl), "--json", str(out)]) == 0
    rows = json.loads(out.read_text())
    assert rows[0]["sha256"] == hashlib.sha256(stl.read_bytes()).hexdigest()
    assert rows[0]["provenance"]["fecheck_version"] == version("fecheck")


AUDIT = """
import json, os, sys
opened = set()
def hook(event, args):
    if event == "open" and isinstance(args[0], (str, os.PathLike)):
        opened.add(os.path.realpath(args[0]))
sys.addaudithook(hook)
from fecheck.cli import main
code = main(sys.argv[1:])
print(json.dumps({"code": code, "opened": sorted(opened)}))
"""


@pytest.mark.parametrize("scene", ["femur_tibia_ligaments", "femur_tibia_menisci"])
def test_every_data_file_a_run_opens_is_recorded(scene, tmp_path):
    # an independent witness: Python's audit hook sees every file the run opens
    import os
    import subprocess
    import sys

    overrides = ["scanned.decimate_faces=1500"]
    args = ["run", scene, *[a for o in overrides for a in ("--set", o)]]
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[2]),
               OPENBLAS_NUM_THREADS="1")
    done = subprocess.run([sys.executable, "-c", AUDIT, *args], capture_output=True,
                          text=True, env=env, cwd=tmp_path, timeout=600)
    report = json.loads(done.stdout.strip().splitlines()[-1])
    assert report["code"] == 0, done.stderr[-2000:]
    package = Path(__file__).resolve().parents[2] / "fecheck"
    data = {p for p in report["opened"]
            if p.startswith((str(package / "data"), str(package / "scenes")))}
    recorded = {str(p) for _, p in input_files(load_scene(scene, overrides))}
    assert data and data <= recorded, sorted(data - recorded)


def test_an_infinite_value_is_recorded_as_strict_json_and_read_back():
    """A rigid indenter's modulus is +inf: the record is strict JSON (no Infinity token)
    and the recorded scene reads it back as +inf."""
    import math

    from fecheck.scene.provenance import recorded_scene

    scene = load_scene(None)
    assert math.isinf(scene["contact.indenter_youngs_MPa"])
    text = json.dumps({"provenance": provenance(scene)}, allow_nan=False)
    back = recorded_scene(json.loads(text), "result.json")
    assert back["contact.indenter_youngs_MPa"] == math.inf
    assert dict(back.values) == dict(scene.values)
