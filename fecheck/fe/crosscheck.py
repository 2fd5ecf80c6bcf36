"""FE cross-check of a scene: per compartment, the FE layer solve under the EF load.

For each compartment (medial, lateral) the EF equilibrium's contact force presses the
condyle sphere (radius = the knee's condyle radius) vertically on a bonded cartilage layer
(the scene's E, ν, h; its plateau: transverse, inclined or polynomial). Beside the 3D FE
answer sit the axisymmetric FE reference (flat layer), the closed-form EF law and Hertz at
the same load, the EF model's own compartment result, and Donahue 2002.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from fecheck.errors import FecheckError
from fecheck.fe.axisym import axisym_sphere_on_layer
from fecheck.fe.layer3d import check_cost, estimate_cost, sphere_on_layer_3d
from fecheck.fe.results import ContactMetrics, FEContactResult
from fecheck.model.plausibility import modulus_warning
from fecheck.reference.closed_forms import (
    DONAHUE_2002,
    column_stiffness,
    ef_sphere_on_plane,
    hertz_sphere_on_plane,
)
from fecheck.scene.constants import COMPARTMENTS, GRAVITY_MPS2
from fecheck.scene.relevance import SCANNED_KINDS

REFERENCE_ELEMENTS = 4
"""The axisymmetric answer is a converged reference for the 3D one only when its contact
radius spans at least this many of its elements (a 3D/axisymmetric gap is then the 3D
discretization error)."""


def stderr_log(message: str) -> None:
    """Progress of `fecheck fe` on standard error, one line per step."""
    print(f"fecheck fe: {message}", file=sys.stderr, flush=True)


@dataclass(frozen=True)
class FESettings:
    """FE options of a scene's ``[fe]`` table (sizes in mm)."""

    size_mm: float = 1.5
    far_size_mm: float = 5.0
    half_extent_mm: float = 30.0
    footprint: str = "ellipse"
    gap: str = "reference"
    solver: str = "cholmod"
    axisym_size_mm: float = 0.1

    @classmethod
    def from_scene(cls, scene, size_mm: float | None = None) -> FESettings:
        values = {k: scene[f"fe.{k}"] for k in cls.__dataclass_fields__}
        if size_mm is not None:
            values["size_mm"] = float(size_mm)
        return cls(**values)


@dataclass(frozen=True, eq=False)
class CompartmentCheck:
    """One compartment's FE answer beside its references (all at ``load_N``)."""

    name: str
    load_N: float
    radius_mm: float
    fe: FEContactResult
    axisym: FEContactResult | None
    ef: ContactMetrics
    hertz: ContactMetrics
    ef_model: ContactMetrics | None
    timing_s: dict = field(default_factory=dict)

    def comparable(self) -> bool:
        """Whether a 3D/axisymmetric gap is the 3D discretization error: both solves ran
        (converged) on the same flat layer, material and load, and the axisymmetric
        contact spans `REFERENCE_ELEMENTS` of its elements (a converged reference)."""
        if self.axisym is None:
            return False
        a = self.axisym.metrics
        radius = math.sqrt(max(a.area_mm2, 0.0) / math.pi)
        size = self.axisym.size_under_contact_mm
        same_load = math.isclose(a.force_N, self.fe.metrics.force_N, rel_tol=1e-9)
        return same_load and radius >= REFERENCE_ELEMENTS * size

    def deviation(self) -> dict[str, float | None]:
        """Relative differences 3D FE vs the axisymmetric FE: the 3D discretization error,
        only where the two are `comparable` (flat layers, same load, a converged
        reference); else {}."""
        if not self.comparable():
            return {}
        f, a = self.fe.metrics, self.axisym.metrics
        return {"max_pressure": f.max_pressure_MPa / a.max_pressure_MPa - 1,
                "area": f.area_mm2 / a.area_mm2 - 1, "depth": f.depth_mm / a.depth_mm - 1}

    def as_dict(self) -> dict[str, Any]:
        out = {"load_N": self.load_N, "radius_mm": self.radius_mm, "fe": self.fe.as_dict(),
               "axisym": None if self.axisym is None else self.axisym.as_dict(),
               "fe_vs_axisym": self.deviation(), "ef": self.ef.as_dict(),
               "hertz": self.hertz.as_dict(),
               "ef_model": None if self.ef_model is None else self.ef_model.as_dict(),
               "donahue_2002": {f"{s:g}mm": m.as_dict()
                                for s, m in DONAHUE_2002[self.name].items()},
               "timing_s": dict(self.timing_s)}
        return out


