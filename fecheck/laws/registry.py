"""The contact-law registry: every law the scene key ``contact.law`` names, in one place.

Each law is one `LawSpec`: its scene half (`fecheck.scene.law_keys.LawKeys`: name, the
scene keys it reads, its documentation), how its law object is built from the scene's
typed values, its compiled kernel (`fecheck.laws.kernel.KERNELS`), whether it is local
(the pressure at a point from that point's depth: usable per face) or takes the force from
the deepest point (Hertz), its reference and a note, and what the model asks of it (mesh
sizing, closed-form reference, depth notes, per-face thickness maps). The model reads the
law of a scene here (`spec_of`) and never branches on its name.

Adding a law is its module (the pressure law, compiled through a kernel of
`fecheck.laws.kernel`: `POWER` is a generic foundation p = c·d^m), its entry and its test:
`register(LawSpec(...))` at run time, or an entry of `BUILT_IN` (with its scene half in
`fecheck.scene.law_keys`, which the schema reads before `laws` is imported). Units: mm, N,
MPa.

>>> spec_of({"contact.law": "volumetric", "contact.volumetric_stiffness_N_per_mm3": 0.01}
...         ).stiffness({"contact.volumetric_stiffness_N_per_mm3": 0.01})
0.01
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any, Literal

import numpy as np

from fecheck.errors import FecheckError
from fecheck.laws import calibrated, layer
from fecheck.laws.foundation import BLANKEVOORT_LINEAR_FROM, blankevoort_params
from fecheck.laws.fused import compiled_law, linear_law
from fecheck.laws.hertz import hertz, hertz_point
from fecheck.laws.kernel import BLANKEVOORT, CALIBRATED, KERNELS, LINEAR
from fecheck.laws.materials import ef_stiffness, hertz_modulus, validate_material
from fecheck.reference.closed_forms import ef_cap_depth, hertz_contact_radius
from fecheck.scene import law_keys
from fecheck.scene.law_keys import LawKeys
from fecheck.scene.schema import SCHEMA

Values = Mapping[str, Any]
"""A `fecheck.scene.Scene`, or any mapping of the dotted scene keys to their values."""
Law = Callable[[Any], Any]
"""A law: a `fecheck.contact.ContactSurface` → `fecheck.laws.LawResult` (a
`fecheck.laws.fused.CompiledLaw` is one, for the compiled hot path)."""
LawFactory = Callable[[float, str], Law]
"""(condyle radius mm, NaN without a sphere; compartment name) → the compartment's law."""


@dataclass(frozen=True)
class LawInputs:
    """What a law's builder reads: the scene's values and, read by the model on demand,
    the calibration file ``contact.calibration`` ({compartment: `Calibration`}, or None
    where it is unset; `fecheck.model.assembly.calibration_file`)."""

    scene: Values
    calibration: Callable[[], Mapping[str, calibrated.Calibration] | None] = lambda: None


