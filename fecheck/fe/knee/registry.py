"""The rigid bodies beyond the tibia whose cartilage the FE joint can carry
(`fecheck.fe.knee.knee_body`): a new body is one more entry in `BODIES`."""

from __future__ import annotations

from fecheck.errors import FecheckError
from fecheck.fe.knee.knee_body import KneeBody
from fecheck.fe.knee.patella_layer import PATELLA_KIND
from fecheck.scene import Scene

BODIES: tuple[KneeBody, ...] = (PATELLA_KIND,)
"""Every body the FE joint knows, in the order their coordinates follow the tibia's."""


def scene_body(scene: Scene) -> KneeBody | None:
    """The body `scene` has beyond the tibia (None: the tibia alone); `FecheckError` when it
    has more than one, which the FE joint does not solve together."""
    wanted = [body for body in BODIES if body.wanted(scene)]
    if len(wanted) > 1:
        raise FecheckError("the FE joint carries one body beyond the tibia, but this scene has "
                           f"{' and '.join(body.name for body in wanted)}: leave out all but one")
    return wanted[0] if wanted else None
