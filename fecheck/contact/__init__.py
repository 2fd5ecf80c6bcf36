"""Contact detection: penetration of a slave surface into a master.

Detection returns a `ContactSurface` (see `fecheck.contact.surface`); contact laws
consume it. No law knows how detection was done; no detection knows the law.
"""

from fecheck.contact.surface import ContactSurface

__all__ = ["ContactSurface"]
