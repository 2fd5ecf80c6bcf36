"""`python -m fecheck` runs the CLI."""

import sys

from fecheck.cli import main

if __name__ == "__main__":
    sys.exit(main())
