"""The meniscus EF calibrated on the FE of the same knee, checked at a load it was not
fitted at.

`fecheck calibrate` on the packaged ``femur_tibia_menisci`` (`fecheck.studies.menisci_calibrate`:
per meniscus C and n of p = C·d·(d + 0.01 mm)^(n − 1) on its two EF interfaces, fitted to
the FE's meniscal share and tibial area under the meniscus) at the scene's 800 N, or the
calibration file given; then at each check load the FE with menisci, the uncalibrated EF
and the calibrated EF side by side (share, tibial area under cartilage and meniscus, p_max
of each), and the calibrated EF's share error in points (the aim: within 10 of the FE).

    python validation/menisci_calibration.py [--quick] [--out DIR] [--calibration FILE]
                                             [--check-loads N ...]

--quick: sheets decimated to 1500 faces (the scene's note for a quick look), check load
1200 N. Writes DIR/menisci_calibration.json (the calibration) unless --calibration is
given, and DIR/menisci_calibration.csv. Units: N, mm², MPa.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

from fecheck.laws.calibrated import MENISCI_INTERFACES, Calibration, read_calibration
from fecheck.model import menisci
from fecheck.model.results import write_rows
from fecheck.scene import load_scene, with_values
from fecheck.studies import menisci_calibrate as mc

SCENE = "femur_tibia_menisci"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="decimated sheets (1500 faces)")
    parser.add_argument("--out", type=Path, default=Path("."), help="output folder")
    parser.add_argument("--calibration", type=Path, help="an existing calibration file "
                        "(else fitted here at the scene's load)")
    parser.add_argument("--check-loads", type=float, nargs="+", default=[1200.0],
                        metavar="N", help="loads to check at (default 1200)")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    warnings.simplefilter("ignore")
    sets = ["scanned.decimate_faces=1500"] if args.quick else []
    scene = load_scene(SCENE, sets)
    t0 = time.perf_counter()

    def log(message: str) -> None:
        print(f"{time.perf_counter() - t0:7.1f} s {message}", file=sys.stderr, flush=True)

    if args.calibration is None:
        fit = mc.calibrate_menisci(scene, log=log)
        print(mc.report(fit))
        path = mc.write(fit, scene, args.out / "menisci_calibration.json")
        parameters = fit.parameters
        print(f"wrote {path}")
    else:
        parameters = read_calibration(args.calibration, MENISCI_INTERFACES,
                                      "menisci.calibration")
    start = dict.fromkeys(parameters, Calibration(menisci.meniscus_stiffness(scene), 1.0))
    rows = []
    for load in args.check_loads:
        fe = mc.fe_answers(scene, [load], log)[0]
        runs = mc.EFRuns(with_values(scene, menisci__calibration=""), [load])
        plain, cal = runs(start)[0], runs(parameters)[0]
        for line in mc.table(load, {"FE": fe, "EF uncalibrated": plain, "EF calibrated": cal}):
            print(line)
        for c in parameters:
            print(f"  {c}: calibrated EF share - FE share = "
                  f"{100 * (cal[c]['share'] - fe[c]['share']):+.1f} points")
            for name, answer in (("FE", fe), ("EF uncalibrated", plain), ("EF calibrated", cal)):
                rows.append({"load_N": load, "compartment": c, "model": name, **answer[c]})
    write_rows(args.out / "menisci_calibration.csv", rows)
    print(f"wrote {args.out / 'menisci_calibration.csv'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
