"""Runs `fecheck.studies.thesis.knee_fits` from a checkout (the code ships with the
package).

    python validation/knee_fits.py [--quick] [--out DIR]
"""

from __future__ import annotations

import sys
from pathlib import Path

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.studies.thesis import knee_fits

if __name__ == "__main__":
    raise SystemExit(knee_fits.main())