@dataclass(frozen=True)
class LawSpec:
    """One contact law.

    scene : its scene half (name = the ``contact.law`` value, keys, documentation)
    build : `LawInputs` → `LawFactory` (validates the material, builds the law once)
    kernel : the code of its compiled pressure kernel (`fecheck.laws.kernel.KERNELS`), or
        None (no compiled kernel: the full path)
    local : the pressure at a point is a function of that point's depth (a foundation,
        usable per face); False: the force comes from the deepest point (Hertz)
    reference : its closed form or citation
    note : one line on the law
    stiffness : scene → k (N/mm³) of p ≈ k·d at small depth, or None
    linear : p = stiffness·d exactly (the closed-form EF cap is its reference at the
        solved force, `fecheck.reference.closed_forms.ef_sphere_plane`)
    per_face : (inputs, thickness () → (n,) mm per slave face, radius mm, compartment) →
        the law over a varying thickness (``scanned.thickness = 'bone-distance'``), or
        None where the law cannot take one
    beyond_thickness : a solved depth ≥ contact.thickness_mm is an "error" (the layer is
        crushed through), a "note" (no layer) or "ignore"d
    depth_notes : (scene, {compartment: solved max depth mm}) → notes, or None
    point : scene → (point contact, radius mm) → `LawResult` on a convex sphere-on-plane
        pair (`fecheck.contact.convex.PointContact`); exactly when ``scene.point_contact``
    contact_radius : (scene, force N, sphere radius mm) → expected contact radius (mm) of
        a sphere on a plane, for mesh sizing; None: from `stiffness` (the EF cap)
    poisson_max : the largest Poisson's ratio at which the law's answer means anything
        (`fecheck.model.plausibility.check_ef_poisson` refuses a scene above it); None:
        any ratio below 0.5
    """

    scene: LawKeys
    build: Callable[[LawInputs], LawFactory]
    kernel: int | None
    local: bool
    reference: str
    note: str
    stiffness: Callable[[Values], float] | None = None
    linear: bool = False
    per_face: Callable[[LawInputs, Callable[[], np.ndarray], float, str], Law] | None = None
    beyond_thickness: Literal["error", "note", "ignore"] = "error"
    depth_notes: Callable[[Values, Mapping[str, float]], list[str]] | None = None
    point: Callable[[Values], Callable[[Any, float], Any]] | None = None
    contact_radius: Callable[[Values, float, float], float] | None = None
    poisson_max: float | None = None

    @property
    def name(self) -> str:
        """The ``contact.law`` value."""
        return self.scene.name

    @property
    def keys(self) -> tuple[str, ...]:
        """The scene keys the law reads beyond the cartilage's material."""
        return self.scene.keys

    def expected_contact_radius(self, scene: Values, force_N: float, radius_mm: float
                                ) -> float:
        """Contact radius (mm) of a sphere of `radius_mm` pressed on a plane by `force_N`
        (N) under this law, capped at the sphere radius (0 for no force)."""
        r = float(radius_mm)
        if force_N <= 0.0:
            return 0.0
        if self.contact_radius is not None:
            return min(r, self.contact_radius(scene, force_N, r))
        d = ef_cap_depth(force_N, r, self.stiffness(scene))
        if d >= r:                                            # the whole hemisphere
            return r
        return math.sqrt(max(2.0 * r * d - d * d, 0.0))

    def check(self) -> None:
        """`FecheckError` for an entry that contradicts itself."""
        problems = []
        if self.kernel is not None and self.kernel not in KERNELS:
            problems.append(f"kernel {self.kernel!r} is not one of {sorted(KERNELS)}")
        if self.scene.point_contact != (self.point is not None):
            problems.append("point_contact of its scene half and its point law disagree")
        if self.stiffness is None and self.contact_radius is None:
            problems.append("it needs a stiffness or a contact_radius (mesh sizing)")
        if self.linear and self.stiffness is None:
            problems.append("a linear law needs its stiffness")
        if self.beyond_thickness not in ("error", "note", "ignore"):
            problems.append(f"beyond_thickness {self.beyond_thickness!r}")
        if problems:
            raise FecheckError(f"law {self.name!r}: " + "; ".join(problems))


def _material(scene: Values) -> tuple[float, float, float]:
    """(E MPa, ν, h mm) of the cartilage."""
    return scene["contact.youngs_MPa"], scene["contact.poisson"], scene["contact.thickness_mm"]


def _same(law: Law) -> LawFactory:
    """A factory giving `law` to every compartment."""
    return lambda r, c: law


def _ef_stiffness(scene: Values) -> float:
    return ef_stiffness(*_material(scene))


def _layers_stiffness(scene: Values) -> float:
    """k (N/mm³) of the linear EF: c/h, or with a femoral cartilage of its own material
    the two layers of `layer.uniform_sides` in series, 1/(h_t/c_t + h_f/c_f)."""
    sides = layer.sides(scene)
    if not sides.own_material:
        return ef_stiffness(*_material(scene))
    validate_material(*_material(scene))
    return sides.c_tibial / float(sides.equivalent_thickness(*layer.uniform_sides(scene)))


def _volumetric_stiffness(scene: Values) -> float:
    return scene["contact.volumetric_stiffness_N_per_mm3"]


