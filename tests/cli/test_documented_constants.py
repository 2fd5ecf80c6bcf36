"""Constants the documentation (README and the pages of docs/), the scene-key help (`fecheck
keys`, docs/scene-keys.md) and the command help restate, pinned to the code: each number is
read from the text a user reads and compared with the constant, or with the behaviour it
sets."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import numpy as np
import pytest

from fecheck.cli import main
from fecheck.laws import ef_stiffness
from fecheck.laws.calibrated import SOFT_DEPTH_MM, Calibration, calibrated_pressure
from fecheck.scene import SCHEMA, load_scene, unit_hints
from fecheck.scene.constants import GRAVITY_MPS2
from fecheck.statics.ligaments import blankevoort_tension

REPO = Path(__file__).resolve().parents[2]
NUMBER = r"([0-9][0-9,]*(?:\.[0-9]+)?(?:e-?[0-9]+)?)"


def _flat(text: str) -> str:
    """The text with every run of white space (line breaks of wrapped help) one space."""
    return re.sub(r"\s+", " ", text)


def _numbers(pattern: str, text: str) -> list[float]:
    """Every number the `pattern` (with NUMBER groups) finds in `text`, as floats."""
    found = re.findall(pattern, _flat(text))
    assert found, f"{pattern!r} is no longer in the text: update this test with the text"
    rows = [m if isinstance(m, tuple) else (m,) for m in found]
    return [float(v.replace(",", "")) for row in rows for v in row]


def _readme() -> str:
    """The text a user reads: the README and every Markdown page of docs/."""
    pages = [REPO / "README.md", *sorted((REPO / "docs").rglob("*.md"))]
    return "\n".join(p.read_text(encoding="utf-8") for p in pages
                     if "_build" not in p.parts and "_generated" not in p.parts)


def _stated(pattern: str, text: str) -> tuple[float, ...]:
    """The numbers `pattern` finds in `text`, the same wherever the text states them."""
    found = re.findall(pattern, _flat(text))
    assert found, f"{pattern!r} is no longer in the text: update this test with the text"
    assert len(set(found)) == 1, f"{pattern!r} is stated with different numbers: {found}"
    row = found[0] if isinstance(found[0], tuple) else (found[0],)
    return tuple(float(v.replace(",", "")) for v in row)


def _keys_text(capsys, prefix: str) -> str:
    assert main(["keys", prefix]) == 0
    return capsys.readouterr().out


# ----------------------------------------------------------------- the calibrated EF
SOFT_LAW = r"p = C·d·\(d \+ " + NUMBER + r" mm\)\^\(n−1\)"


def _soft_depth_texts(capsys) -> dict[str, str]:
    with pytest.raises(SystemExit):
        main(["calibrate", "--help"])
    calibrate_help = capsys.readouterr().out
    return {"README.md and docs/": _readme(),
            "docs/scene-keys.md": (REPO / "docs" / "scene-keys.md").read_text("utf-8"),
            "fecheck keys": _keys_text(capsys, "contact.law"),
            "fecheck calibrate --help": calibrate_help,
            "fecheck/scenes/baseline.toml":
                (REPO / "fecheck" / "scenes" / "baseline.toml").read_text("utf-8"),
            "validation/scenes/baseline.toml":
                (REPO / "validation" / "scenes" / "baseline.toml").read_text("utf-8")}


def test_soft_depth_of_the_calibrated_law_is_the_documented_one(capsys):
    for where, text in _soft_depth_texts(capsys).items():
        assert set(_numbers(SOFT_LAW, text)) == {SOFT_DEPTH_MM}, where
    # and the law evaluates the documented formula with the documented d_s
    d_s = _numbers(SOFT_LAW, _readme())[0]
    d = np.array([0.0, 0.003, 0.01, 0.2, 1.5])
    p, _ = calibrated_pressure(Calibration(4.0, 0.55))(d)
    np.testing.assert_allclose(p, 4.0 * d * (d + d_s) ** (0.55 - 1), rtol=1e-13)


def test_the_calibration_table_script_has_no_copy_of_the_soft_depth():
    tree = ast.parse((REPO / "validation" / "ef_calibration_table.py").read_text("utf-8"))
    assigned = {t.id for node in ast.walk(tree) if isinstance(node, ast.Assign)
                for t in node.targets if isinstance(t, ast.Name)}
    assert "SOFT_DEPTH_MM" not in assigned
    imported = {(node.module, a.name) for node in ast.walk(tree)
                if isinstance(node, ast.ImportFrom) for a in node.names}
    assert ("fecheck.laws.calibrated", "SOFT_DEPTH_MM") in imported


def test_calibration_fit_warning_threshold_is_the_readme_s():
    from fecheck.studies.calibrate import FIT_TOLERANCE

    (percent,) = _stated(r"more than " + NUMBER + r" % off the FE", _readme())
    assert FIT_TOLERANCE == pytest.approx(percent / 100, rel=1e-12)


# ----------------------------------------------------------------- scene keys
def test_gravity_is_the_documented_one(capsys):
    (g,) = _numbers(r"tibia\.mass_kg × " + NUMBER + r" N", _keys_text(capsys, "gravity"))
    assert GRAVITY_MPS2 == g
    scene = load_scene(overrides=["tibia.mass_kg=3.5"])
    assert unit_hints.tibia_weight_N(scene) == pytest.approx(3.5 * g, rel=1e-12)


def test_blankevoort_transition_is_the_documented_strain(capsys):
    text = _keys_text(capsys, "ligaments.transition_strain")
    (eps_l,) = _numbers(r"\(ε_l = " + NUMBER + r"\)", text)
    default = SCHEMA["ligaments.transition_strain"].default
    assert default == pytest.approx(2 * eps_l, rel=1e-12)
    # the toe k·ε²/(4ε_l) meets the line k·(ε − ε_l) at 2ε_l with the line's slope k
    k = 1000.0
    f, df = blankevoort_tension(np.array([eps_l, 2 * eps_l, 3 * eps_l]), k, default)
    np.testing.assert_allclose(f, [k * eps_l / 4, k * eps_l, 2 * k * eps_l], rtol=1e-12)
    np.testing.assert_allclose(df, [k / 2, k, k], rtol=1e-12)


def test_layer_stiffness_is_the_formula_of_the_thickness_help(capsys):
    text = _keys_text(capsys, "contact.thickness_mm")
    assert "k = (1-ν)E / ((1+ν)(1-2ν)h)" in _flat(text)
    E, nu, h = (SCHEMA["contact.youngs_MPa"].default, SCHEMA["contact.poisson"].default,
                SCHEMA["contact.thickness_mm"].default)
    assert (E, nu, h) == (20.0, 0.3, 6.0)               # the thesis's cartilage
    # by hand: 0.7 · 20 / (1.3 · 0.4 · 6) = 14 / 3.12 N/mm³
    assert ef_stiffness(E, nu, h) == pytest.approx(14.0 / 3.12, rel=1e-12)


def test_poisson_limit_and_the_nearly_incompressible_level_count(capsys):
    from fecheck.fe.bodies.settings import NEARLY_INCOMPRESSIBLE

    key = SCHEMA["contact.poisson"]
    (limit,) = _numbers(r"below " + NUMBER, key.doc)
    assert (key.high, key.high_open) == (limit, True)
    (nu,) = _numbers(r"3 where contact\.poisson >= " + NUMBER, _keys_text(capsys, "fe.layers"))
    assert NEARLY_INCOMPRESSIBLE == nu


def test_the_importer_s_uniform_layer_is_the_scene_default():
    from fecheck.studies.knee_import import THICKNESS_MM

    assert THICKNESS_MM == SCHEMA["contact.thickness_mm"].default


# ----------------------------------------------------------------- the documented limits
def test_knee_load_range_is_the_readme_s():
    (low, high) = _stated(r"a load outside " + NUMBER + r" N-" + NUMBER + r" kN", _readme())
    assert unit_hints.KNEE_LOAD_N == (low, 1000 * high)
    for inside in (low, 1000 * high):
        assert unit_hints.load_warning(inside) == ""
    for outside in (0.99 * low, 1010 * high):
        assert unit_hints.load_warning(outside) != ""


def test_absurd_modulus_bounds_are_the_readme_s():
    (low, high) = _stated(r"a modulus under " + NUMBER + r" or from " + NUMBER + r" MPa",
                          _readme())
    assert unit_hints.ABSURD_E_MPA == (low, high)
    assert unit_hints.modulus_error(0.99 * low) and unit_hints.modulus_error(high)
    assert not unit_hints.modulus_error(low) and not unit_hints.modulus_error(0.99 * high)


def test_sweep_checkpoint_period_is_the_readme_s():
    from fecheck.cli.sweep import CHECKPOINT_S

    assert "rewritten about once a second" in _flat(_readme())
    assert CHECKPOINT_S == 1.0


def test_peer_benchmark_sphere_and_faces_are_the_readme_s():
    from fecheck.studies import bench_peers

    (radius, low, high, depth) = _stated(
        r"an icosphere of R " + NUMBER + r" mm, " + NUMBER + r" to " + NUMBER
        + r" faces, " + NUMBER + r" mm into a plane", _readme())
    assert (bench_peers.RADIUS_MM, bench_peers.DEPTH_MM) == (radius, depth)
    levels = bench_peers.LEVELS_FULL
    assert (20 * 4 ** levels[0], 20 * 4 ** levels[-1]) == (low, high)
