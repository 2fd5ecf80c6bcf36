"""The error estimate of `fecheck fe` (`fecheck.studies.estimate`): the GCI band against hand
values, the band of the baseline's FE against the axisymmetric FE (the reference of a flat
layer, converged to 0.3 % at fe.axisym_size_mm), the three-level plumbing on synthetic
levels of known order, and the CLI's JSON keys and solve counts.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from conftest import require_knee_data

import fecheck.fe.knee.crosscheck
from fecheck.cli import main
from fecheck.errors import FecheckError
from fecheck.fe.bodies.scene_bodies import scene_bodies
from fecheck.fe.knee.crosscheck import cross_check
from fecheck.scene import load_scene
from fecheck.studies import estimate as est_mod
from fecheck.studies.estimate import QUANTITIES, Level, band, estimate


@pytest.fixture(scope="module")
def baseline():
    scene = load_scene()
    check = cross_check(scene, mode="compartment", log=None)
    return scene, check, estimate(scene, check, check.ef_run)


def test_two_level_band_by_hand():
    # r = 2, order 2, Fs 3: extrapolated (4·10 − 9.4)/3 = 10.2, half-width 3·0.6/3 = 0.6
    b = band([10.0, 9.4], [2.0])
    assert b.extrapolated == pytest.approx(10.2)
    assert b.half_width == pytest.approx(0.6)
    assert (b.low, b.high) == pytest.approx((9.4, 10.6))
    assert (b.order, b.safety_factor) == (2.0, 3.0)
    # a quantity near zero (a centre of pressure) keeps an absolute band
    assert band([0.0, 0.3], [2.0]).half_width == pytest.approx(0.3)


def test_three_level_band_is_celik_2008_table_1():
    # Celik et al. 2008 Table 1: p 1.53, extrapolated 6.1685, GCI_fine 2.2 % of 6.063
    b = band([6.063, 5.972, 5.863], [1.5, 1.333])
    assert b.order == pytest.approx(1.53, abs=0.01)
    assert b.extrapolated == pytest.approx(6.1685, abs=1e-3)
    assert b.half_width / 6.063 == pytest.approx(0.022, abs=5e-4)
    assert b.safety_factor == 1.25


def test_the_baseline_band_contains_the_axisymmetric_fe(baseline):
    # acceptance (issue 30): the band of the FE p_max and area contains the axisymmetric
    # FE at the same force. Measured (default / coarse / band / axisym): medial p_max
    # 4.393 / 4.334 / 4.329-4.457 / 4.396, area 114.05 / 113.56 / 113.52-114.57 / 113.96;
    # lateral p_max 4.557 / 4.493 / 4.488-4.625 / 4.557, area 157.19 / 154.06 /
    # 153.82-160.57 / 158.98 (the lateral area is 1.8 mm² short: a band with Fs 1, or the
    # ratio taken as the dofs ratio, 7.4, misses it)
    _, check, est = baseline
    for c, chk in check.compartments.items():
        ref = chk.axisym.metrics
        assert est.bands[c]["p_max_vertex_MPa"].contains(ref.max_pressure_MPa), c
        assert est.bands[c]["area_mm2"].contains(ref.area_mm2), c


def test_the_estimate_costs_a_fraction_of_the_default_run(baseline):
    # the coarse level has about 1/8 of the dofs (r ≈ 2 in three dimensions)
    _, check, est = baseline
    assert len(est.levels) == 2 and est.ratios[0] == pytest.approx(2.0, abs=0.1)
    coarse = est.levels[1]
    assert coarse.dofs < check.geometry["dofs"] / 6
    assert coarse.levels == 1


def test_verify_observes_the_order_of_synthetic_levels(baseline, monkeypatch):
    # levels f(h) = A + B·h² with h ∝ dofs^(-1/3): the observed order is 2 and the
    # extrapolated value A, whatever the level values
    scene, check, _ = baseline
    default = est_mod.default_level(check)
    h0 = default.dofs ** (-1 / 3)

    def synthetic(scene_, check_, run, label, settings, bodies, log):
        dofs = round(default.dofs * (8 if label == "fine" else 1 / 8))
        h = dofs ** (-1 / 3)
        values = {c: {q: v + 0.5 * (h ** 2 - h0 ** 2) / h0 ** 2 for q, v in vals.items()}
                  for c, vals in default.values.items()}
        return dataclasses.replace(default, label=label, values=values, dofs=dofs)

    monkeypatch.setattr(est_mod, "solve_level", synthetic)
    res = estimate(scene, check, check.ef_run, verify=True)
    assert [lv.label for lv in res.levels] == ["fine", "default", "coarse"]
    b = res.bands["medial"]["area_mm2"]
    assert b.order == pytest.approx(2.0, abs=1e-6)
    assert b.safety_factor == 1.25
    assert b.extrapolated == pytest.approx(default.values["medial"]["area_mm2"] - 0.5, abs=1e-6)


@pytest.mark.parametrize("flags, solves", [([], 1), (["--no-estimate"], 0)])
def test_fe_json_carries_the_bands_and_no_estimate_skips_the_solve(baseline, monkeypatch,
                                                                   tmp_path, capsys, flags,
                                                                   solves):
    _, check, _ = baseline
    monkeypatch.setattr(fecheck.fe.knee.crosscheck, "cross_check", lambda *a, **k: check)
    calls = []
    real = est_mod.solve_level

    def counted(*args, **kwargs) -> Level:
        calls.append(args[3])
        return real(*args, **kwargs)

    monkeypatch.setattr(est_mod, "solve_level", counted)
    out = tmp_path / "fe.json"
    assert main(["fe", "--mode", "compartment", "--json", str(out)] + flags) == 0
    data = json.loads(out.read_text())
    assert len(calls) == solves
    text = capsys.readouterr().out
    if not solves:
        assert data["error_estimate"] is None and "skipped (--no-estimate)" in text
        return
    assert "error estimate" in text and "order 2 assumed, safety factor 3" in text
    est = data["error_estimate"]
    assert est["cost_over_default"] < 1
    for c in ("medial", "lateral"):
        assert set(est["compartments"][c]) == {q for q, _, _ in QUANTITIES}
        p = est["compartments"][c]["p_max_vertex_MPa"]
        lo, hi = p["band"]
        assert lo <= data["compartments"][c]["axisym"]["max_pressure_MPa"] <= hi


def test_a_failed_coarse_level_warns_and_keeps_the_answer(baseline, monkeypatch, tmp_path,
                                                          capsys):
    _, check, _ = baseline
    monkeypatch.setattr(fecheck.fe.knee.crosscheck, "cross_check", lambda *a, **k: check)

    def fails(*args, **kwargs):
        raise FecheckError("the coarse sheet does not extrude")

    monkeypatch.setattr(est_mod, "solve_level", fails)
    out = tmp_path / "fe.json"
    assert main(["fe", "--mode", "compartment", "--json", str(out)]) == 0
    assert "no error estimate: its coarse level failed" in capsys.readouterr().err
    assert json.loads(out.read_text())["error_estimate"] is None
    assert main(["fe", "--mode", "compartment", "--verify"]) == 2


def test_the_coarse_scanned_sheet_has_edges_twice_as_long():
    # a quarter of the faces of a sheet is edges about twice as long (same area); the
    # thickness map is carried over from the nearest default vertex
    require_knee_data()
    scene = load_scene("femur_tibia", ["scanned.decimate_faces=2000"])
    for body in scene_bodies(scene):
        coarse = est_mod.coarse_body(scene, body)
        assert coarse.surface.n_faces == pytest.approx(body.surface.n_faces / 4, abs=2)
        ratio = _mean_edge(coarse.surface) / _mean_edge(body.surface)
        assert 1.8 < ratio < 2.2, body.name
        assert coarse.surface.area == pytest.approx(body.surface.area, rel=0.01)
        assert body.thickness_mm.min() <= coarse.thickness_mm.min()
        assert coarse.thickness_mm.max() <= body.thickness_mm.max()
        assert coarse.indenter is body.indenter


def _mean_edge(mesh) -> float:
    e = mesh.points[mesh.faces[:, [1, 2, 0]]] - mesh.points[mesh.faces]
    return float(np.linalg.norm(e, axis=2).mean())
