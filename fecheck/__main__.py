"""`python -m fecheck` runs the CLI."""

import sys

from fecheck.cli import main

sys.exit(main())
