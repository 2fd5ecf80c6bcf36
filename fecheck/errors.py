"""User-facing errors and warnings (see `geometry.errors`)."""

from geometry.errors import FecheckError, ImplausibleInput

__all__ = ["FecheckError", "ImplausibleInput"]