@dataclass(frozen=True, eq=False)
class CrossCheck:
    """The FE cross-check of a scene."""

    compartments: dict[str, CompartmentCheck]
    settings: FESettings
    material: dict[str, float]
    timing_s: dict

    def as_dict(self) -> dict[str, Any]:
        fe = {c: chk.fe for c, chk in self.compartments.items()}
        mesh = {"element": next(iter(fe.values())).element,
                **{c: {"n_dofs": r.n_dofs, "n_elements": r.n_elements,
                       "size_under_contact_mm": r.size_under_contact_mm} for c, r in fe.items()}}
        return {"compartments": {c: chk.as_dict() for c, chk in self.compartments.items()},
                "mesh": mesh, "settings": self.settings.__dict__, "material": self.material,
                "timing_s": self.timing_s}

    def table(self) -> str:
        """A plain-text comparison table."""
        rows = [f"{'':24s}" + "".join(f"{c:>34s}" for c in self.compartments)]
        head = f"{'':24s}" + "".join(f"{'p_max':>9s}{'p_mean':>8s}{'area':>9s}{'depth':>8s}"
                                      for _ in self.compartments)
        rows.append(head)
        labels = (("FE 3D", "fe"), ("FE axisymmetric", "axisym"), ("EF (closed form)", "ef"),
                  ("EF model", "ef_model"), ("Hertz", "hertz"))
        for label, attr in labels:
            line = f"{label:24s}"
            for chk in self.compartments.values():
                m = getattr(chk, attr)
                m = m.metrics if isinstance(m, FEContactResult) else m
                line += (f"{'(flat layers only)':>34s}" if m is None else
                         f"{m.max_pressure_MPa:9.3f}{m.mean_pressure_MPa:8.3f}"
                         f"{m.area_mm2:9.1f}{m.depth_mm:8.3f}")
            rows.append(line)
        for size in (1.0,):
            line = f"{'Donahue 2002 (1 mm)':24s}"
            for c in self.compartments:
                m = DONAHUE_2002[c][size]
                line += f"{m.max_pressure_MPa:9.3f}{m.mean_pressure_MPa:8.3f}{m.area_mm2:9.1f}" \
                        f"{'':>8s}"
            rows.append(line)
        rows.append("units: MPa, MPa, mm², mm; loads " + ", ".join(
            f"{c} {chk.load_N:.2f} N" for c, chk in self.compartments.items()))
        return "\n".join(rows)


def _shifted(coeffs: np.ndarray, dx: float, dy: float) -> np.ndarray:
    """Coefficients of q(x, y) = p(x + dx, y + dy) (``c[i, j]`` multiplies x^i y^j)."""
    from math import comb

    c = np.asarray(coeffs, dtype=float)
    out = np.zeros_like(c)
    for i in range(c.shape[0]):
        for j in range(c.shape[1]):
            for a in range(i + 1):
                for b in range(j + 1):
                    out[a, b] += c[i, j] * comb(i, a) * comb(j, b) * dx ** (i - a) * dy ** (j - b)
    return out


