"""`fecheck fe [SCENE]`: FE cross-check of a scene's elastic-foundation answer.

Runs the scene's EF equilibrium, then per compartment a 3D quadratic-tetrahedron solve
of the cartilage layer pressed by the condyle sphere under the EF compartment force
(exact frictionless contact), beside the axisymmetric FE reference, EF, Hertz and
Donahue 2002. Only the standard library is imported here.
"""

from __future__ import annotations

import argparse
from pathlib import Path


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "fe", help="FE cross-check of the EF contact answer (scikit-fem)",
        description="Per compartment: 3D FE layer solve under the EF load, the axisymmetric "
                    "FE reference, EF and Hertz closed forms and Donahue 2002. Scene keys "
                    "[fe] set sizes, gap convention and solver.")
    p.add_argument("scene", nargs="?", type=Path,
                   help="scene TOML file (default: the packaged baseline scene)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scene key, e.g. --set fe.gap='deformed'")
    p.add_argument("--json", type=Path, metavar="PATH", help="write the comparison as JSON")
    p.add_argument("--plot", type=Path, metavar="DIR",
                   help="write FE/EF pressure maps and radial profiles (PNG) into DIR")
    p.add_argument("--size", type=float, metavar="MM",
                   help="3D element size under the contact, mm (overrides fe.size_mm)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    import json

    from fecheck.errors import FecheckError
    from fecheck.fe.crosscheck import cross_check
    from fecheck.scene import load_scene

    if args.size is not None and not (0 < args.size <= 10):
        raise FecheckError(f"--size must be in (0, 10] mm, got {args.size}")
    scene = load_scene(args.scene, args.overrides)
    check = cross_check(scene, size_mm=args.size)
    print(check.table())
    for name, chk in check.compartments.items():
        dev = chk.deviation()
        t = check.timing_s[name]
        line = f"{name}: 3D FE {t['fe_3d']:.2f} s = {t['fe_3d_over_ef_equilibrium']:.0f}x the EF " \
               f"equilibrium"
        if dev:
            line += (f"; 3D vs axisymmetric: p_max {100 * dev['max_pressure']:+.1f}%, "
                     f"area {100 * dev['area']:+.1f}% (the 3D discretization error)")
        print(line)
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(check.as_dict(), indent=2))
        print(f"wrote {args.json}")
    if args.plot:
        from fecheck.io.fe_plots import pressure_maps, radial_profile

        mat = check.material
        for name, chk in check.compartments.items():
            for fn, stem in ((pressure_maps, "pressure_map"), (radial_profile, "profile")):
                path = fn(chk, mat["E_MPa"], mat["nu"], mat["thickness_mm"],
                          args.plot / f"fe_{stem}_{name}.png")
                print(f"wrote {path}")
    return 0
