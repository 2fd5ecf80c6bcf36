"""A population of the scanned knee: which inputs drive contact pressure and the split.

Runs ``fecheck population`` on the packaged scanned knee with its 55 ligament bundles
(``femur_tibia_ligaments``) over

* alignment, as the load point's x (the ankle centre moved ±15 mm medio-laterally: about
  ±2.3° of varus/valgus over the 381 mm shank),
* the bundles' stiffness (±20 %) and slack length (±2 %: a factor of 0.9 on every slack
  length quadrupled the contact force and 1.1 left the knee without an equilibrium, so
  the ±20 % of the literature's stiffness ranges is not used for the slack),
* the cartilage modulus and thickness (±20 % each),

each uniform, in Saltelli's design (scrambled Sobol base points), and reports the
statistics of the peak pressure, the medial share and each compartment's peak, their
first-order and total Sobol indices, and the time. The full study is 10,000 samples on
two local processes; --quick is 56 samples of the knee decimated to 1,500 tibial faces.

    python validation/population_study.py [--quick] [--out DIR] [--workers N]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.cli import main as fecheck

SCENE = "femur_tibia_ligaments"
VARY = ("load.point_mm[0]=uniform:-16.757:13.243",
        "scanned.ligament_stiffness_scale=uniform:0.8:1.2",
        "scanned.ligament_slack_scale=uniform:0.98:1.02",
        "contact.youngs_MPa=uniform:16:24",
        "scanned.thickness_scale=uniform:0.8:1.2")
SAMPLES, QUICK_SAMPLES = 10_000, 56
QUICK_SET = ("scanned.decimate_faces=1500",)


def arguments(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true",
                   help=f"{QUICK_SAMPLES} samples of the decimated knee (under a minute)")
    p.add_argument("--out", type=Path, default=Path("out/validation/population"),
                   help="output folder (CSV, JSON, plots)")
    p.add_argument("--workers", type=int, default=2, help="local processes (default 2)")
    return p.parse_args(argv)


def main(argv=None) -> int:
    args = arguments(argv)
    out = args.out
    samples = QUICK_SAMPLES if args.quick else SAMPLES
    cmd = ["population", SCENE, *(a for v in VARY for a in ("--vary", v)),
           "--samples", str(samples), "--workers", str(args.workers),
           "--csv", str(out / "population.csv"), "--json", str(out / "population.json"),
           "--plot", str(out)]
    if args.quick:
        cmd += [a for s in QUICK_SET for a in ("--set", s)]
    start = time.perf_counter()
    code = fecheck(cmd)
    wall = time.perf_counter() - start
    if code not in (0, 1):
        return code
    data = json.loads((out / "population.json").read_text())
    failed, stalled = data["failed"]["count"], data["not_converged"]["count"]
    print(f"{data['finished']} of {data['samples']} samples in {wall:.0f} s on "
          f"{args.workers} processes ({failed} failed, {stalled} did not converge)")
    (out / "population_time.json").write_text(json.dumps(
        {"samples": data["samples"], "workers": args.workers, "wall_s": wall,
         "failed": failed, "not_converged": stalled, "quick": args.quick}, indent=2) + "\n")
    return 0 if failed + stalled <= 0.01 * data["samples"] else 1


if __name__ == "__main__":
    sys.exit(main())
