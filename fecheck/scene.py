"""Scenes: TOML files describing one knee-contact problem, validated on load.

A scene is a flat mapping of dotted keys (``contact.poisson``) to values; every key has
a type, a default, an allowed range and a line of documentation in `SCHEMA`. The
packaged ``fecheck/scenes/baseline.toml`` documents every key with comments.

>>> scene = load_scene(overrides=["contact.poisson=0.4"])
>>> scene["contact.poisson"], scene["contact.law"]
(0.4, 'ef')
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import tomllib

from fecheck.errors import FecheckError
from fecheck.knee import PRESETS, Knee, knee_from_landmarks

DOF_NAMES = ("x", "y", "z", "abduction", "internal")
LIGAMENT_NAMES = ("ACL", "PCL", "MCL")
MODEL_KINDS = ("rigid", "sphere-plane", "sphere-tibia", "femur-tibia")


@dataclass(frozen=True)
class Key:
    """One scene key: kind ("int", "float", "bool", "str", "vec3", "pair", "strings",
    "table", "matrix"), default, allowed choices or numeric bounds, and documentation.
    Numbers must be finite unless `allow_inf` (then +inf is allowed, e.g. a rigid body)."""

    kind: str
    default: Any
    doc: str
    choices: tuple = ()
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    allow_inf: bool = False


def _lig(name: str, stiffness_N: float, reference_strain: float) -> dict[str, Key]:
    return {
        f"ligaments.{name}.stiffness_N": Key(
            "float", stiffness_N, f"{name} spring stiffness, N per unit strain", low=0.0),
        f"ligaments.{name}.reference_strain": Key(
            "float", reference_strain, f"{name} strain at the reference pose", low=-0.5,
            high=1.0),
    }


# Spring defaults: Lenhart et al. 2015 (J. Biomech. Eng. 137, 081006), as shipped in
# /work/shared/data/knee/lenhart2015/ligaments.json: per ligament the sum of its bundles'
# Blankevoort1991Ligament linear stiffnesses (MCL 16 x 500 N, ACL 12 x 820 N,
# PCL 5 x 900 + 5 x 300 N) and the mean of its bundles' strains at rest.
SCHEMA: dict[str, Key] = {
    "name": Key("str", "", "free-text scene name"),
    "gravity": Key("bool", True, "apply the tibia's weight (tibia.mass_kg · 9.81 N, -z)"),
    "model.kind": Key("str", "sphere-plane", "model: rigid (point contacts, linear statics) "
                      "or sphere-plane (meshed condyles on plateaus)", choices=MODEL_KINDS),
    "mesh.sphere_subdivisions": Key("int", 4, "icosphere level: 20·4^n faces per condyle",
                                    low=0, high=7),
    "mesh.method": Key("str", "gmsh", "icosphere builder", choices=("gmsh", "trimesh")),
    "mesh.plateau_radius_mm": Key("float", 14.0, "contact.master = condyle: radius of the "
                                  "meshed plateau disc around each contact point, mm",
                                  low=1.0, high=100.0),
    "mesh.plateau_size_mm": Key("float", 2.0, "plateau element size away from the contact, mm",
                                low=0.01, high=20.0),
    "mesh.plateau_refine_mm": Key("float", 0.8, "plateau element size under the contact, mm",
                                  low=0.01, high=20.0),
    "mesh.plateau_refine_radius_mm": Key("float", 9.0, "radius of the refined zone, mm",
                                         low=0.0, high=100.0),
    "knee.preset": Key("str", "baseline-right", "landmarks: thesis Table B.1, Table B.3 or "
                       "custom (knee.side + knee.landmarks)",
                       choices=tuple(PRESETS) + ("custom",)),
    "knee.side": Key("str", "right", "custom knee side", choices=("right", "left")),
    "knee.landmarks": Key("table", None, "custom landmarks (see fecheck.knee)"),
    "plateau.kind": Key("str", "transverse", "tibial plateau: transverse planes, inclined "
                        "planes, or z = f(x, y) polynomials",
                        choices=("transverse", "inclined", "polynomial")),
    "plateau.medial_angles_deg": Key("pair", [-0.36, -5.93], "medial plane slopes (λ sagittal, "
                                     "γ frontal), deg, thesis Table 2.1 without outliers"),
    "plateau.lateral_angles_deg": Key("pair", [-0.34, 9.82], "lateral plane (λ, γ)"),
    "plateau.medial_coefficients": Key("matrix", None, "medial z = Σ c[i][j] x^i y^j, "
                                       "tibia frame, mm"),
    "plateau.lateral_coefficients": Key("matrix", None, "lateral z = Σ c[i][j] x^i y^j"),
    "contact.law": Key("str", "ef", "contact law", choices=("ef", "hertz", "volumetric",
                                                            "blankevoort")),
    "contact.area": Key("str", "clipped", "in-contact area of a face: clipped at zero depth "
                        "(exact) or the whole face (thesis)", choices=("clipped", "whole-face")),
    "contact.master": Key("str", "condyle", "analytic master: plateau (plane master, "
                          "icosphere slave) or condyle (sphere master, meshed plateau slave)",
                          choices=("plateau", "condyle")),
    "contact.detection": Key("str", "auto", "detection method",
                             choices=("auto", "closed-form", "bvh", "ray-parity", "fcl")),
    "contact.margin_mm": Key("float", 2.0, "broad-phase margin, mm", low=0.0),
    "contact.youngs_MPa": Key("float", 20.0, "cartilage Young's modulus, MPa", low=0.0,
                              low_open=True),
    "contact.poisson": Key("float", 0.3, "cartilage Poisson's ratio", low=0.0, high=0.5,
                           high_open=True),
    "contact.thickness_mm": Key("float", 6.0, "cartilage thickness h, mm", low=0.0,
                                low_open=True),
    "contact.volumetric_stiffness_N_per_mm3": Key(
        "float", 1e-2, "volumetric k_V, N/mm³ (thesis 1e7 N/m³ = 1e-2 N/mm³)", low=0.0,
        low_open=True),
    "contact.indenter_youngs_MPa": Key("float", math.inf, "Hertz: indenter modulus, MPa "
                                       "(inf = rigid)", low=0.0, low_open=True,
                                       allow_inf=True),
    "contact.indenter_poisson": Key("float", 0.3, "Hertz: indenter Poisson's ratio",
                                    low=0.0, high=0.5, high_open=True),
    "load.force_N": Key("float", 800.0, "external load magnitude, N", low=0.0),
    "load.point_mm": Key("vec3", [7.9, 12.8, -380.0], "load point in the tibia frame, mm "
                         "(x = +7.9: see DESIGN §4, the thesis prints -7.9 in error)"),
    "load.frame": Key("str", "world", "the load point is fixed in the world (line of action "
                      "fixed, e.g. a ground reaction) or moves with the tibia",
                      choices=("world", "tibia")),
    "load.direction": Key("vec3", [0.0, 0.0, 1.0], "load direction (normalised), world"),
    "tibia.mass_kg": Key("float", 2.0, "tibia mass, kg", low=0.0),
    "tibia.com_mm": Key("vec3", [0.0, 12.8, -190.0], "tibia centre of mass, tibia frame, mm"),
    "ligaments.model": Key("str", "none", "ligaments: none, rods of constant length "
                           "(Lagrange multipliers) or Blankevoort 1991 springs",
                           choices=("none", "rod", "spring")),
    "ligaments.transition_strain": Key("float", 0.06, "spring: 2ε_l, end of the toe region",
                                       low=0.0, low_open=True, high=1.0),
    **_lig("ACL", 9840.0, -0.0708),
    **_lig("PCL", 6000.0, -0.057),
    **_lig("MCL", 8000.0, 0.0289),
    "dofs.free": Key("strings", ["z", "abduction"], "free tibia DOFs (others driven)",
                     choices=DOF_NAMES),
    "dofs.x_mm": Key("float", 0.0, "tibia x: driven value or start, mm"),
    "dofs.y_mm": Key("float", 0.0, "tibia y, mm"),
    "dofs.z_mm": Key("float", 0.0, "tibia z, mm"),
    "dofs.abduction_deg": Key("float", 0.0, "θy, deg", low=-45.0, high=45.0),
    "dofs.internal_deg": Key("float", 0.0, "θz, deg", low=-45.0, high=45.0),
    "dofs.flexion_deg": Key("float", 0.0, "θx (always driven), deg", low=-45.0, high=45.0),
    "constraints.equal_forces": Key("bool", False, "constrain medial force = lateral force"),
    "solver.start_gap_mm": Key("float", 0.0, "start with the tibia this far below the "
                               "reference pose, mm", low=0.0, high=50.0),
    "solver.max_iterations": Key("int", 60, "Newton iteration cap", low=1, high=1000),
    "solver.tolerance": Key("float", 1e-8, "residual tolerance relative to the load",
                            low=0.0, low_open=True, high=1e-2),
    # Scanned knee (fecheck.scanned, fecheck.scanned_models): sphere-tibia, femur-tibia.
    "scanned.data_dir": Key("str", "", "scanned knee folder; '' = $FECHECK_KNEE_DIR or "
                            "<repo>/../shared/data/knee/lenhart2015"),
    "scanned.thickness": Key("str", "uniform", "sphere-tibia/femur-tibia foundation "
                             "thickness: contact.thickness_mm, or per face the tibial + "
                             "femoral cartilage to bone",
                             choices=("uniform", "bone-distance")),
    "scanned.decimate_faces": Key("int", 0, "sphere-tibia/femur-tibia: 0 = full meshes, "
                                  "N = about N tibial faces",
                                  low=0),
    "scanned.condyle": Key("str", "sphere", "sphere-tibia condyles: spheres or hemispheres "
                           "cut towards the notch", choices=("sphere", "hemisphere")),
    "scanned.hemisphere_cut_mm": Key("float", 10.0, "hemisphere cut: distance of the "
                                     "sagittal cut plane from the centre towards the notch, mm",
                                     low=0.0),
    "scanned.ligaments": Key("str", "none", "the scanned knee's 55 Blankevoort bundles as "
                             "springs (any contact model)", choices=("none", "bundles")),
    # FE cross-check (fecheck.fe, `fecheck fe`).
    "fe.size_mm": Key("float", 1.5, "3D FE element size under the contact, mm", low=0.05,
                      high=10.0),
    "fe.far_size_mm": Key("float", 5.0, "3D FE element size away from the contact, mm",
                          low=0.1, high=20.0),
    "fe.half_extent_mm": Key("float", 30.0, "FE layer half-extent (disc radius), mm",
                             low=1.0, high=200.0),
    "fe.footprint": Key("str", "ellipse", "FE layer outline", choices=("ellipse", "rectangle")),
    "fe.gap": Key("str", "reference", "FE contact gap: vertical in the reference or the "
                  "deformed configuration", choices=("reference", "deformed")),
    "fe.solver": Key("str", "cholmod", "FE sparse factorization",
                     choices=("cholmod", "superlu")),
    "fe.axisym_size_mm": Key("float", 0.1, "axisymmetric FE element size under the contact, mm",
                             low=0.005, high=2.0),
}


@dataclass(frozen=True)
class Scene:
    """A validated scene: `values` maps every dotted key of `SCHEMA` to its value."""

    values: Mapping[str, Any]
    source: str

    def __getitem__(self, key: str) -> Any:
        return self.values[key]

    @property
    def knee(self) -> Knee:
        """The knee landmarks of this scene."""
        if self["knee.preset"] == "custom":
            if self["knee.landmarks"] is None:
                raise FecheckError("knee.preset = 'custom' needs a [knee.landmarks] table")
            return knee_from_landmarks(self["knee.side"], self["knee.landmarks"])
        return PRESETS[self["knee.preset"]]

    @property
    def free_dofs(self) -> tuple[str, ...]:
        """Free tibia DOFs in the canonical order x, y, z, abduction, internal."""
        return tuple(d for d in DOF_NAMES if d in self["dofs.free"])


def packaged_scene_path(name: str = "baseline") -> Path:
    """Path of a scene shipped in `fecheck/scenes`."""
    return Path(str(resources.files("fecheck") / "scenes" / f"{name}.toml"))


def _flatten(data: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in data.items():
        key = f"{prefix}{k}"
        if isinstance(v, Mapping) and SCHEMA.get(key, Key("", None, "")).kind != "table":
            out.update(_flatten(v, key + "."))
        else:
            out[key] = v
    return out


def _unknown(key: str, source: str) -> FecheckError:
    close = difflib.get_close_matches(key, SCHEMA, n=1, cutoff=0.5)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    return FecheckError(f"{source}: unknown scene key {key!r}{hint}")


def _finite(key: str, x: Any, source: str, allow_inf: bool = False) -> float:
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        raise FecheckError(f"{source}: {key} must be a number, got {x!r}")
    if math.isnan(x):
        raise FecheckError(f"{source}: {key} is NaN; give a number")
    if math.isinf(x) and not (allow_inf and x > 0):
        raise FecheckError(f"{source}: {key} is infinite ({x!r}); give a finite number")
    return float(x)


def _check(key: str, value: Any, source: str) -> Any:
    spec = SCHEMA[key]
    kind = spec.kind
    if kind == "bool":
        if not isinstance(value, bool):
            raise FecheckError(f"{source}: {key} must be true or false, got {value!r}")
        return value
    if kind == "str":
        if not isinstance(value, str):
            raise FecheckError(f"{source}: {key} must be a string, got {value!r}")
        if spec.choices and value not in spec.choices:
            raise FecheckError(f"{source}: {key} = {value!r} is not one of "
                               f"{', '.join(spec.choices)}")
        return value
    if kind == "strings":
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise FecheckError(f"{source}: {key} must be a list of strings, got {value!r}")
        bad = [v for v in value if v not in spec.choices]
        if bad:
            raise FecheckError(f"{source}: {key} has {bad}; allowed: {', '.join(spec.choices)}")
        return list(value)
    if kind == "table":
        if not isinstance(value, Mapping):
            raise FecheckError(f"{source}: {key} must be a table")
        return value
    if kind in ("vec3", "pair"):
        n = 3 if kind == "vec3" else 2
        if not isinstance(value, list) or len(value) != n:
            raise FecheckError(f"{source}: {key} must be a list of {n} numbers, got {value!r}")
        return [_finite(key, v, source) for v in value]
    if kind == "matrix":
        if not isinstance(value, list) or not value or not all(
                isinstance(r, list) and len(r) == len(value[0]) for r in value):
            raise FecheckError(f"{source}: {key} must be a rectangular list of lists "
                               f"(c[i][j] multiplies x^i y^j)")
        return [[_finite(key, v, source) for v in r] for r in value]
    if kind == "int" and (isinstance(value, bool) or not isinstance(value, int)):
        raise FecheckError(f"{source}: {key} must be an integer, got {value!r}")
    x = _finite(key, value, source, spec.allow_inf) if kind == "float" else value
    lo_bad = spec.low is not None and (x < spec.low or (spec.low_open and x == spec.low))
    hi_bad = spec.high is not None and (x > spec.high or (spec.high_open and x == spec.high))
    if lo_bad or hi_bad:
        lo = "" if spec.low is None else ("> " if spec.low_open else ">= ") + f"{spec.low:g}"
        hi = "" if spec.high is None else ("< " if spec.high_open else "<= ") + f"{spec.high:g}"
        extra = (" (EF stiffness diverges as ν → 0.5)" if key.endswith("poisson") else "")
        raise FecheckError(f"{source}: {key} = {value!r} is out of range; it must be "
                           f"{' and '.join(s for s in (lo, hi) if s)}{extra}")
    return x


def parse_override(text: str) -> tuple[str, Any]:
    """``"contact.poisson=0.4"`` → ``("contact.poisson", 0.4)``; values are TOML literals,
    and a bare word that is not one is taken as a string (``contact.law=hertz``)."""
    key, sep, raw = text.partition("=")
    key, raw = key.strip(), raw.strip()
    if not sep or not key:
        raise FecheckError(f"--set {text!r}: expected KEY=VALUE, e.g. contact.poisson=0.4")
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    return key, value


def validate(data: Mapping[str, Any], source: str = "scene") -> Scene:
    """Check a nested scene mapping against `SCHEMA`; fill defaults; return the `Scene`."""
    flat = _flatten(data)
    values = {k: spec.default for k, spec in SCHEMA.items()}
    for key, value in flat.items():
        if key not in SCHEMA:
            raise _unknown(key, source)
        values[key] = _check(key, value, source)
    scene = Scene(values, source)
    _ = scene.knee                               # validates custom landmarks
    if scene["plateau.kind"] == "polynomial":
        for c in ("medial", "lateral"):
            if scene[f"plateau.{c}_coefficients"] is None:
                raise FecheckError(f"{source}: plateau.kind = 'polynomial' needs "
                                   f"plateau.{c}_coefficients")
    if scene["load.force_N"] > 0 and not any(scene["load.direction"]):
        raise FecheckError(f"{source}: load.direction must not be the zero vector")
    return scene


def load_scene(path: str | Path | None = None, overrides: Sequence[str] = ()) -> Scene:
    """Read and validate a scene TOML file (None → the packaged baseline).

    `overrides` are ``KEY=VALUE`` strings (``--set``) applied before validation.
    Raises `FecheckError` naming the file or key on any problem.
    """
    path = packaged_scene_path() if path is None else Path(path)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise FecheckError(f"scene file not found: {path}") from None
    except OSError as err:
        raise FecheckError(f"cannot read scene file {path}: {err.strerror}") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise FecheckError(f"{path}: not valid TOML: {err}") from None
    return apply_overrides(validate(data, str(path)), overrides)


def apply_overrides(scene: Scene, overrides: Sequence[str]) -> Scene:
    """A copy of `scene` with ``KEY=VALUE`` overrides applied and validated."""
    if not overrides:
        return scene
    values = dict(scene.values)
    for text in overrides:
        key, value = parse_override(text)
        if key not in SCHEMA:
            raise _unknown(key, "--set")
        values[key] = _check(key, value, "--set")
    return validate(_nest(values), scene.source)


def with_values(scene: Scene, **dotted: Any) -> Scene:
    """A copy of `scene` with some keys replaced (dotted keys, '.' written as '__')."""
    values = dict(scene.values)
    for k, v in dotted.items():
        values[k.replace("__", ".")] = v
    return validate(_nest(values), scene.source)


def _nest(values: Mapping[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in values.items():
        if value is None:
            continue
        node = out
        *head, last = key.split(".")
        for part in head:
            node = node.setdefault(part, {})
        node[last] = value
    return out
