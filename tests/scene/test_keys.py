"""`fecheck keys`, the generated baseline scene and key list, `--version`, and the warnings
for scene keys that have no effect (`fecheck.scene.relevance`)."""

from __future__ import annotations

import importlib.metadata
import warnings
from pathlib import Path

import pytest
import tomllib

from fecheck.cli import main
from fecheck.model.run import run_scene
from fecheck.scene import SCHEMA, apply_overrides, load_scene, packaged_scene_path
from fecheck.scene.document import baseline_document, baseline_values, keys_markdown
from fecheck.scene.relevance import InertKeyWarning, inert_keys

REPO = Path(__file__).resolve().parents[2]


def _flat(data: dict, prefix: str = "") -> set[str]:
    out = set()
    for k, v in data.items():
        key = prefix + k
        if isinstance(v, dict) and key not in SCHEMA:
            out |= _flat(v, key + ".")
        else:
            out.add(key)
    return out


def test_keys_lists_every_schema_key_with_unit_default_and_range(capsys):
    assert main(["keys"]) == 0
    out = capsys.readouterr().out
    listed = [line.split()[0] for line in out.splitlines() if line and line[0] != " "]
    assert listed == list(SCHEMA)
    assert ("contact.youngs_MPa  float, MPa; default 20.0; allowed value > 0"
            in out.splitlines())
    assert "ligaments.ACL.stiffness_N  float, N per unit strain; default 9840.0" in out
    assert main(["keys", "contact.indenter"]) == 0
    assert capsys.readouterr().out.count("\ncontact.") == 1       # two keys, one after a \n


def test_every_key_is_documented_in_words():
    short = [k for k, spec in SCHEMA.items() if len(spec.doc.split()) < 6]
    assert not short, f"keys with a terse doc: {short}"
    assert not [k for k, spec in SCHEMA.items() if "DESIGN" in spec.doc]


def test_packaged_baseline_is_the_generated_document_and_holds_every_key(capsys):
    text = packaged_scene_path().read_text(encoding="utf-8")
    assert text == baseline_document(), (
        "fecheck/scenes/baseline.toml is out of date: regenerate it with "
        "`fecheck keys --format toml > fecheck/scenes/baseline.toml` "
        "(validation/scenes/baseline.toml links to it)")
    assert main(["keys", "--format", "toml"]) == 0
    assert capsys.readouterr().out == text
    written = _flat(tomllib.loads(text))
    for key in set(SCHEMA) - written:                # unset by default: a commented example
        leaf = key.rsplit(".", 1)[-1]
        assert SCHEMA[key].default is None, key
        assert f"Example: {leaf} = " in text or f"# [{key}." in text, key
    scene = load_scene()
    assert dict(scene.values) == baseline_values()
    assert {k for k, v in scene.values.items() if v != SCHEMA[k].default} == {"name"}


def test_scene_keys_markdown_is_up_to_date(capsys):
    assert main(["keys", "--format", "markdown"]) == 0
    generated = capsys.readouterr().out
    assert generated == keys_markdown()
    assert (REPO / "docs" / "scene-keys.md").read_text(encoding="utf-8") == generated, (
        "docs/scene-keys.md is out of date: `fecheck keys --format markdown > "
        "docs/scene-keys.md`")
    assert all(f"`{key}`" in generated for key in SCHEMA)


