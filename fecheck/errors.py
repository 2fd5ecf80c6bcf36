"""User-facing errors and warnings (see `geometry.errors`)."""

from geometry.errors import FecheckError

__all__ = ["FecheckError"]
