"""Contact detection: penetration of a slave surface into a master.

Detection returns a `ContactSurface` (see `fecheck.contact.surface`); contact laws
consume it. No law knows how detection was done; no detection knows the law.
`ContactPair` (in `fecheck.contact.pair`) is the query the statics solver calls.
"""

from fecheck.contact.analytic import Plane, PolynomialSurface, Sphere
from fecheck.contact.gjk import BoxShape, ConvexPoints, SphereShape, gjk_epa, max_penetration
from fecheck.contact.pair import ContactPair
from fecheck.contact.surface import ContactSurface

__all__ = ["BoxShape", "ContactPair", "ContactSurface", "ConvexPoints", "Plane",
           "PolynomialSurface", "Sphere", "SphereShape", "gjk_epa", "max_penetration"]
