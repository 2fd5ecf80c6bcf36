"""The contact-law registry (`fecheck.laws.registry`): one entry per law, every dispatch
site reads it, and a law added here — module, entry, test — runs a scene with nothing
else changed."""

from __future__ import annotations

import math
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from fecheck.errors import FecheckError
from fecheck.laws import registry
from fecheck.laws.fused import compiled_law
from fecheck.laws.kernel import KERNELS, POWER, law_function, law_values
from fecheck.laws.registry import REGISTRY, LawInputs, LawSpec, register, unregister
from fecheck.model.run import run_scene
from fecheck.scene import SCHEMA, load_scene
from fecheck.scene.law_keys import LAWS, LawKeys
from fecheck.scene.relevance import InertKeyWarning

ROOT = Path(__file__).resolve().parents[2]


# --- a law added in the test: p = c·d³ ------------------------------------------------

def _cubic_c(scene) -> float:
    """c = k0/h³ (MPa/mm³), k0 = (1−ν)E/((1+ν)(1−2ν)): the layer's stress grows as the
    cube of its strain d/h."""
    e, nu, h = scene["contact.youngs_MPa"], scene["contact.poisson"], scene["contact.thickness_mm"]
    return (1 - nu) * e / ((1 + nu) * (1 - 2 * nu)) / h ** 3


def _build_cubic(inputs: LawInputs):
    law = compiled_law(POWER, np.array([_cubic_c(inputs.scene), 3.0]))
    return lambda r, c: law


def cubic_force(c: float, radius: float, delta: float) -> float:
    """F = ∫ c·d³ dA of a sphere R at approach δ on a plane, d(ρ) = δ − R + √(R² − ρ²)
    over the projected disc: with s = d, ρ dρ = −(s + R − δ) ds,
    F = 2πc ∫₀^δ s³ (s + R − δ) ds = 2πc [δ⁵/5 + (R − δ) δ⁴/4] (N)."""
    return 2 * math.pi * c * (delta ** 5 / 5 + (radius - delta) * delta ** 4 / 4)


def _cubic_radius(scene, force_N: float, radius_mm: float) -> float:
    """Contact radius √(2Rδ) at the leading-order approach δ = (2F/(πcR))^(1/4) (mesh
    sizing: an overestimate)."""
    delta = (2 * force_N / (math.pi * _cubic_c(scene) * radius_mm)) ** 0.25
    return math.sqrt(2 * radius_mm * delta)


CUBIC = LawSpec(LawKeys("cubic", "cubic foundation", doc="= p = c·d³, c = k0/h³ (a test)"),
                _build_cubic, POWER, True, "F = 2πc[δ⁵/5 + (R − δ)δ⁴/4] (sphere on a plane)",
                "a law added by a test", contact_radius=_cubic_radius)


@pytest.fixture
def cubic():
    register(CUBIC)
    yield CUBIC
    unregister("cubic")


def test_a_law_added_in_a_test_solves_a_scene_and_matches_its_closed_form(cubic):
    # the sphere-plane baseline (condyle spheres over plateau discs refined under the
    # contact: the EF cap's depth within 0.2 % of its closed form there) with the new law;
    # the force at the solved depth is within 0.22 % of F(δ) here, and 0.6 % leaves room
    # for the mesh while a wrong exponent (d² or d⁴) moves F by more than 40 %
    scene = load_scene(None, ["contact.law='cubic'", "contact.thickness_mm=3.0"])
    result = run_scene(scene)
    assert result.converged and result.law == "cubic"
    c = _cubic_c(scene)
    for name, comp in result.compartments.items():
        expected = cubic_force(c, scene.knee.radius_mm(name), comp.max_depth_mm)
        assert comp.force_N == pytest.approx(expected, rel=0.006), name
        assert comp.max_pressure_MPa == pytest.approx(c * comp.max_depth_mm ** 3, rel=1e-9)


def test_a_registered_law_is_in_the_schema_and_leaves_with_unregister(cubic):
    assert "cubic" in SCHEMA["contact.law"].choices
    assert "'cubic' = p = c·d³" in SCHEMA["contact.law"].doc
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_scene(None, ["contact.law='cubic'", "contact.indenter_youngs_MPa=100"])
    msgs = [str(w.message) for w in caught if issubclass(w.category, InertKeyWarning)]
    assert any("contact.law = 'cubic' (only the Hertz law reads it)" in m for m in msgs), msgs
    unregister("cubic")
    with pytest.raises(FecheckError, match="contact.law"):
        load_scene(None, ["contact.law='cubic'"])
    register(CUBIC)                                      # for the fixture's teardown


