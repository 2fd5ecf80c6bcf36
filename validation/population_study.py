"""A population of the scanned knee: which inputs drive contact pressure and the split.

Runs ``fecheck population`` on the packaged scanned knee with its 55 ligament bundles
(``femur_tibia_ligaments``) over

* alignment, as the load point's x (the ankle centre moved ±15 mm medio-laterally: about
  ±2.3° of varus/valgus over the 381 mm shank),
* the bundles' stiffness and slack length (±20 % each, one factor on every bundle: a
  slack factor of 1.18 or more lets the tibia slide about 18 mm back, where the bundles
  catch it again; a sample whose equilibrium is found neither from the pose the
  baseline's linearised response predicts nor from the baseline pose is reached by a
  continuation from the scene's values),
* the cartilage modulus and thickness (±20 % each),

each uniform, in Saltelli's design (scrambled Sobol base points), and reports the
statistics of the peak pressure, the medial share and each compartment's peak, their
first-order and total Sobol indices, and the time. The full study is 10,000 samples on
two local processes; --quick is 56 samples of the knee decimated to 1,500 tibial faces;
--samples N another size.

    python validation/population_study.py [--quick] [--samples N] [--out DIR] [--workers N]
"""

from __future__ import annotations

import argparse
import csv
import json
import resource
import sys
import time
from pathlib import Path

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.cli import main as fecheck

SCENE = "femur_tibia_ligaments"
VARY = ("load.point_mm[0]=uniform:-16.757:13.243",
        "scanned.ligament_stiffness_scale=uniform:0.8:1.2",
        "scanned.ligament_slack_scale=uniform:0.8:1.2",
        "contact.youngs_MPa=uniform:16:24",
        "scanned.thickness_scale=uniform:0.8:1.2")
SAMPLES, QUICK_SAMPLES = 10_000, 56
QUICK_SET = ("scanned.decimate_faces=1500",)


def arguments(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true",
                   help=f"{QUICK_SAMPLES} samples of the decimated knee (under a minute)")
    p.add_argument("--samples", type=int, help=f"samples (default {SAMPLES:,})")
    p.add_argument("--out", type=Path, default=Path("out/validation/population"),
                   help="output folder (CSV, JSON, plots)")
    p.add_argument("--workers", type=int, default=2, help="local processes (default 2)")
    return p.parse_args(argv)


def continued_samples(path: Path) -> int:
    """How many samples of the study's CSV took continuation steps."""
    with path.open(newline="") as f:
        return sum(1 for row in csv.DictReader(f)
                   if float(row.get("continuation_steps") or 0.0) > 0)


def main(argv=None) -> int:
    args = arguments(argv)
    out = args.out
    samples = args.samples or (QUICK_SAMPLES if args.quick else SAMPLES)
    cmd = ["population", SCENE, *(a for v in VARY for a in ("--vary", v)),
           "--samples", str(samples), "--workers", str(args.workers),
           "--csv", str(out / "population.csv"), "--json", str(out / "population.json"),
           "--plot", str(out)]
    if args.quick:
        cmd += [a for s in QUICK_SET for a in ("--set", s)]
    start = time.perf_counter()
    code = fecheck(cmd)
    wall = time.perf_counter() - start
    cpu = sum(resource.getrusage(who).ru_utime + resource.getrusage(who).ru_stime
              for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))
    if code not in (0, 1):
        return code
    data = json.loads((out / "population.json").read_text())
    failed, stalled = data["failed"]["count"], data["not_converged"]["count"]
    continued = continued_samples(out / "population.csv")
    print(f"{data['finished']} of {data['samples']} samples in {wall:.0f} s on "
          f"{args.workers} processes, {cpu:.0f} s of CPU in all ({failed} failed, {stalled} "
          f"did not converge, {continued} reached by a continuation)")
    (out / "population_time.json").write_text(json.dumps(
        {"samples": data["samples"], "workers": args.workers, "wall_s": wall, "cpu_s": cpu,
         "failed": failed, "not_converged": stalled, "continued": continued,
         "quick": args.quick}, indent=2) + "\n")
    return 0 if failed + stalled <= 0.01 * data["samples"] else 1


if __name__ == "__main__":
    sys.exit(main())