def _build_ef(inputs: LawInputs) -> LawFactory:
    validate_material(*_material(inputs.scene))
    return _same(linear_law(_layers_stiffness(inputs.scene)))


def _ef_per_face(inputs: LawInputs, thickness: Callable[[], np.ndarray], radius_mm: float,
                 compartment: str) -> Law:
    """The linear EF with a stiffness per slave face from its thickness."""
    e, nu, _ = _material(inputs.scene)
    return layer.face_elastic_foundation(layer.face_ef_stiffness(thickness(), e, nu))


def _build_volumetric(inputs: LawInputs) -> LawFactory:
    validate_material(*_material(inputs.scene))
    return _same(linear_law(_volumetric_stiffness(inputs.scene)))


def _build_blankevoort(inputs: LawInputs) -> LawFactory:
    return _same(compiled_law(BLANKEVOORT, blankevoort_params(*_material(inputs.scene))))


def _blankevoort_notes(scene: Values, max_depth_mm: Mapping[str, float]) -> list[str]:
    limit = BLANKEVOORT_LINEAR_FROM * scene["contact.thickness_mm"]
    deep = [c for c, d in max_depth_mm.items() if d > limit]
    return [f"depth beyond 0.9 h in {deep}: the log law was continued linearly"] if deep else []


def _table_calibration(scene: Values, radius_mm: float) -> calibrated.Calibration:
    """The built-in table's law for a sphere of `radius_mm` on the scene's layer."""
    if not math.isfinite(radius_mm) or scene["scanned.thickness"] == "bone-distance":
        raise FecheckError("contact.law = 'ef-calibrated' on this scene needs its own "
                           "calibration (no condyle sphere, or a varying thickness, for the "
                           "built-in table): run `fecheck calibrate SCENE -o FILE` and set "
                           "contact.calibration = FILE")
    return calibrated.table_calibration(*_material(scene), radius_mm)


def _build_calibrated(inputs: LawInputs) -> LawFactory:
    validate_material(*_material(inputs.scene))
    own = inputs.calibration()

    def calibrated_law(r: float, c: str) -> Law:
        if own is not None and c not in own:
            raise FecheckError(
                f"contact.calibration: {inputs.scene['contact.calibration']} holds no {c} "
                f"compartment (it has {', '.join(own) or 'none'}): fit this scene's with "
                "`fecheck calibrate SCENE -o FILE`, or unset contact.calibration for the "
                "built-in table")
        cal = own[c] if own is not None else _table_calibration(inputs.scene, r)
        return compiled_law(CALIBRATED, calibrated.calibrated_params(cal))

    return calibrated_law


def _calibrated_per_face(inputs: LawInputs, thickness: Callable[[], np.ndarray],
                         radius_mm: float, compartment: str) -> Law:
    """The calibration was fitted to the FE of the scene's own layers: the map is in it."""
    return _build_calibrated(inputs)(radius_mm, compartment)


def _e_star(scene: Values) -> float:
    e, nu, _ = _material(scene)
    return hertz_modulus(e, nu, scene["contact.indenter_youngs_MPa"],
                         scene["contact.indenter_poisson"])


def _build_hertz(inputs: LawInputs) -> LawFactory:
    e_star = _e_star(inputs.scene)

    def hertz_law(r: float, c: str) -> Law:
        if not math.isfinite(r):
            raise FecheckError("contact.law = 'hertz' needs a condyle radius, and the "
                               "femur-tibia model has no sphere: use 'ef', 'blankevoort' or "
                               "'volumetric'")
        return lambda s: hertz(s, r, e_star)

    return hertz_law


def _hertz_point(scene: Values) -> Callable[[Any, float], Any]:
    e_star = _e_star(scene)
    return lambda contact, r: hertz_point(contact, r, e_star)


def _hertz_radius(scene: Values, force_N: float, radius_mm: float) -> float:
    return hertz_contact_radius(force_N, radius_mm, _e_star(scene))


