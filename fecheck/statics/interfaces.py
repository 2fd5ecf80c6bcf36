"""Contact interfaces between two bodies of a `fecheck.statics.newton.Problem`.

An interface is a contact pair (a slave surface on one body, a master on another, each in
its body's frame) with its law. At the bodies' poses it gives the `Part` of the wrench:
W on the slave and -W on the master (N, N·mm about the world origin) with the tangent
blocks for both bodies' twists (`fecheck.statics.newton.interface_part`), through the
compiled hot path (`fecheck.laws.fused.HotPath`). For a meniscus between femur and tibia:
one interface femur ↔ meniscus superior surface, one meniscus inferior surface
↔ tibia, each with its own law.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from fecheck.laws.fused import HotPath
from fecheck.statics.newton import BodyPose, Part, interface_part


class Interface:
    """Contact of `pair` (slave surface, master) under `law`, between the bodies `slave`
    and `master` (indices into `Problem.bodies`). `max_depth_mm` is the largest depth of
    the latest evaluation (0: not touching)."""

    def __init__(self, name: str, pair, law: Callable, slave: int, master: int) -> None:
        self.name, self.pair, self.law = name, pair, law
        self.slave, self.master = slave, master
        self._hot = HotPath(pair, law)
        self.max_depth_mm = 0.0

    def __call__(self, poses: Sequence[BodyPose]) -> Part:
        """The interface's `Part` at the poses of all bodies."""
        w = self._hot.evaluate(poses[self.slave], poses[self.master])
        self.max_depth_mm = float(w.max_depth)
        return interface_part(self.slave, self.master, w.wrench.copy(), w.tangent.copy())

    def wrench_on_slave(self, poses: Sequence[BodyPose]) -> np.ndarray:
        """The contact wrench (6,) on the slave body at the poses (N, N·mm)."""
        return self(poses)[1][:6]
