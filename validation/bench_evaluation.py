"""Runs `fecheck.studies.bench_evaluation` from a checkout (the code ships with the
package).

    python validation/bench_evaluation.py [--quick] [--compare TREE]
"""

from __future__ import annotations

import sys
from pathlib import Path

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.studies import bench_evaluation

if __name__ == "__main__":
    raise SystemExit(bench_evaluation.main())
