"""Plain results of the FE cross-check (frozen dataclasses; units in the field names)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fecheck.reference.closed_forms import ContactMetrics


@dataclass(frozen=True, eq=False)
class SideMetrics:
    """One compartment's contact as FE or EF answers it.

    force_vector_N : (3,) contact force on the tibia, world axes; `force_N` its magnitude;
        `axial_force_N` its component along the tibia's long axis (+ compressive)
    max_pressure_MPa, mean_pressure_MPa : mean = normal force / area
    area_mm2 : contact area; depth_mm : deepest rigid overlap of the surfaces at the pose
    center_of_pressure_mm : (3,) tibia frame (None where undefined, e.g. point contacts)
    """

    force_vector_N: np.ndarray
    axial_force_N: float
    max_pressure_MPa: float
    mean_pressure_MPa: float
    area_mm2: float
    depth_mm: float
    center_of_pressure_mm: np.ndarray | None

    @property
    def force_N(self) -> float:
        return float(np.linalg.norm(self.force_vector_N))

    def contact_metrics(self) -> ContactMetrics:
        return ContactMetrics(self.max_pressure_MPa, self.mean_pressure_MPa, self.area_mm2,
                              self.depth_mm, self.force_N)

    def as_dict(self) -> dict:
        def num(v):
            return float(v) if v is not None and np.isfinite(v) else None

        cop = self.center_of_pressure_mm
        return {"force_N": num(self.force_N), "axial_force_N": num(self.axial_force_N),
                "force_vector_N": [num(v) for v in self.force_vector_N],
                "max_pressure_MPa": num(self.max_pressure_MPa),
                "mean_pressure_MPa": num(self.mean_pressure_MPa),
                "area_mm2": num(self.area_mm2), "depth_mm": num(self.depth_mm),
                "center_of_pressure_mm": None if cop is None else [num(v) for v in cop]}


@dataclass(frozen=True, eq=False)
class FEContactResult:
    """An FE contact solve under load control.

    Attributes
    ----------
    metrics : max/mean pressure, contact area, indenter displacement, summed reaction
    points : (n, 3) top-surface node positions (reference configuration), mm; for the
        axisymmetric model (r, 0, z)
    pressure_MPa : (n,) recovered contact pressure at those nodes
    gap0_mm : (n,) vertical gap to the indenter before loading (0 where it first touches)
    nodal_force_N : (n,) contact force at each node (≥ 0, pressing down)
    gap_mm : (n,) vertical gap to the indenter after loading (≥ 0; 0 where in contact)
    active : (n,) nodes in contact
    faces : (k, 3) triangles over ``points`` for plotting (empty for the axisymmetric model)
    n_dofs, n_elements : problem size; element : element kind, e.g. "tet P2"
    size_under_contact_mm : median element edge on the top inside the contact
    iterations : active-set iterations; timing_s : wall times of the steps
    max_penetration_mm : worst overlap at the candidate contact nodes (≥ 0)
    node_area_mm2 : area counted as the tributary areas of the nodes in contact
        (``metrics.area_mm2`` is the better estimate; see each model)
    """

    metrics: ContactMetrics
    points: np.ndarray
    pressure_MPa: np.ndarray
    gap0_mm: np.ndarray
    nodal_force_N: np.ndarray
    gap_mm: np.ndarray
    active: np.ndarray
    faces: np.ndarray
    n_dofs: int
    n_elements: int
    element: str
    size_under_contact_mm: float
    iterations: int
    timing_s: dict
    max_penetration_mm: float
    node_area_mm2: float

    def as_dict(self) -> dict:
        return {**self.metrics.as_dict(), "n_dofs": self.n_dofs, "n_elements": self.n_elements,
                "element": self.element, "size_under_contact_mm": self.size_under_contact_mm,
                "iterations": self.iterations, "max_penetration_mm": self.max_penetration_mm,
                "min_nodal_force_N": float(self.nodal_force_N.min()),
                "min_pressure_MPa": float(self.pressure_MPa.min()),
                "node_area_mm2": self.node_area_mm2,
                "timing_s": dict(self.timing_s)}


@dataclass(frozen=True, eq=False)
class PressurePeaks:
    """One compartment's FE pressure peak at three scales, and whether the vertex peak is a
    lone spike (`fecheck.fe.pressure.recovery.pressure_peaks`).

    vertex_MPa, vertex_at_mm : the largest vertex pressure (force / tributary area) and its
        place (tibia frame, mm); neighbour_MPa : the largest of its edge neighbours'
    face_MPa : the largest FE pressure averaged onto one EF face (the EF's scale)
    smoothed_MPa, smoothed_at_mm : the largest area-weighted mean pressure over the
        vertices within `length_mm` of a vertex (the contact force there over its area)
    spike : why the vertex peak is a lone spike ("" when it is not)
    feature_mm : largest distance of the tibial sheet from its smoothed copy within
        `length_mm` of the vertex peak (NaN when not measured); rough : whether that is a
        rough feature (see `fecheck.fe.knee.crosscheck.ROUGH_FEATURE_SHARE`)
    """

    vertex_MPa: float
    vertex_at_mm: np.ndarray
    neighbour_MPa: float
    face_MPa: float
    smoothed_MPa: float
    smoothed_at_mm: np.ndarray
    length_mm: float
    spike: str
    feature_mm: float = float("nan")
    rough: bool = False

    def as_dict(self) -> dict:
        def num(v):
            return float(v) if np.isfinite(v) else None

        return {"vertex_MPa": num(self.vertex_MPa),
                "vertex_at_mm": [float(v) for v in self.vertex_at_mm],
                "neighbour_MPa": num(self.neighbour_MPa), "face_MPa": num(self.face_MPa),
                "smoothed_MPa": num(self.smoothed_MPa),
                "smoothed_at_mm": [float(v) for v in self.smoothed_at_mm],
                "smoothing_length_mm": self.length_mm, "lone_spike": bool(self.spike),
                "spike_reason": self.spike or None, "feature_mm": num(self.feature_mm),
                "on_rough_feature": self.rough}
