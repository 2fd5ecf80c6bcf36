"""The meniscus EF calibration (`fecheck calibrate` on a scene with menisci): the fit
recovers a law that made its targets, on a flat knee whose statics are exact; the file it
writes is read by menisci.calibration and by nothing else; the meniscus interfaces of the
packaged knee take the file's law. No FE here: the targets are EF answers of a known law."""

from __future__ import annotations

import json

import numpy as np
import pytest
from contact_helpers import box

from fecheck.contact.pair import ContactPair
from fecheck.errors import FecheckError
from fecheck.laws import calibrated
from fecheck.laws.calibrated import Calibration
from fecheck.laws.fused import linear_law
from fecheck.model import menisci
from fecheck.scene import load_scene
from fecheck.statics.interfaces import Interface
from fecheck.statics.newton import Body, Problem, body_pose, point_force, solve
from fecheck.studies import menisci_calibrate as mc
from geometry.plateau import plane_patch

K_CART, K_MEN = 9.0, 1.1        # N/mm³: the cartilage's and the uncalibrated meniscus's
FEMUR, TIBIA, MEN = 0, 1, 2
LOADS_N = (300.0, 900.0)
KNOWN = Calibration(2.4, 0.7)   # the law that makes the targets


def _disc(x: float, y: float, z: float, normal_z: float):
    return plane_patch((x, y, z), (0.0, 0.0, normal_z), radius=4.0, size=1.0)


def flat_knee() -> menisci.MenisciKnee:
    """A flat one-compartment knee: the tibia (z free) under a femoral block on a cartilage
    disc (gap 0.1 mm), and a meniscus block (z free) between a femoral disc pressed 0.02 mm
    into its top and a tibial disc (tests/model/test_menisci.py's reduced knee)."""
    men = box((-30, -22, 0.0), (-10, -8, 2.0))
    interfaces = (
        Interface("medial", ContactPair(_disc(-20, 15, 0.0, 1.0),
                                        box((-30, 8, 0.1), (-10, 22, 5))),
                  linear_law(K_CART), TIBIA, FEMUR),
        Interface("medial femur-meniscus", ContactPair(_disc(-20, -15, 1.98, -1.0), men),
                  linear_law(K_MEN), FEMUR, MEN),
        Interface("medial meniscus-tibia", ContactPair(_disc(-20, -15, 0.0, 1.0), men),
                  linear_law(K_MEN), TIBIA, MEN))
    bodies = (Body("femur", np.zeros(6), ()),
              Body("tibia", np.array([0, 0, 0.25, 0, 0, 0.0]), (2,)),
              Body("medial meniscus", np.array([0, 0, 0.1, 0, 0, 0.0]), (2,)))
    return menisci.MenisciKnee(bodies, interfaces, {}, [], ("medial",), {})


class FlatRuns:
    """The flat knee's meniscal share and tibial area under the meniscus at `LOADS_N` for
    given meniscus laws, through `MenisciKnee.with_laws` as the calibration swaps them."""

    def __init__(self):
        self.knee = flat_knee()

    def __call__(self, parameters):
        knee = self.knee.with_laws({s: menisci.calibrated_meniscus_law(p)
                                    for s, p in parameters.items()})
        by_name = {i.name: i for i in knee.interfaces}
        out = []
        for load in LOADS_N:
            def wrench(poses, load=load):
                push = point_force(poses[TIBIA][1], np.array([0.0, 0.0, load]))
                return [i(poses) for i in knee.interfaces] + [((TIBIA,), *push)]

            sol = solve(Problem(knee.bodies, wrench, force_scale_N=load))
            assert sol.converged
            poses = [body_pose(q) for q in sol.q]
            men = by_name["medial meniscus-tibia"].wrench_on_slave(poses)[2]
            cart = by_name["medial"].wrench_on_slave(poses)[2]
            area = float(by_name["medial meniscus-tibia"].pair.slave.face_areas.sum())
            out.append({"medial": {"share": men / (men + cart), "meniscus_area_mm2": area}})
        return out


def test_fit_recovers_the_law_that_made_its_targets():
    # Targets: the flat knee's share at 300 and 900 N under C = 2.4 MPa/mm^0.7, n = 0.7.
    # From the uncalibrated start (C = 1.1, n = 1) the fit must come back to them. On flat
    # faces of uniform depth F = A·p(d) exactly, so the share at two loads pins C and n;
    # the tolerance is the solver's 1e-8 and least squares' xtol 1e-6 (measured error
    # below 1e-5).
    runs = FlatRuns()
    targets = runs({"medial": KNOWN})
    start = runs({"medial": Calibration(K_MEN, 1.0)})
    assert abs(start[0]["medial"]["share"] - targets[0]["medial"]["share"]) > 0.05
    got = mc.fit_law(runs, targets, ("medial",), {"medial": Calibration(K_MEN, 1.0)})
    assert got["medial"].C == pytest.approx(KNOWN.C, rel=1e-4)
    assert got["medial"].n == pytest.approx(KNOWN.n, abs=1e-4)