def plateau_geometry(scene, compartment: str) -> dict[str, Any]:
    """Keyword arguments of `sphere_on_layer_3d` for the scene's plateau under a condyle."""
    kind = scene["plateau.kind"]
    if kind == "transverse":
        return {}
    if kind == "inclined":
        lam, gam = scene[f"plateau.{compartment}_angles_deg"]
        return {"sagittal_deg": float(lam), "frontal_deg": float(gam)}
    from geometry.polynomial import Polynomial2D

    cx, cy = np.asarray(scene.knee.condyle_center[compartment])[:2]
    coeffs = np.asarray(scene[f"plateau.{compartment}_coefficients"], dtype=float)
    return {"top": Polynomial2D(_shifted(coeffs, cx, cy))}


def check_physical(label: str, result: FEContactResult, E_MPa: float,
                   size_mm: float) -> None:
    """`FecheckError` naming the quantity of an FE answer that is not physical (NaN, a
    zero contact area or pressure under the load) and its likely cause."""
    m = result.metrics
    values = {"max pressure": m.max_pressure_MPa, "mean pressure": m.mean_pressure_MPa,
              "contact area": m.area_mm2, "indentation": m.depth_mm}
    bad = [f"{k} {v:g}" for k, v in values.items()
           if not math.isfinite(v) or (k != "indentation" and v <= 0)]
    if not bad:
        return
    cause = modulus_warning(E_MPa) or "check contact.youngs_MPa and load.force_N"
    raise FecheckError(f"{label}: {', '.join(bad)}: not a physical answer; the contact "
                       f"is smaller than the elements under it ({size_mm:g} mm), so no "
                       f"patch is resolved: refine (--size, fe.size_mm); {cause}")


def check_compartment(name: str, load_N: float, radius_mm: float, E_MPa: float, nu: float,
                      thickness_mm: float, settings: FESettings,
                      geometry: dict[str, Any] | None = None,
                      ef_model: ContactMetrics | None = None,
                      log: Callable[[str], None] | None = None) -> CompartmentCheck:
    """FE (3D and, for a flat layer, axisymmetric) and references for one compartment.
    `log` gets progress lines (None: silent); a non-physical FE answer raises
    `FecheckError` (`check_physical`)."""
    geometry = geometry or {}
    say = log or (lambda message: None)
    estimate = check_cost(estimate_cost(load_N, radius_mm, E_MPa, nu, thickness_mm,
                                        settings.size_mm, settings.far_size_mm,
                                        settings.half_extent_mm))
    say(f"{name}: 3D layer under {load_N:.1f} N at {settings.size_mm:g} mm: "
        f"{estimate.text()}")
    timing = {}
    t = time.perf_counter()
    fe = sphere_on_layer_3d(load_N, radius_mm, E_MPa, nu, thickness_mm,
                            footprint=settings.footprint, half_extent_mm=settings.half_extent_mm,
                            size_mm=settings.size_mm, far_size_mm=settings.far_size_mm,
                            gap=settings.gap, solver=settings.solver,
                            log=lambda m: say(f"{name}: {m}"), **geometry)
    timing["fe_3d"] = time.perf_counter() - t
    say(f"{name}: 3D FE done in {timing['fe_3d']:.1f} s")
    check_physical(f"{name} 3D FE", fe, E_MPa, settings.size_mm)
    axisym = None
    if not geometry:
        say(f"{name}: axisymmetric reference at {settings.axisym_size_mm:g} mm")
        t = time.perf_counter()
        axisym = axisym_sphere_on_layer(load_N, radius_mm, E_MPa, nu, thickness_mm,
                                        layer_radius_mm=settings.half_extent_mm,
                                        size_mm=settings.axisym_size_mm, gap=settings.gap,
                                        solver=settings.solver)
        timing["fe_axisym"] = time.perf_counter() - t
        check_physical(f"{name} axisymmetric FE", axisym, E_MPa, settings.axisym_size_mm)
    return CompartmentCheck(name=name, load_N=load_N, radius_mm=radius_mm, fe=fe, axisym=axisym,
                            ef=ef_sphere_on_plane(load_N, radius_mm, E_MPa, nu, thickness_mm),
                            hertz=hertz_sphere_on_plane(load_N, radius_mm, E_MPa, nu),
                            ef_model=ef_model, timing_s=timing)


