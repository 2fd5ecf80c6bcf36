"""Run time against error of every way to get contact pressure and area.

The same study as ``fecheck bench``: EF (clipped, whole-face, analytic master), the
thesis's fcl stack, Hertz and FE (3D, axisymmetric) on the baseline compartments, against
each model's converged reference; ratios to the thesis stack; time per contact
evaluation against faces. See `fecheck.studies.bench` for the methods and references.

    python validation/bench_pareto.py [--quick] [--json PATH] [--plot DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import sys

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

from fecheck.studies import bench


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer levels, sizes, repeats")
    parser.add_argument("--json", help="write the result as JSON")
    parser.add_argument("--plot", help="write the Pareto plots (PNG) into this folder")
    args = parser.parse_args(argv)
    config = bench.BenchConfig.quick() if args.quick else bench.BenchConfig()
    result = bench.run_bench(config, log=lambda m: print(m, file=sys.stderr, flush=True))
    print(bench.table(result))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(result, fh, indent=2)
    if args.plot:
        for path in bench.plot(result, args.plot):
            print(f"wrote {path}")
    return result


if __name__ == "__main__":
    main()
