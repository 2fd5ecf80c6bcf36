"""Detection benchmark (thesis Figs. 3.21 and 3.25): run time and accuracy per method.

Usage: python validation/bench_detection.py [--quick] [--json PATH] [--plot DIR]
(the same as ``fecheck bench detection``). See `fecheck.studies.bench_detection` for the
scenarios.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

from fecheck.studies import bench_detection as bench


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="up to 20,480 faces")
    parser.add_argument("--json", type=Path, help="write the rows and ratios here")
    parser.add_argument("--plot", type=Path, help="write the log-log PNG into this folder")
    args = parser.parse_args(argv)
    result = bench.run(quick=args.quick,
                       progress=lambda m: print(f"  {m}", file=sys.stderr, flush=True))
    print(bench.table(result))
    if args.json:
        bench.write_json(result, args.json)
    if args.plot:
        for path in bench.plot(result, args.plot):
            print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
