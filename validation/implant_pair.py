"""Write the synthetic total knee replacement (`geometry.synthetic.implant`) and its scene.

    python validation/implant_pair.py [--quick] [--out DIR] [--femur-y MM]

writes DIR/femur.stl, insert.stl (closed), insert_top.stl and implant.toml (then
``fecheck fe DIR/implant.toml``); --quick a coarser insert.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from geometry.synthetic.implant import FEMUR_Y_MM, write_implant


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a coarser insert (1.5 mm)")
    parser.add_argument("--out", type=Path, default=Path("out/implant"))
    parser.add_argument("--femur-y", type=float, default=FEMUR_Y_MM,
                        help="condyles this far anterior of the dwells, mm")
    args = parser.parse_args()
    scene = write_implant(args.out, args.femur_y, fine_mm=1.5 if args.quick else 1.0)
    print(f"wrote {scene} and its meshes; run: fecheck fe {scene}")


if __name__ == "__main__":
    main()
