"""Contact detection: penetration of a slave surface into a master.

Detection returns a `ContactSurface` (see `fecheck.contact.surface`); contact laws
consume it. No law knows how detection was done; no detection knows the law.
`ContactPair` (in `fecheck.contact.pair`) is the query the statics solver calls.
Imports only `fecheck.errors`, `fecheck.scene` constants and `geometry`.
"""

from fecheck.contact.analytic import Plane, PolynomialSurface, Sphere
from fecheck.contact.pair import ContactPair
from fecheck.contact.surface import ContactSurface

__all__ = ["ContactPair", "ContactSurface", "Plane", "PolynomialSurface", "Sphere"]
