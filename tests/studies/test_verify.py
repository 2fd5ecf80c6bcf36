"""The verification suite: its runner's orders and verdicts on synthetic data, Roache's GCI
against Celik et al. 2008's worked example, a handful of its cheapest cases, the CLI."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest

from fecheck.cli import main
from fecheck.studies import verify
from fecheck.studies.gci import gci, observed_order


@pytest.mark.parametrize("p", [2.0, 3.0])
def test_observed_order_of_synthetic_errors(p):
    h = [0.4, 0.2, 0.1]
    assert observed_order([3.0 * x ** p for x in h], h) == pytest.approx(p, rel=1e-12)
    assert math.isnan(observed_order([1.0, 0.0], [0.2, 0.1]))


def test_gci_reproduces_celik_2008_table_1():
    # Celik et al. 2008, J. Fluids Eng. 130:078001, Table 1, first column: phi 6.063,
    # 5.972, 5.863 at r21 1.5, r32 1.333 -> p 1.53, phi_ext 6.1685, GCI_fine 2.2 %
    r = gci([6.063, 5.972, 5.863], [1.5, 1.333])
    assert r.order == pytest.approx(1.53, abs=0.01)
    assert r.extrapolated == pytest.approx(6.1685, abs=5e-4)
    assert 100 * r.gci_fine == pytest.approx(2.2, abs=0.05)
    assert r.safety_factor == 1.25 and r.monotone


def test_gci_recovers_a_synthetic_limit_at_unequal_ratios():
    # f(h) = f0 + c h^p at h 0.1, 0.2, 0.3: r21 = 2, r32 = 1.5 (the q(p) term matters)
    f0, c, p = 4.2, 0.8, 1.7
    vals = [f0 + c * h ** p for h in (0.1, 0.2, 0.3)]
    r = gci(vals, [2.0, 1.5])
    assert r.order == pytest.approx(p, rel=1e-9)
    assert r.extrapolated == pytest.approx(f0, rel=1e-12)
    # GCI_fine = Fs·|(f1 − f2)/f1| / (r^p − 1) = 1.25·|f1 − f0|/f1 here
    assert r.gci_fine == pytest.approx(1.25 * abs(vals[0] - f0) / vals[0], rel=1e-9)


def test_gci_with_two_levels_assumes_the_order_and_uses_fs_3():
    vals = [5.0 + 0.1 ** 2, 5.0 + 0.2 ** 2]
    r = gci(vals, [2.0], formal_order=2.0)
    assert (r.order, r.safety_factor) == (2.0, 3.0)
    assert r.extrapolated == pytest.approx(5.0, rel=1e-12)


def _case(**kw) -> verify.Case:
    base = dict(name="synthetic", group="g", verifies="", reference="", quantity="q",
                levels=(0.4, 0.2, 0.1), quick_levels=(0.4, 0.2, 0.1),
                solve=lambda h: (1.0 + h * h, 1.0), expected=2.0, band=(1.8, 2.2),
                tolerance=0.02)
    base.update(kw)
    return verify.Case(**base)


def test_judge_passes_and_fails_on_order_and_tolerance():
    h = (0.4, 0.2, 0.1)
    second = [(1.0 + x * x, 1.0) for x in h]
    errors, error, order, status, _ = verify.judge(_case(), h, second)
    assert errors == pytest.approx([0.16, 0.04, 0.01]) and order == pytest.approx(2.0)
    assert (error, status) == (pytest.approx(0.01), "pass")
    first = [(1.0 + 0.1 * x, 1.0) for x in h]                  # right error, wrong order
    assert verify.judge(_case(), h, first)[3] == "FAIL"
    big = [(1.0 + 9 * x * x, 1.0) for x in h]                   # right order, error 0.09
    assert verify.judge(_case(), h, big)[3] == "FAIL"
    assert verify.judge(_case(known="stated"), h, first)[3] == "known"
    assert verify.judge(_case(known="stated"), h, second)[3] == "pass"


def test_judge_by_richardson_and_exactness():
    h = (0.4, 0.2, 0.1)
    own = [(3.0 + 0.5 * x ** 1.5, None) for x in h]
    _, error, order, status, _ = verify.judge(_case(order_from="values", band=(1.4, 1.6)),
                                              h, own)
    assert order == pytest.approx(1.5, rel=1e-9)
    assert error == pytest.approx(0.5 * 0.1 ** 1.5 / 3.0, rel=1e-9) and status == "pass"
    exact = _case(expected=None, tolerance=1e-10)
    assert verify.judge(exact, (1,), [(1e-12, 0.0)])[3] == "pass"
    assert verify.judge(exact, (1,), [(1e-9, 0.0)])[3] == "FAIL"


def test_suite_has_25_cases_each_with_an_expectation():
    cases = verify.cases()
    assert len(cases) >= 25 and len({c.name for c in cases}) == len(cases)
    for c in cases:
        assert c.reference and c.verifies and c.tolerance > 0
        if c.expected is not None:
            assert c.band[0] <= c.expected <= c.band[1]
            need = 3 if c.order_from == "values" else 2
            assert len(c.levels) >= need and len(c.quick_levels) >= need
            assert list(c.levels) == sorted(c.levels, reverse=True)


@pytest.mark.parametrize("name", ["patch-P2-nu0.49", "patch-P1-nu0.3",
                                  "patch-traction-P2-nu0.3", "hertz-two-bodies",
                                  "ef-invariance-tilt20-spin30", "load-scaling-nu0.3",
                                  "fe3d-invariance-tilt20-spin30"])
def test_exact_cases_are_round_off(name):
    (case,) = [c for c in verify.cases() if c.name == name]
    row = verify.run_case(case, quick=True)
    assert row.status == "pass" and row.error <= case.tolerance


def test_manufactured_solution_orders_are_p2():
    # P2 on a smooth solution: L2 order 3, energy order 2 (3 and 6 cells a side)
    rows = [verify.run_case(c, quick=True) for c in verify.select(["mms-3d-L2-nu0.3",
                                                                   "mms-3d-energy-nu0.3"])]
    assert [round(r.order, 1) for r in rows] == [pytest.approx(3.0, abs=0.15),
                                                 pytest.approx(1.9, abs=0.15)]
    assert all(r.status == "pass" for r in rows)


def test_cli_writes_the_report(tmp_path):
    out = tmp_path / "v"
    assert main(["verify", "--quick", "--only", "patch-P1", "ef-plate",
                 "--out", str(out), "--json", str(tmp_path / "v.json")]) == 0
    rows = list(csv.DictReader((out / "verify.csv").open()))
    assert [r["case"] for r in rows] == ["patch-P1-nu0.3", "ef-plate-force"]
    assert float(rows[1]["observed_order"]) == pytest.approx(2.0, abs=0.1)
    report = (out / "report.md").read_text()
    assert "| ef-plate-force |" in report and "verify.png" in report
    assert (out / "verify.png").stat().st_size > 1000


def test_cli_refuses_before_any_work(tmp_path, monkeypatch):
    def never(*args, **kwargs):
        raise AssertionError("a case ran")

    monkeypatch.setattr(verify, "run_suite", never)
    assert main(["verify", "--only", "no-such-case"]) == 2
    assert main(["verify", "--scene", "x.toml"]) == 2                 # needs --out
    scene = str(Path(verify.__file__).parents[1] / "scenes" / "baseline.toml")
    assert main(["verify", "--out", str(tmp_path), "--scene", scene,
                 "--scene-levels", "0", "2"]) == 2                  # ratio 4: refused
    (tmp_path / "f").write_text("")
    assert main(["verify", "--out", str(tmp_path / "f")]) == 2        # a file, not a folder


def test_scene_estimate_is_the_gci_of_the_fe_answers(monkeypatch):
    # synthetic FE answers p(h) = 4 + 0.3 h^1.5, A(h) = 100 − 8 h² at refine k (h = 2^-k):
    # three levels give order 1.5 and 4.0 extrapolated, GCI 1.25·|p1 − 4|/p1
    from types import SimpleNamespace

    import fecheck.fe.knee.crosscheck as crosscheck

    def fake(scene, refine, log):
        h = 0.5 ** refine
        fe = SimpleNamespace(max_pressure_MPa=4.0 + 0.3 * h ** 1.5, area_mm2=100 - 8 * h * h)
        return SimpleNamespace(compartments={"medial": SimpleNamespace(fe=fe)})

    monkeypatch.setattr(crosscheck, "cross_check", fake)
    text = verify.scene_estimate(None, [0, 1, 2], "s.toml")
    p_row = [ln for ln in text.splitlines() if "max_pressure_MPa" in ln][0].split("|")
    assert float(p_row[4]) == pytest.approx(1.5, abs=0.005)
    assert float(p_row[5]) == pytest.approx(4.0, abs=5e-4)
    p1 = 4.0 + 0.3 * 0.25 ** 1.5
    assert float(p_row[6].strip(" %")) == pytest.approx(100 * 1.25 * (p1 - 4) / p1, abs=0.006)
    a_row = [ln for ln in text.splitlines() if "area_mm2" in ln][0].split("|")
    assert float(a_row[4]) == pytest.approx(2.0, abs=0.005)
