"""The patella in the FE cross-check: its cartilage a layer bonded to a second rigid body,
pressed by the femoral cartilage surface, with the patella's six DOFs solved with the
tibia's.

- Layer (`patella_body`): the patellar cartilage sheet the EF presses (patella frame,
  normals toward the femur), extruded toward the bone by the EF's thickness: with
  ``scanned.thickness = "bone-distance"`` the patellar and femoral cartilage in series
  (`fecheck.model.patella.series_thickness`, averaged onto the vertices), else
  ``contact.thickness_mm``. It is built by `fecheck.fe.solve.press.build_layers` as a tibial
  sheet is, and carried by the body ``"P"`` (`fecheck.fe.bodies.scene_bodies.FEBody.carrier`).
- Indenter: the femoral articular surface the EF patella presses (rigid, world frame),
  its contact faded within the EF's `fecheck.model.patella.RIM_MM` of the sheet's open
  rim as the EF's (the EF pair's rim table and width, `MeshIndenter`'s rim): a
  penetration there counts as the EF's faded depth.
- Unknowns (`knee_drive`): the tibia's free DOFs (scene order) then the patella's six
  body coordinates (`fecheck.statics.newton.Body`, the data's pose at 0). The load on them
  is the EF's: the scene's load, gravity and tibial bundles on the tibia; the quadriceps,
  the patellofemoral bundles and the patellar tendon (coupling the two) on the patella,
  with their exact tangents (`fecheck.statics.newton.generalised_force`).
- EF (`ef_knee`): the tibia and the patella solved together
  (`fecheck.model.patella.solve_knee`), as `fecheck flex` solves each angle.
- The cross-check knows it as `PATELLA_KIND` (a `fecheck.fe.knee.knee_body.KneeBody`,
  registered in `fecheck.fe.knee.registry.BODIES`) and its EF state as `PatellaEF` (a
  `fecheck.fe.knee.knee_body.BodyAtEF`).

Two deformable layers (``fe.cartilage = "two-layer"``), ``fe.mode = "compartment"`` and
``fe.prepare = "on"`` are refused with the patella (`refuse_patella`); ``fe.prepare =
"auto"`` leaves the patellar sheet as it is (`fecheck.fe.bodies.budget.prepared_for_size`).
Units: mm, N, MPa.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from fecheck.errors import FecheckError
from fecheck.fe.bodies.indenter import MeshIndenter
from fecheck.fe.bodies.pose import FramePose
from fecheck.fe.bodies.scene_bodies import FEBody, vertex_values
from fecheck.fe.bodies.settings import FESettings
from fecheck.fe.solve.press import Drive
from fecheck.model.assembly import applied_load, free_indices
from fecheck.model.knee_surfaces import femoral_master
from fecheck.model.patella import (
    CARTILAGE,
    COMPARTMENT,
    PATELLA,
    TIBIA,
    PatellaModel,
    PatellaState,
    build_patella,
    pf_coordinates,
    series_thickness,
    solve_knee,
)
from fecheck.model.results import CompartmentResult, RunResult
from fecheck.model.scanned import build_compartments, bundle_parts, bundle_springs, scanned_result
from fecheck.scene import Scene, surfaces
from fecheck.statics.newton import (
    TIBIA_COORDINATES,
    Body,
    Problem,
    body_basis,
    body_pose,
    generalised_force,
    tibia_body,
    tibia_coordinates,
)

BEHIND_MM = 10.0
"""A patellar vertex whose ray back through the patella meets a femoral face farther than
this is not inside the femur (`MeshIndenter.max_depth_mm`), mm: in flexion the rays of the
sheet's rim cross the patella and meet the far side of the trochlea (measured at 30°: 16
vertices at 47-50 mm, where the EF's deepest patellar penetration is below 1 mm)."""
FRAME = "P"
"""The patella's frame name (`fecheck.fe.bodies.pose.FramePose.body`, `FEBody.carrier`)."""


NOTE = ("the patella (patella.dir): its cartilage one more layer, bonded to the "
        "patella (a rigid body, six free DOFs solved with the tibia's under the "
        "quadriceps, the patellar tendon and the patellofemoral bundles of the EF) and "
        "pressed by the rigid femoral surface; its centre of pressure in the patella "
        "frame, its force left out of the medial/lateral split")


