"""CLI verbs, one module each (see `fecheck.cli`)."""