def test_a_law_reading_a_key_of_another_is_named_in_the_inert_key_warning():
    spec = LawSpec(LawKeys("soft-hertz", "soft Hertz", ("contact.indenter_youngs_MPa",)),
                   _build_cubic, POWER, True, "-", "-", contact_radius=_cubic_radius)
    register(spec)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            load_scene(None, ["contact.indenter_youngs_MPa=100"])
        msgs = [str(w.message) for w in caught]
        assert any("only the Hertz and soft Hertz laws read it" in m for m in msgs), msgs
    finally:
        unregister("soft-hertz")


def test_registering_twice_or_an_inconsistent_entry_is_refused(cubic):
    with pytest.raises(FecheckError, match="already registered"):
        register(CUBIC)
    with pytest.raises(FecheckError, match="shipped law"):
        unregister("ef")
    bad = LawSpec(LawKeys("no-sizing", "x"), _build_cubic, POWER, True, "-", "-")
    with pytest.raises(FecheckError, match="stiffness or a contact_radius"):
        register(bad)
    point = LawSpec(LawKeys("pointless", "x", point_contact=True), _build_cubic, POWER, True,
                    "-", "-", contact_radius=_cubic_radius)
    with pytest.raises(FecheckError, match="point_contact"):
        register(point)
    assert "no-sizing" not in REGISTRY and "pointless" not in LAWS


# --- the compiled kernels ---------------------------------------------------------------

def test_the_power_kernel_is_c_d_to_the_m_with_its_slope():
    d = np.array([0.0, 0.3, 1.0, 2.5])
    p, slope = law_function(POWER, np.array([2.0, 3.0]))(d)
    np.testing.assert_allclose(p, 2.0 * d ** 3, rtol=1e-14, atol=0)
    np.testing.assert_allclose(slope, 6.0 * d ** 2, rtol=1e-14, atol=0)


def test_an_unknown_kernel_code_fails_loudly():
    unknown = max(KERNELS) + 1
    with pytest.raises(FecheckError, match="unknown compiled law kernel"):
        compiled_law(unknown, np.array([1.0]))
    with pytest.raises(FecheckError, match="unknown compiled law kernel"):
        law_function(unknown, np.array([1.0]))
    with pytest.raises(FecheckError, match="takes c, m"):
        compiled_law(POWER, np.array([1.0]))
    with pytest.raises(ValueError, match="unknown compiled law kernel"):   # inside numba too
        law_values(unknown, np.array([1.0]), np.array([0.5]))


# --- one place ------------------------------------------------------------------------

def test_the_registry_and_its_scene_half_name_the_same_laws():
    assert tuple(REGISTRY) == tuple(LAWS) == SCHEMA["contact.law"].choices
    for name, spec in REGISTRY.items():
        assert spec.scene is LAWS[name]
        spec.check()


def test_the_shipped_laws_keep_their_parameters():
    # the linear laws' stiffness is the closed form's k; Hertz has none and sizes by E*
    scene = load_scene()
    e, nu, h = 20.0, 0.3, 6.0
    assert registry.law_spec("ef").stiffness(scene) == pytest.approx(
        (1 - nu) * e / ((1 + nu) * (1 - 2 * nu) * h), rel=1e-15)
    assert registry.law_spec("volumetric").stiffness(scene) == 1e-2
    assert registry.law_spec("hertz").stiffness is None
    assert [n for n, s in REGISTRY.items() if not s.local] == ["hertz"]
    assert registry.laws_with(lambda s: s.per_face is not None) == ("ef", "ef-calibrated")
    with pytest.raises(FecheckError, match="not a registered law"):
        registry.law_spec("linear")


LAW_BRANCH = re.compile(r"""\[["']contact\.law["']\]\s*(==|!=|in\b|not\s+in\b)"""
                        r"""|\b(law|name)\s*(==|!=)\s*["'](ef|hertz|volumetric|blankevoort)""")


def test_no_module_outside_the_registry_branches_on_a_law_name():
    # the thesis's law figure compares each law's closed form by name, as the thesis did
    allowed = {ROOT / "fecheck/laws/registry.py", ROOT / "fecheck/scene/law_keys.py",
               ROOT / "fecheck/studies/thesis/row_laws.py"}
    hits = [f"{p.relative_to(ROOT)}:{i}: {line.strip()}"
            for p in sorted((ROOT / "fecheck").rglob("*.py")) if p not in allowed
            for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
            if LAW_BRANCH.search(line)]
    assert not hits, hits


def test_the_branch_pattern_sees_a_branch():
    assert LAW_BRANCH.search('    if scene["contact.law"] == "hertz":')
    assert LAW_BRANCH.search("    if law == 'volumetric':")
    assert not LAW_BRANCH.search('    spec = spec_of(scene)  # contact.law')