@dataclass(frozen=True, eq=False)
class PatellaEF:
    """The EF patella of a cross-check (a `fecheck.fe.knee.knee_body.BodyAtEF`): its model,
    its state at the EF equilibrium and the FE's body coordinates (6,) (None before the
    FE solve)."""

    model: PatellaModel
    state: PatellaState
    q_fe: np.ndarray | None = None

    @property
    def kind(self) -> Patella:
        return PATELLA_KIND

    @property
    def contact(self) -> CompartmentResult:
        return self.state.contact

    @property
    def ef_pose(self) -> FramePose:
        return FramePose(self.state.rot, self.state.t, "W", FRAME)

    @property
    def q(self) -> np.ndarray:
        return np.asarray(self.state.q, dtype=float)

    def fe_pose(self) -> FramePose:
        return FramePose(*body_pose(np.asarray(self.q_fe, dtype=float)), "W", FRAME)

    def with_fe(self, q: np.ndarray) -> PatellaEF:
        return replace(self, q_fe=np.asarray(q, dtype=float))

    def balance(self, X_WT: FramePose, contact: np.ndarray) -> tuple[np.ndarray, float]:
        """The patellar tendon's wrench on the tibia (6,) and the patella's largest
        generalised force (quadriceps, patellofemoral bundles, tendon and `contact`) over
        the quadriceps' total, moments over 100 mm times it."""
        prot, pt = self.fe_pose().pair()
        tendon = self.model.tendon((X_WT.pair(), (prot, pt)))[1]
        on_patella = (self.model.femoral(prot, pt)[0] + self.model.quadriceps(prot, pt)[0]
                      + tendon[6:] + contact)
        quads = float(self.model.quadriceps.tension_N.sum())
        return tendon[:6], float(np.abs(on_patella / np.repeat([quads, 100.0 * quads], 3)).max())

    def as_dict(self) -> dict[str, Any]:
        """``patella_pose``: the FE's and the EF's patellofemoral coordinates and body
        coordinates."""
        return {"patella_pose": {"fe": pf_coordinates(*self.fe_pose().pair()),
                                 "ef": self.state.coordinates(),
                                 "fe_q": [float(v) for v in self.q_fe],
                                 "ef_q": [float(v) for v in self.state.q]}}

    def lines(self) -> list[str]:
        pf = self.as_dict()["patella_pose"]
        return ["patella FE - EF: " + ", ".join(f"{k} {pf['fe'][k] - pf['ef'][k]:+.4f}"
                                                for k in pf["fe"])]


@dataclass(frozen=True)
class Patella:
    """The patella as a `fecheck.fe.knee.knee_body.KneeBody` (module docstring)."""

    name: str = "patella"
    frame: str = FRAME
    compartment: str = COMPARTMENT
    note: str = NOTE
    unloaded_hint: str = "raise patella.quadriceps_N"

    def wanted(self, scene: Scene) -> bool:
        return bool(scene["patella.dir"])

    def refuse(self, scene: Scene, settings: FESettings) -> None:
        refuse_patella(scene, settings)

    def model(self, scene: Scene) -> PatellaModel:
        return build_patella(scene)

    def fe_body(self, scene: Scene, model: PatellaModel) -> FEBody:
        return patella_body(scene, model)

    def ef(self, scene: Scene, flexion: tuple[float, np.ndarray | None] | None,
           model: PatellaModel) -> tuple[RunResult, PatellaEF]:
        run, at_ef, _ = ef_knee(scene, flexion, model=model)
        return run, at_ef

    def drive(self, scene: Scene, q_ef: np.ndarray, springs: Sequence[Callable],
              flexion: tuple[float, np.ndarray | None], at_ef: PatellaEF) -> Drive:
        return knee_drive(scene, q_ef, springs, flexion, at_ef.model, at_ef.q)


PATELLA_KIND = Patella()
"""The patella kind, registered in `fecheck.fe.knee.registry.BODIES`."""


def refuse_patella(scene: Scene, settings: FESettings) -> None:
    """`FecheckError` (one line) for a patella scene the FE does not model."""
    if settings.mode != "joint":
        raise FecheckError("the FE with the patella (patella.dir) solves the joint: use "
                           "fe.mode = 'joint' (the patella's load is its muscles and "
                           "bundles, not a compartment force)")
    if settings.cartilage == "two-layer":
        raise FecheckError("the FE with the patella (patella.dir) models one deformable layer "
                           "per contact: use fe.cartilage = 'series', or patella.dir = ''")
    if settings.prepare == "on":
        raise FecheckError("the FE with the patella (patella.dir) meshes the EF's sheets: use "
                           "fe.prepare = 'auto' or 'off' (a prepared sheet and its femoral "
                           "surface are cut for a tibial sheet)")
    if scene["model.kind"] != "femur-tibia":
        raise FecheckError("patella.dir in the FE needs model.kind = 'femur-tibia' (the "
                           "patella presses the femoral articular surface)")


