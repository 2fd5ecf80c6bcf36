"""Runs `fecheck.studies.thesis.row_detection` from a checkout (the code ships with the
package; ``fecheck validate --only detection`` runs it too).

    python validation/row_detection.py [--quick] [--out DIR]
"""

from __future__ import annotations

import sys
from pathlib import Path

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.studies.thesis import row_detection
from fecheck.studies.thesis.report import main_for

if __name__ == "__main__":
    raise SystemExit(main_for(row_detection.rows))
