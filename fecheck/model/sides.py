"""Each cartilage layer's compression in a linear EF run whose scene sets the two layers
apart (``contact.femoral_share`` other than ½, or ``contact.femoral_youngs_MPa`` /
``contact.femoral_poisson`` set).

The layers are two foundations in series: under a face of depth δ (the overlap of the
two articular surfaces) each carries the same pressure p = k·δ, k = 1/(h_t/c_t + h_f/c_f),
so the tibial layer compresses δ_t = p·h_t/c_t = δ·(h_t/c_t)/(h_t/c_t + h_f/c_f) and the
femoral one δ − δ_t (`fecheck.laws.layer.Sides.tibial_ratio`). Thicknesses: uniform
(`fecheck.laws.layer.uniform_sides`) or, with ``scanned.thickness = "bone-distance"``,
per tibial face (`fecheck.model.scanned.slave_sides`). A compartment reports the deepest
face-mean compression of each layer, mm.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from fecheck.laws import layer
from fecheck.laws.registry import spec_of
from fecheck.model.knee_surfaces import tibial_slaves
from fecheck.model.results import CompartmentResult, RunResult
from fecheck.scene import Scene


def _tibial_ratio(scene: Scene, sides: layer.Sides, compartment: str) -> np.ndarray:
    """δ_t/δ of the compartment's slave faces (a scalar for uniform layers)."""
    if scene["scanned.thickness"] == "uniform":
        return sides.tibial_ratio(*layer.uniform_sides(scene))
    from fecheck.model.scanned import slave_sides

    return sides.tibial_ratio(*slave_sides(scene, tibial_slaves(scene)[compartment]))


def split(res: CompartmentResult, tibial_ratio: np.ndarray | float) -> CompartmentResult:
    """`res` with the deepest face-mean compression of each layer (mm), the tibial layer
    taking `tibial_ratio` of every face's depth."""
    depth = np.maximum(np.asarray(res.face_depth_mm, dtype=float), 0.0)
    tibial = depth * tibial_ratio
    return replace(res, tibial_compression_mm=float(tibial.max(initial=0.0)),
                   femoral_compression_mm=float((depth - tibial).max(initial=0.0)))


def with_layer_compression(scene: Scene, result: RunResult) -> RunResult:
    """`result` with each layer's compression (module docstring), when the scene sets the
    layers apart and its law is the linear foundation of a layer; else `result`."""
    sides = layer.sides(scene)
    spec = spec_of(scene)
    if not (sides.given and spec.linear and spec.per_face is not None):
        return result
    out = {name: res if res.face_depth_mm is None
           else split(res, _tibial_ratio(scene, sides, name))
           for name, res in result.compartments.items()}
    return replace(result, compartments=out)