def patella_body(scene: Scene, model: PatellaModel) -> FEBody:
    """The patellar cartilage as an FE body (module docstring), patella frame."""
    slave = model.compartment.pair.slave
    if scene["scanned.thickness"] == "uniform":
        h = np.full(slave.n_points, float(scene["contact.thickness_mm"]))
    else:
        h = vertex_values(slave, series_thickness(scene, slave, model.bone))
    femur = surfaces.file_path(scene, "femur").name
    indenter = MeshIndenter(femoral_master(scene), BEHIND_MM, model.compartment.pair.rim)
    return FEBody(COMPARTMENT, slave, h, indenter,
                  f"mesh:{CARTILAGE}", f"mesh:{femur}", scene["scanned.thickness"],
                  carrier=FRAME)


def knee_drive(scene: Scene, q_ef: np.ndarray, springs: Sequence[Callable],
               flexion: tuple[float, np.ndarray | None], patella: PatellaModel,
               q_patella: np.ndarray) -> Drive:
    """The tibia's free DOFs and the patella's six as the FE's unknowns x (module
    docstring), from the EF's tibia q_ef (5,) and patella q_patella (6,); `springs` the
    tibia's bundles, `flexion` = (θx rad, Q (3, 3) or None) held. `Drive.full` gives the
    tibia's q (5,); the patella's coordinates are x[-6:]."""
    free = list(free_indices(scene))
    k = len(free) + 6
    theta, base = flexion
    tibia_parts = [applied_load(scene), *springs]
    patella_parts = [patella.femoral, patella.quadriceps]

    def wrench(poses):
        out = [((TIBIA,), *part(*poses[TIBIA])) for part in tibia_parts]
        out += [((PATELLA,), *part(*poses[PATELLA])) for part in patella_parts]
        out.append(patella.tendon(poses))
        return out

    problem = Problem((tibia_body(q_ef, free, theta, base),
                       Body("patella", np.asarray(q_patella, dtype=float), tuple(range(6)))),
                      wrench)

    def full(x: np.ndarray) -> np.ndarray:
        q = np.array(q_ef, dtype=float)
        q[free] = x[:len(free)]
        return q

    def coordinates(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return tibia_coordinates(full(x), theta), np.asarray(x[len(free):], dtype=float)

    def pose(x: np.ndarray) -> tuple[FramePose, FramePose]:
        q_t, q_p = coordinates(x)
        return (FramePose(*body_pose(q_t, base), "W", "T"),
                FramePose(*body_pose(q_p), "W", FRAME))

    def basis(x: np.ndarray) -> np.ndarray:
        q_t, q_p = coordinates(x)
        out = np.zeros((2, 6, k))
        out[0, :, :len(free)] = body_basis(q_t, base)[:, [TIBIA_COORDINATES[i] for i in free]]
        out[1, :, len(free):] = body_basis(q_p)
        return out

    return Drive(pose, basis, lambda x: generalised_force(problem, coordinates(x))[0],
                 lambda x: generalised_force(problem, coordinates(x))[1],
                 np.concatenate([np.asarray(q_ef, dtype=float)[free],
                                 np.asarray(q_patella, dtype=float)]), full)


def ef_knee(scene: Scene, flexion: tuple[float, np.ndarray | None] | None = None,
            warm: tuple[np.ndarray, np.ndarray] | None = None, built: tuple | None = None,
            model: PatellaModel | None = None) -> tuple[RunResult, PatellaEF, float]:
    """The EF of the tibia and the patella solved together at `flexion` (θx rad, Q or
    None; None: dofs.flexion_deg about x), from `warm` (tibia q (5,), patella q (6,)) or
    the scene's start and the data's pose; `built` = (compartments, bundle names, bundle
    springs) as `fecheck.model.scanned.run_scanned` takes them. Returns the tibia's
    `RunResult`, the patella and the wall time (s)."""
    t0 = time.perf_counter()
    comps, names, springs = built or (build_compartments(scene), *bundle_springs(scene))
    model = model or build_patella(scene)
    t1 = time.perf_counter()
    held = flexion or (math.radians(scene["dofs.flexion_deg"]), None)
    parts = bundle_parts(springs)
    eq, state = solve_knee(scene, comps, parts, model, None if warm is None else warm[0],
                           None if warm is None else warm[1], held, check=built is None)
    if not eq.solution.converged:
        raise FecheckError("the EF equilibrium of the tibia and the patella did not converge; "
                           "fix the scene (see `fecheck flex`) before the FE cross-check")
    run = scanned_result(scene, eq, comps, names, parts, flexion,
                         (t1 - t0, time.perf_counter() - t0))
    return run, PatellaEF(model, state), time.perf_counter() - t0
