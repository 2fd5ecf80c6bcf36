"""The packaged Donahue knee (``donahue2002``): the scene makes each of Donahue et al. 2002's
modelling choices with the values the papers give, and ``fecheck fe`` prints them with their
sources and the published tibial contact beside its own (the FE itself is too slow here: a
stand-in result carries the FE's numbers)."""

from __future__ import annotations

import json
from types import SimpleNamespace

import pytest

from fecheck.cli import main
from fecheck.fe.knee import knee_menisci, knee_menisci_report
from fecheck.fe.knee.knee_menisci_report import choice_lines, choice_rows, published_lines
from fecheck.fe.material.anisotropy import MENISCUS
from fecheck.reference.published_fe import DONAHUE_2002_CHOICES
from fecheck.scene import load_scene

# The values as the sources state them, written here from the papers (not from the code):
# Donahue et al. 2002 (J Biomech Eng 124:273): 800 N at full extension, varus-valgus free,
# both cartilages deformable, cartilage E 15 MPa, nu 0.475 (attributed to it, no source found
# that states them); the meniscus E_theta 140 MPa, E_r = E_z 20 MPa, nu 0.3 / 0.2 and
# 2000 N/mm a horn (Haut Donahue et al. 2003, as cited).
CITED = {"load.force_N": 800.0, "dofs.flexion_deg": 0.0, "fe.cartilage": "two-layer",
         "contact.youngs_MPa": 15.0, "contact.poisson": 0.475, "menisci.roots": "springs",
         "menisci.root_N_per_mm": 2000.0}
# Donahue 2002, 1 mm elements (lateral / medial): area 415 / 490 mm², p_max 2.36 / 2.55 MPa;
# the subject FE at 1150 N (Devaraj et al. 2020, Open Biomed Eng J 14:74), medial / lateral:
# area 701 ± 89 / 617 ± 63 mm², largest compressive stress 2.98 ± 0.51 / 2.57 ± 0.53 MPa.
PUBLISHED = ("415.0", "2.360", "490.0", "2.550", "701 ± 89", "2.98 ± 0.51", "617 ± 63",
             "2.57 ± 0.53", "1150")


@pytest.fixture(scope="module")
def scene():
    return load_scene("donahue2002")


def test_scene_holds_the_cited_values(scene):
    for key, value in CITED.items():
        assert scene[key] == value, key
    assert sorted(scene["dofs.free"]) == ["abduction", "z"]
    assert scene["contact.femoral_youngs_MPa"] is None       # the femoral layer takes 15 / 0.475
    assert scene["contact.femoral_poisson"] is None
    assert sorted(scene["menisci.sides"]) == ["lateral", "medial"]


def test_the_fe_meniscus_is_the_cited_material():
    assert (MENISCUS.E_t, MENISCUS.E_p, MENISCUS.nu_tp, MENISCUS.nu_p) == (140.0, 20.0, 0.3, 0.2)


def test_every_choice_is_the_scenes_and_has_a_source(scene):
    rows = choice_rows(scene)
    assert len(rows) == len(DONAHUE_2002_CHOICES)
    assert all(r["same"] for r in rows), [r for r in rows if not r["same"]]
    assert all("Donahue" in r["source"] for r in rows)
    assert {ch.key: ch.value for ch in DONAHUE_2002_CHOICES if ch.key in CITED} == CITED


def test_a_scene_with_other_choices_is_reported_as_differing():
    other = load_scene("donahue2002", ["contact.youngs_MPa=20", "menisci.roots=bundles"])
    lines = "\n".join(choice_lines(other))
    assert "contact.youngs_MPa = 20, differs from Donahue's 15" in lines
    assert "menisci.roots = bundles, differs from Donahue's springs" in lines
    assert "8 of 10 the same" in lines


def _stand_in(load_N: float = 784.0):
    """A result with what the printed blocks read: per compartment area and p_max."""
    fe = {c: SimpleNamespace(area_mm2=a, p_max_MPa=p)
          for c, a, p in (("medial", 300.0, 3.5), ("lateral", 280.0, 5.9))}
    return SimpleNamespace(fe=fe, load_N=load_N)


def test_published_lines_carry_the_published_numbers():
    text = "\n".join(published_lines(_stand_in()))
    for number in PUBLISHED:
        assert number in text, number


def _no_nan(text):
    raise AssertionError(f"{text} in the JSON")


def test_fecheck_fe_prints_the_choices_and_the_published_numbers(monkeypatch, capsys,
                                                                 tmp_path):
    # The FE starts from the EF of the scene's own cartilage (no other EF handed to it).
    starts = []
    monkeypatch.setattr(knee_menisci, "knee_menisci_fe", lambda scene, ef=None, **k: starts.append(
        (ef, scene["contact.youngs_MPa"], scene["contact.poisson"])) or _stand_in())
    monkeypatch.setattr(knee_menisci_report, "report_lines", lambda result, wall: [])
    monkeypatch.setattr(knee_menisci_report, "as_dict", lambda result, name: {})
    path = tmp_path / "fe.json"
    assert main(["fe", "donahue2002", "--json", str(path)]) == 0
    out = capsys.readouterr().out
    assert "modelling choices beside Donahue 2002's (10 of 10 the same" in out
    assert "Haut Donahue et al. 2003, J Biomech 36:19" in out
    for number in PUBLISHED:
        assert number in out, number
    assert starts == [(None, 15.0, 0.475)]
    data = json.loads(path.read_text(encoding="utf-8"), parse_constant=_no_nan)
    donahue = {r["compartment"]: (r["area_mm2"], r["p_max_MPa"]) for r in data["published"]
               if r["model"] == "Donahue 2002"}
    assert donahue == {"medial": (490.0, 2.55), "lateral": (415.0, 2.36)}
    assert all(r["same"] for r in data["choices"])
