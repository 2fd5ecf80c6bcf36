"""Run a scene: the registry of model kinds and the one entry point, `run_scene`.

To add a model kind, write its runner (a function of the scene and an optional warm
start returning a `RunResult`), register it in `MODEL_RUNNERS` and add the kind to
`fecheck.scene.constants.MODEL_KINDS`.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from fecheck.errors import FecheckError
from fecheck.laws.coldstart import announce_cold_kernels
from fecheck.model import scanned, sphere_plane
from fecheck.model.plausibility import after_solve
from fecheck.model.results import RunResult
from fecheck.model.reuse import building_once
from fecheck.model.rigid import run_rigid
from fecheck.model.scanned import bundle_parts, bundle_springs, run_scanned
from fecheck.model.sides import with_layer_compression
from fecheck.model.sphere_plane import ligament_parts, run_contact_model
from fecheck.scene import Scene

MODEL_RUNNERS: dict[str, Callable[..., RunResult]] = {
    "rigid": run_rigid,
    "sphere-plane": run_contact_model,
    "sphere-tibia": run_scanned,
    "femur-tibia": run_scanned,
}


def run_scene(scene: Scene, warm_start: np.ndarray | None = None) -> RunResult:
    """Solve a scene and return its `RunResult`.

    `warm_start` (5,) = (x, y, z mm, θy, θz rad) starts the Newton solve there (sweeps).
    Inputs and meshes are checked before the solve (warnings, or `FecheckError` where the
    solve could mean nothing) and the result after it: a value that cannot be physical
    raises `FecheckError` (`fecheck.model.plausibility`).
    """
    kind = scene["model.kind"]
    if scene["menisci.dir"]:
        from fecheck.model.menisci import run_menisci

        runner = run_menisci
    elif scene["scanned.ligaments"] != "none":
        runner = run_scanned
    elif kind in MODEL_RUNNERS:
        runner = MODEL_RUNNERS[kind]
    else:
        raise FecheckError(f"model.kind {kind!r} has no runner; known: "
                           f"{', '.join(MODEL_RUNNERS)}")
    if runner is not run_rigid:
        announce_cold_kernels()
    with building_once():
        result = runner(scene, warm_start)
    after_solve(scene, result)
    return with_layer_compression(scene, result)


def ligament_springs(scene: Scene) -> list[Callable]:
    """The ligament springs (wrench parts of the pose) the scene's run adds to contact,
    load and gravity: the scanned knee's bundles or the three spring ligaments."""
    if scene["scanned.ligaments"] != "none":
        return bundle_parts(bundle_springs(scene)[1])
    return ligament_parts(scene)[0] if scene["model.kind"] == "sphere-plane" else []


def forget_contact_state(scene: Scene) -> None:
    """Make the next `run_scene` of `scene` start from fresh contact state: the contact
    pairs that its run will reuse (inside `fecheck.model.reuse.reusing_builds`) drop the
    candidate sets and closest-point states that earlier runs left (`ContactPair.forget`),
    so that its numbers do not depend, even at round-off, on which runs came before (a
    population's samples, wherever they run). Builds the pairs if they are not built."""
    if scene["menisci.dir"]:
        return
    if scene["scanned.ligaments"] != "none" or scene["model.kind"] in ("sphere-tibia",
                                                                      "femur-tibia"):
        comps = scanned.build_compartments(scene)
    elif scene["model.kind"] == "sphere-plane":
        comps = sphere_plane.build_compartments(scene)
    else:
        return
    for comp in comps:
        forget = getattr(comp.pair, "forget", None)
        if forget is not None:
            forget()