def test_version_prints_the_package_version(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    assert capsys.readouterr().out == f"fecheck {importlib.metadata.version('fecheck')}\n"


def test_an_inert_key_given_by_set_warns_and_a_default_does_not(tmp_path):
    with pytest.warns(InertKeyWarning, match=r"^mesh.sphere_subdivisions has no effect: "
                      r"contact.master = 'condyle' with analytic detection"):
        load_scene(overrides=["mesh.sphere_subdivisions=5"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_scene()                                 # every key written, all defaults
        load_scene(REPO / "validation" / "scenes" / "baseline.toml")
        load_scene(overrides=["mesh.sphere_subdivisions=5", "contact.master=plateau"])
        inert_default = tmp_path / "default.toml"
        inert_default.write_text("[mesh]\nsphere_subdivisions = 4\n")
        load_scene(inert_default)                    # written at its default: documentation
    inert_default.write_text("[ligaments]\nACL.stiffness_N = 100.0\n")
    with pytest.warns(InertKeyWarning, match="ligaments.ACL.stiffness_N has no effect: "
                      "ligaments.model = 'none'"):
        load_scene(inert_default)


def test_the_cli_prints_an_inert_key_warning_on_one_line(capsys):
    assert main(["run", "--set", "model.kind=rigid", "--set", "solver.tolerance=1e-6"]) == 0
    err = [line for line in capsys.readouterr().err.splitlines() if line]
    assert err == ["fecheck: warning: solver.tolerance has no effect: model.kind = 'rigid' "
                   "has point contacts solved directly: no contact law, mesh or Newton "
                   "iteration"]


INERT = {
    "mesh.sphere_subdivisions=5": "condyle is an exact sphere",
    "mesh.method=trimesh": "condyle is an exact sphere",
    "scanned.condyle=hemisphere": "only sphere-tibia",
    "scanned.hemisphere_cut_mm=3": "only sphere-tibia",
    "scanned.thickness='bone-distance'": "reads no tibial surface file",
    "scanned.decimate_faces=500": "reads no tibial surface file",
    "geometry.dir='/nowhere'": "reads no file",
    "geometry.femur='femur.stl'": "reads no femoral surface",
    "geometry.femur_bone='bone.stl'": "reads no tibial surface file",
    "ligaments.ACL.stiffness_N=5": "ligaments.model = 'none'",
    "ligaments.MCL.reference_strain=0.1": "ligaments.model = 'none'",
    "ligaments.transition_strain=0.1": "ligaments.model = 'none'",
    "plateau.medial_angles_deg=[3, 4]": "only inclined plateaus",
    "plateau.lateral_coefficients=[[-6.0]]": "only polynomial plateaus",
    "contact.volumetric_stiffness_N_per_mm3=0.5": "only the volumetric law",
    "contact.indenter_youngs_MPa=100": "only the Hertz law",
    "contact.indenter_poisson=0.1": "only the Hertz law",
    "knee.side=left": "knee.preset = 'baseline-right'",
    "menisci.root_N_per_mm=10": "no menisci",
}
"""Keys with no effect on the packaged baseline scene → a word of the reason."""


def test_keys_declared_inert_leave_the_baseline_answer_unchanged():
    scene = apply_overrides(load_scene(), list(INERT))
    reasons = dict(inert_keys(scene, [o.split("=")[0] for o in INERT]))
    for override, word in INERT.items():
        assert word in reasons[override.split("=")[0]], override
    base, changed = run_scene(load_scene()), run_scene(scene)
    for c in ("medial", "lateral"):
        assert changed.compartments[c].force_N == base.compartments[c].force_N
        assert changed.compartments[c].area_mm2 == base.compartments[c].area_mm2


@pytest.mark.parametrize("overrides, key, inert", [
    (["contact.master=plateau"], "mesh.sphere_subdivisions", False),
    (["contact.detection=bvh"], "mesh.sphere_subdivisions", False),
    (["contact.master=plateau"], "mesh.plateau_radius_mm", True),
    (["contact.law=hertz", "contact.master=plateau"], "mesh.sphere_subdivisions", True),
    (["contact.law=hertz"], "contact.master", True),
    (["contact.law=hertz", "contact.area='whole-face'"], "contact.master", False),
    (["contact.law=hertz"], "contact.indenter_poisson", True),
    (["contact.law=hertz", "contact.indenter_youngs_MPa=100"], "contact.indenter_poisson",
     False),
    (["contact.law=volumetric"], "contact.volumetric_stiffness_N_per_mm3", False),
    (["ligaments.model=spring"], "ligaments.ACL.stiffness_N", False),
    (["ligaments.model=rod"], "ligaments.ACL.stiffness_N", True),
    (["plateau.kind=inclined"], "plateau.medial_angles_deg", False),
    (["plateau.kind=inclined"], "fe.axisym_size_mm", True),
    (["gravity=false"], "tibia.mass_kg", True),
    (["model.kind=rigid"], "contact.law", True),
    (["model.kind=rigid"], "contact.youngs_MPa", False),         # `fecheck fe` reads it
    (["model.kind=rigid"], "solver.start_gap_mm", True),
    (["model.kind='sphere-tibia'"], "scanned.condyle", False),
    (["model.kind='sphere-tibia'"], "mesh.sphere_subdivisions", True),
    (["model.kind='sphere-tibia'", "scanned.condyle=hemisphere"], "mesh.sphere_subdivisions",
     False),
    (["model.kind='femur-tibia'"], "mesh.plateau_size_mm", True),
    (["model.kind='femur-tibia'"], "contact.master", True),
    (["scanned.ligaments=bundles"], "geometry.dir", False),
    (["scanned.ligaments=bundles"], "geometry.ligaments", False),
    (["model.kind='femur-tibia'"], "geometry.split_x_mm", True),
    (["model.kind='femur-tibia'", "geometry.tibia_split=sagittal"], "geometry.split_x_mm",
     False),
    (["model.kind='femur-tibia'", "geometry.tibia_lateral='l.stl'"], "geometry.tibia_split",
     True),
    ([], "fe.size_mm", False),
    (["fe.prepare=off"], "fe.smooth_mm", True),
    ([], "dofs.x_mm", False),
    ([], "menisci.calibration", True),
    ([], "patella.quadriceps_N", True),
    (["model.kind='femur-tibia'", "menisci.dir='fecheck:knee/smith2019_menisci'"],
     "menisci.calibration", False),
])
def test_inert_key_rules(overrides, key, inert):
    scene = apply_overrides(load_scene(), overrides)
    assert bool(inert_keys(scene, [key])) is inert
