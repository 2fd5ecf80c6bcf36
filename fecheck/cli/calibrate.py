"""`fecheck calibrate SCENE [-o FILE]`: fit the calibrated EF (contact.law =
'ef-calibrated') to the FE of the scene's own geometry at a few loads, write the
parameters to the file that contact.calibration reads, and print the fit quality. On a
scene with menisci (menisci.dir) it fits the meniscus interfaces' law instead
(`fecheck.studies.menisci_calibrate`), for menisci.calibration.

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
                    "contact.law = 'ef-calibrated' and contact.calibration = FILE. On a "
                    "scene with menisci (menisci.dir) it fits the law of each meniscus's "
                    "EF interfaces to the FE with menisci instead (meniscal share and tibial "
                    "area under the meniscus), prints the FE and EF tables side by side, "
                    "and the scene reads FILE with menisci.calibration = FILE.")
    add_scene_arguments(p, "override a scene key (repeatable)")
    p.add_argument("-o", "--out", type=Path, default=Path("calibration.json"), metavar="FILE",
                   help="calibration file to write (default: calibration.json)")
    p.add_argument("--loads", type=float, nargs="+", metavar="FACTOR",
                   help="loads to calibrate at, as multiples of load.force_N "
                        "(default: 0.6 1.0 1.4; with menisci: 1.0)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from fecheck.io.outputs import check_output
    from fecheck.scene import load_scene
    from fecheck.studies.calibrate import LOAD_FACTORS, calibrate, report, write

    check_output(args.out)                       # before the FE, not after
    scene = load_scene(args.scene, args.overrides)
    if scene["menisci.dir"]:
        return run_menisci(args, scene)
    factors = args.loads or LOAD_FACTORS
    fit = calibrate(scene, factors, log=lambda s: print(f"fecheck {s}", file=sys.stderr,
                                                         flush=True))
    print(report(fit))
    path = write(fit, scene, args.out).resolve()
    print(f"wrote {path} (FE {fit.seconds['fe']:.1f} s, fit {fit.seconds['fit']:.1f} s); "
          f"run the scene with contact.law = 'ef-calibrated' and contact.calibration = "
          f"'{path}'")
    return 0


def run_menisci(args: argparse.Namespace, scene) -> int:
    """`fecheck calibrate` on a scene with menisci: fit the meniscus interfaces' law."""
    import warnings

    from fecheck.studies import menisci_calibrate as mc

    fit = mc.calibrate_menisci(scene, args.loads or mc.LOAD_FACTORS,
                               log=lambda s: print(f"fecheck {s}", file=sys.stderr, flush=True))
    for message in mc.fit_warnings(fit, scene.label):
        warnings.warn(message, stacklevel=1)
    print(mc.report(fit))
    path = mc.write(fit, scene, args.out).resolve()
    print(f"wrote {path} (FE {fit.seconds['fe']:.1f} s, fit {fit.seconds['fit']:.1f} s); "
          f"run the scene with menisci.calibration = '{path}'")
    return 0