def refuse_costly(scene, settings: FESettings) -> None:
    """Before any work: `FecheckError` for a 3D size below the floor or beyond the memory
    available, estimated at the whole load (and weight) on the larger condyle."""
    weight = scene["tibia.mass_kg"] * GRAVITY_MPS2 * scene["gravity"]
    load = max(scene["load.force_N"] + weight, 1.0)
    radius = max(scene.knee.radius_mm(c) for c in COMPARTMENTS)
    check_cost(estimate_cost(load, radius, scene["contact.youngs_MPa"], scene["contact.poisson"],
                             scene["contact.thickness_mm"], settings.size_mm,
                             settings.far_size_mm, settings.half_extent_mm))


def refuse_stand_in(scene) -> None:
    """`FecheckError` for a scene whose surfaces this FE cannot model: it meshes a condyle
    sphere over a plateau-shaped layer, so for the scanned cartilage surfaces it would
    answer for another geometry (never a silent stand-in)."""
    kind = scene["model.kind"]
    if kind in SCANNED_KINDS:
        raise FecheckError(f"fecheck fe models a condyle sphere on a plateau-shaped layer; "
                           f"the scanned cartilage surfaces of model.kind = '{kind}' are not "
                           "modelled by it yet (a sphere on a flat layer would stand in for "
                           "them): no FE cross-check for this scene")
    if kind == "rigid":
        raise FecheckError("model.kind = 'rigid' has no cartilage: nothing to cross-check "
                           "with the FE")


def cross_check(scene, size_mm: float | None = None,
                log: Callable[[str], None] | None = stderr_log) -> CrossCheck:
    """Solve the scene's EF equilibrium, then one FE solve per compartment under its load.

    Sizes whose estimated cost is out of reach are refused first (`refuse_costly`);
    `log` gets progress lines (default: standard error; None: silent)."""
    from fecheck.model.run import run_scene

    refuse_stand_in(scene)
    settings = FESettings.from_scene(scene, size_mm)
    refuse_costly(scene, settings)
    say = log or (lambda message: None)
    E, nu, h = scene["contact.youngs_MPa"], scene["contact.poisson"], scene["contact.thickness_mm"]
    t = time.perf_counter()
    say("solving the EF equilibrium")
    run = run_scene(scene)
    ef_time = time.perf_counter() - t
    if not run.converged:
        raise FecheckError("the EF equilibrium of this scene did not converge; fix the scene "
                           "(see `fecheck run`) before the FE cross-check")
    checks = {}
    timing: dict[str, Any] = {"ef_equilibrium": ef_time}
    for c in COMPARTMENTS:
        res = run.compartments[c]
        load = float(res.force_N)
        if not (np.isfinite(load) and load > 0):
            raise FecheckError(f"the {c} compartment carries no load ({load} N) at equilibrium: "
                               "nothing to cross-check")
        ef_model = None
        if np.isfinite(res.max_pressure_MPa):
            ef_model = ContactMetrics(float(res.max_pressure_MPa), float(res.mean_pressure_MPa),
                                      float(res.area_mm2), float(res.max_depth_mm), load)
        chk = check_compartment(c, load, scene.knee.radius_mm(c), E, nu, h, settings,
                                plateau_geometry(scene, c), ef_model, log)
        checks[c] = chk
        timing[c] = {**chk.timing_s, "fe_3d_over_ef_equilibrium": chk.timing_s["fe_3d"] / ef_time}
    return CrossCheck(checks, settings, {"E_MPa": E, "nu": nu, "thickness_mm": h,
                                         "ef_k_N_per_mm3": column_stiffness(E, nu, h)}, timing)
