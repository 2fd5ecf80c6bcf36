"""The baseline's EF error atlas: where the EF stays within 5 % of the FE.

Runs ``fecheck atlas`` on the packaged baseline (sphere-plane, the thesis's knee) over
the layer thickness, Poisson's ratio, the modulus, the load, the plateau slope and the
load point (uniform ranges below), with FE design points, then more FE runs at random
points the error model never saw, checked against its cross-validated error. The full
study is 40 FE design points, 10 held-out and 1,000 EF samples; --quick is 5 FE points
over two keys on a coarse FE mesh and 40 EF samples (the verb's whole path, in about a
minute).

The condyle radius is not among the keys: the baseline's spheres come from its knee
landmarks (a table), which has no real-valued key to draw.

    python validation/atlas_study.py [--quick] [--out DIR] [--workers N]
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

SCENE = "baseline"
FULL_SET = ("plateau.kind='inclined'",)
VARY = ("contact.thickness_mm=uniform:3:8",
        "contact.poisson=uniform:0.2:0.45",
        "contact.youngs_MPa=uniform:10:30",
        "load.force_N=uniform:400:1600",
        "plateau.medial_angles_deg[1]=uniform:-10:0",
        "load.point_mm[0]=uniform:3.9:11.9")
FE, HOLDOUT, SAMPLES = 40, 10, 1000
QUICK_VARY = VARY[:1] + VARY[2:3]
QUICK_SET = ("mesh.plateau_refine_mm=1.6", "mesh.plateau_size_mm=3.0", "fe.layers=2")
QUICK_FE, QUICK_SAMPLES = 5, 40


def arguments(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true",
                   help="5 FE points over two keys on a coarse FE mesh, 40 EF samples")
    p.add_argument("--out", type=Path, default=Path("out/validation/atlas"),
                   help="output folder (JSON, plots)")
    p.add_argument("--workers", type=int, default=1, help="local processes (default 1)")
    return p.parse_args(argv)


def main(argv=None) -> int:
    args = arguments(argv)
    out = args.out
    vary = QUICK_VARY if args.quick else VARY
    sets = QUICK_SET if args.quick else FULL_SET
    cmd = ["atlas", SCENE, *(a for v in vary for a in ("--vary", v)),
           *(a for s in sets for a in ("--set", s)),
           "--fe", str(QUICK_FE if args.quick else FE),
           "--samples", str(QUICK_SAMPLES if args.quick else SAMPLES),
           "--workers", str(args.workers), "--json", str(out / "atlas.json"),
           "--plot", str(out)]
    if not args.quick:
        cmd += ["--holdout", str(HOLDOUT)]
    start = time.perf_counter()
    code = fecheck(cmd)
    wall = time.perf_counter() - start
    if code != 0:
        return code
    data = json.loads((out / "atlas.json").read_text())
    print(f"atlas: {data['fe_points']['solved']} FE points, {data['ef_samples']} EF samples "
          f"in {wall:.0f} s; EF within {data['tolerance']:g} of the FE in p_max, area and "
          f"split together: {100 * data['within']['all']:.1f} % of the samples")
    return 0


if __name__ == "__main__":
    sys.exit(main())