def test_residuals_weigh_the_share_and_the_log_area():
    # (EF share − FE share)·5 and log(EF area / FE area), per load and side
    ef = [{"medial": {"share": 0.40, "meniscus_area_mm2": 200.0}}]
    fe = [{"medial": {"share": 0.50, "meniscus_area_mm2": 100.0}}]
    np.testing.assert_allclose(mc.residuals(ef, fe, ("medial",)),
                               [5 * -0.10, np.log(2.0)], rtol=1e-12)


def _fit() -> mc.MenisciFit:
    answer = {"share": 0.5, "cartilage_area_mm2": 140.0, "meniscus_area_mm2": 250.0,
              "cartilage_p_max_MPa": 3.5, "meniscus_p_max_MPa": 3.0}
    fe = {"medial": answer, "lateral": dict(answer, share=0.55)}
    ef = {"medial": dict(answer, share=0.45), "lateral": dict(answer, share=0.40)}
    return mc.MenisciFit({"medial": KNOWN, "lateral": Calibration(3.0, 1.0)}, [800.0],
                         [fe], [ef], [ef], {"fe": 1.0, "fit": 1.0}, "abc")


def test_file_is_for_menisci_calibration_only(tmp_path):
    scene = load_scene("femur_tibia_menisci")
    path = mc.write(_fit(), scene, tmp_path / "men.json")
    data = json.loads(path.read_text())
    assert data["interfaces"] == "menisci"
    assert data["tables"][0]["fe"]["lateral"]["share"] == 0.55
    back = calibrated.read_calibration(path, calibrated.MENISCI_INTERFACES,
                                       "menisci.calibration")
    assert back["medial"] == KNOWN
    with pytest.raises(FecheckError, match="calibrates the menisci interfaces.*"
                                           "menisci.calibration"):
        calibrated.read_calibration(path)
    cartilage = calibrated.write_calibration(tmp_path / "cart.json", {"medial": KNOWN}, {})
    with pytest.raises(FecheckError, match="calibrates the cartilage interfaces"):
        calibrated.read_calibration(cartilage, calibrated.MENISCI_INTERFACES)


def test_report_sets_fe_and_ef_side_by_side():
    text = mc.report(_fit())
    rows = [line.split() for line in text.splitlines()]
    fe_lateral = next(r for r in rows if r[:2] == ["lateral", "FE"])
    assert float(fe_lateral[2]) == 55.0
    cal_medial = next(r for r in rows if r[:3] == ["medial", "EF", "calibrated"])
    assert float(cal_medial[3]) == 45.0
    assert _fit().worst_share_points() == pytest.approx((15.0, 800.0, "lateral"))


def test_scene_reads_the_meniscus_law_from_menisci_calibration(tmp_path):
    # The file's C and n become each meniscus's compiled calibrated law; unset, the linear
    # EF of the lumped layer (3.181818 N/mm³, tests/model/test_menisci.py by hand).
    scene = load_scene("femur_tibia_menisci")
    fit = mc.MenisciFit(_fit().parameters, [], [], [], [], {},
                        menisci.menisci_fingerprint(scene))
    path = mc.write(fit, scene, tmp_path / "men.json")
    laws = menisci.meniscus_laws(load_scene("femur_tibia_menisci",
                                            [f"menisci.calibration='{path}'"]),
                                 ("medial", "lateral"))
    np.testing.assert_allclose(laws["medial"].params, [2.4, 0.7, calibrated.SOFT_DEPTH_MM])
    np.testing.assert_allclose(laws["lateral"].params, [3.0, 1.0, calibrated.SOFT_DEPTH_MM])
    assert "C 2.4 MPa/mm^n, n 0.7 (menisci.calibration)" in menisci.law_text(laws["medial"])
    plain = menisci.meniscus_laws(scene, ("medial",))
    assert plain["medial"].params[0] == pytest.approx(3.181818, rel=1e-6)
    assert menisci.law_text(plain["medial"]) == "linear EF k = 3.182 N/mm³"


def test_calibrate_verb_takes_the_menisci_path_on_a_scene_with_menisci(tmp_path, monkeypatch,
                                                                       capsys):
    # The verb hands a scene with menisci.dir to the meniscus calibration (stubbed here: no
    # FE), prints its tables, warns on a share 15 points off and writes the menisci file.
    from fecheck.cli import main

    monkeypatch.setattr(mc, "calibrate_menisci", lambda scene, factors, log: _fit())
    assert main(["calibrate", "femur_tibia_menisci", "-o", str(tmp_path / "m.json")]) == 0
    out, err = capsys.readouterr()
    assert "EF calibrated" in out and "menisci.calibration" in out
    assert "lateral meniscal share misses the FE's by 15.0 points" in err
    assert json.loads((tmp_path / "m.json").read_text())["interfaces"] == "menisci"
