"""`fecheck calibrate SCENE [-o FILE]`: fit the calibrated EF (contact.law =
'ef-calibrated') to the FE of the scene's own geometry at a few loads, write the
parameters to the file that contact.calibration reads, and print the fit quality.

Only the standard library is imported here; the solvers inside `run`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from fecheck.cli import add_scene_arguments


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "calibrate", help="fit the calibrated EF law to the scene's FE (writes a calibration "
                          "file for contact.calibration)",
        description="Solve the FE cross-check of the scene (its geometry, material, load and "
                    "fe.* settings) at a few loads, fit the law p = C·d·(d + 0.01 mm)^(n−1) "
                    "per compartment so that the EF equilibrium reproduces the FE's contact "
                    "area, peak pressure and load share, write C and n to FILE and print the "
                    "fit against the FE beside the linear EF's. Then run the scene with "
                    "contact.law = 'ef-calibrated' and contact.calibration = FILE.")
    add_scene_arguments(p, "override a scene key (repeatable)")
    p.add_argument("-o", "--out", type=Path, default=Path("calibration.json"), metavar="FILE",
                   help="calibration file to write (default: calibration.json)")
    p.add_argument("--loads", type=float, nargs="+", metavar="FACTOR",
                   help="loads to calibrate at, as multiples of load.force_N "
                        "(default: 0.6 1.0 1.4)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from fecheck.io.outputs import check_output
    from fecheck.scene import load_scene
    from fecheck.studies.calibrate import LOAD_FACTORS, calibrate, report, write

    check_output(args.out)                       # before the FE, not after
    scene = load_scene(args.scene, args.overrides)
    factors = args.loads or LOAD_FACTORS
    fit = calibrate(scene, factors, log=lambda s: print(f"fecheck {s}", file=sys.stderr,
                                                         flush=True))
    print(report(fit))
    path = write(fit, scene, args.out).resolve()
    print(f"wrote {path} (FE {fit.seconds['fe']:.1f} s, fit {fit.seconds['fit']:.1f} s); "
          f"run the scene with contact.law = 'ef-calibrated' and contact.calibration = "
          f"'{path}'")
    return 0