_KEYS = law_keys.LAWS
BUILT_IN: tuple[LawSpec, ...] = (
    LawSpec(_KEYS["ef"], _build_ef, LINEAR, True,
            "thesis eq. 4.1-4.3; a sphere on a plane: F = k·πd²(R − d/3) "
            "(fecheck.reference.closed_forms.ef_sphere_plane)",
            "linear elastic foundation p = k·d, k = (1−ν)E/((1+ν)(1−2ν)h)",
            stiffness=_layers_stiffness, linear=True, per_face=_ef_per_face,
            poisson_max=0.49),
    LawSpec(_KEYS["hertz"], _build_hertz, None, False,
            "thesis eq. 4.4-4.8: P = 4/3·E*·√R·d^(3/2), a = √(R d)",
            "from the deepest point: smooth on a convex sphere-plane pair, from the deepest "
            "vertex (not smooth in the pose) on a mesh",
            beyond_thickness="ignore", point=_hertz_point, contact_radius=_hertz_radius),
    LawSpec(_KEYS["volumetric"], _build_volumetric, LINEAR, True,
            "thesis eq. 4.9: F = k_V·V (v_n = 0 in statics), the EF cap with k = k_V",
            "p = k_V·d with no layer thickness",
            stiffness=_volumetric_stiffness, linear=True, beyond_thickness="note"),
    LawSpec(_KEYS["blankevoort"], _build_blankevoort, BLANKEVOORT, True,
            "Blankevoort et al. 1991, J. Biomech. 24(11):1019-1031",
            "p = −(1−ν)E/((1+ν)(1−2ν))·ln(1 − d/h), continued linearly beyond 0.9·h; "
            "mesh sizing takes its small-depth EF stiffness",
            stiffness=_ef_stiffness, depth_notes=_blankevoort_notes),
    LawSpec(_KEYS["ef-calibrated"], _build_calibrated, CALIBRATED, True,
            "fitted to FE: `fecheck calibrate`, or the built-in table of axisymmetric FE "
            "(validation/ef_calibration_table.py)",
            "p = C·d·(d + 0.01 mm)^(n−1) per compartment; mesh sizing takes the linear "
            "EF stiffness",
            stiffness=_ef_stiffness, per_face=_calibrated_per_face),
)
"""The shipped laws, in the order of `fecheck.scene.law_keys.LAWS`."""

REGISTRY: dict[str, LawSpec] = {spec.name: spec for spec in BUILT_IN}
"""Every registered law by its ``contact.law`` value."""


def law_spec(name: str) -> LawSpec:
    """The registered law `name`; `FecheckError` naming the registered ones otherwise."""
    try:
        return REGISTRY[name]
    except KeyError:
        raise FecheckError(f"contact.law = {name!r} is not a registered law; use one of "
                           f"{', '.join(REGISTRY)}") from None


def spec_of(scene: Values) -> LawSpec:
    """The law of a scene (its ``contact.law``)."""
    return law_spec(scene["contact.law"])


def laws_with(test: Callable[[LawSpec], bool]) -> tuple[str, ...]:
    """The names of the registered laws for which `test(spec)` holds (for messages)."""
    return tuple(name for name, spec in REGISTRY.items() if test(spec))


def _refresh_schema() -> None:
    """The schema's ``contact.law`` allows and documents exactly the declared laws."""
    SCHEMA["contact.law"] = replace(SCHEMA["contact.law"], choices=law_keys.law_names(),
                                    doc=law_keys.law_doc())


def register(spec: LawSpec) -> None:
    """Add a law: a scene may then name it (``contact.law``), its keys take part in the
    inert-key warnings and every model builds it through `spec`. `FecheckError` for a
    name already registered or an inconsistent entry."""
    spec.check()
    if spec.name in REGISTRY or spec.name in law_keys.LAWS:
        raise FecheckError(f"contact.law = {spec.name!r} is already registered")
    REGISTRY[spec.name] = spec
    law_keys.LAWS[spec.name] = spec.scene
    _refresh_schema()


def unregister(name: str) -> None:
    """Remove a law added by `register` (the shipped laws stay)."""
    if name in (spec.name for spec in BUILT_IN):
        raise FecheckError(f"contact.law = {name!r} is a shipped law and stays registered")
    REGISTRY.pop(name, None)
    law_keys.LAWS.pop(name, None)
    _refresh_schema()
