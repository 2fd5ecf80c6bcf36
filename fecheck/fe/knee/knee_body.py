"""A rigid body beyond the tibia whose cartilage joins the FE joint (the patella): what the
cross-check asks of it.

The cross-check (`fecheck.fe.knee.crosscheck`) and the balance (`fecheck.fe.knee.balance`)
know such a body only through these two protocols, so adding one takes its builder (a
module with a `KneeBody` and its `BodyAtEF`), one line in `fecheck.fe.knee.registry.BODIES`
and its test:

- `KneeBody` (the kind): whether a scene has the body, what the FE refuses with it, its
  model, its cartilage as an `FEBody` carried by its frame, the EF of the tibia and the
  body solved together, and the FE's unknowns (the tibia's free DOFs, then the body's
  coordinates) with their load as a `Drive`.
- `BodyAtEF` (the body at the EF equilibrium): its EF contact and pose, the FE's
  coordinates once solved, the balance of its own DOFs and what it adds to the tibia's,
  and what it adds to the JSON and the report.

Units: mm, N, MPa; poses (R, t) map the body's frame into the world (the femur's frame).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Protocol

import numpy as np

from fecheck.fe.bodies.pose import FramePose
from fecheck.fe.bodies.scene_bodies import FEBody
from fecheck.fe.bodies.settings import FESettings
from fecheck.fe.solve.press import Drive
from fecheck.model.results import CompartmentResult, RunResult
from fecheck.scene import Scene

Flexion = tuple[float, "np.ndarray | None"]
"""(θx rad, Q (3, 3) or None): the tibia's flexion held about Q's first column (None: x)."""


class BodyAtEF(Protocol):
    """A `KneeBody` at the EF equilibrium of a cross-check."""

    kind: KneeBody
    model: Any
    """The body's model (`KneeBody.model`)."""
    q_fe: np.ndarray | None
    """The FE's coordinates of the body (None before the FE solve)."""

    @property
    def contact(self) -> CompartmentResult:
        """The EF contact of the body's cartilage (its compartment)."""

    @property
    def ef_pose(self) -> FramePose:
        """The body's EF pose in the world, X_WB (B its frame, `KneeBody.frame`)."""

    @property
    def q(self) -> np.ndarray:
        """The body's EF coordinates (the FE's start)."""

    def fe_pose(self) -> FramePose:
        """The body's FE pose in the world at `q_fe`, X_WB."""

    def with_fe(self, q: np.ndarray) -> BodyAtEF:
        """A copy with the FE's coordinates `q`."""

    def balance(self, X_WT: FramePose, contact: np.ndarray) -> tuple[np.ndarray, float]:
        """At the FE poses (the tibia's X_WT, the body's at `q_fe`), with the FE
        `contact` wrench on the body (6,) (N, N·mm, about the world origin): the wrench the
        body's parts put on the tibia (6,) and the largest generalised force on the body's
        DOFs over its load."""

    def as_dict(self) -> dict[str, Any]:
        """The fields the body adds to the cross-check's JSON."""

    def lines(self) -> list[str]:
        """The lines the body adds to `fecheck fe`'s report."""


class KneeBody(Protocol):
    """A kind of rigid body whose cartilage joins the FE joint (module docstring)."""

    name: str
    """The body's name (its key in `fecheck.fe.knee.balance.body_balance`)."""
    frame: str
    """The body's frame name (`FEBody.carrier`, `FramePose.body`); "T" is the tibia's."""
    compartment: str
    """The name of its contact among the cross-check's compartments."""
    note: str
    """What the FE models of it, for the cross-check's notes."""
    unloaded_hint: str
    """What to change when its contact carries no load at the EF equilibrium."""

    def wanted(self, scene: Scene) -> bool:
        """Whether `scene` has the body."""

    def refuse(self, scene: Scene, settings: FESettings) -> None:
        """`FecheckError` (one line) for a scene or setting the FE does not model with it."""

    def model(self, scene: Scene) -> Any:
        """The body's model, built once per cross-check."""

    def fe_body(self, scene: Scene, model: Any) -> FEBody:
        """Its cartilage as an FE body, in its frame, carried by `frame`."""

    def ef(self, scene: Scene, flexion: Flexion | None, model: Any
           ) -> tuple[RunResult, BodyAtEF]:
        """The EF of the tibia and the body solved together (`flexion` None:
        dofs.flexion_deg about x)."""

    def drive(self, scene: Scene, q_ef: np.ndarray, springs: Sequence[Callable],
              flexion: Flexion, at_ef: BodyAtEF) -> Drive:
        """The tibia's free DOFs then the body's coordinates as the FE's unknowns, from the
        EF's tibia q_ef (5,) and `at_ef`; `Drive.full` gives the tibia's q (5,)."""
