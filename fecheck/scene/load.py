"""Scenes: TOML files describing one knee-contact problem, validated on load.

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
from fecheck.scene.constants import COMPARTMENTS, DOF_NAMES
from fecheck.scene.knee import PRESETS, Knee, knee_from_landmarks
from fecheck.scene.schema import SCHEMA, Key


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


def _check_bool(key: str, spec: Key, value: Any, source: str) -> bool:
    if not isinstance(value, bool):
        raise FecheckError(f"{source}: {key} must be true or false, got {value!r}")
    return value


def _check_str(key: str, spec: Key, value: Any, source: str) -> str:
    if not isinstance(value, str):
        raise FecheckError(f"{source}: {key} must be a string, got {value!r}")
    if spec.choices and value not in spec.choices:
        raise FecheckError(f"{source}: {key} = {value!r} is not one of "
                           f"{', '.join(spec.choices)}")
    return value


def _check_strings(key: str, spec: Key, value: Any, source: str) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise FecheckError(f"{source}: {key} must be a list of strings, got {value!r}")
    bad = [v for v in value if v not in spec.choices]
    if bad:
        raise FecheckError(f"{source}: {key} has {bad}; allowed: {', '.join(spec.choices)}")
    return list(value)


def _check_table(key: str, spec: Key, value: Any, source: str) -> Mapping:
    if not isinstance(value, Mapping):
        raise FecheckError(f"{source}: {key} must be a table")
    return value


def _check_vector(key: str, spec: Key, value: Any, source: str) -> list[float]:
    n = 3 if spec.kind == "vec3" else 2
    if not isinstance(value, list) or len(value) != n:
        raise FecheckError(f"{source}: {key} must be a list of {n} numbers, got {value!r}")
    return [_finite(key, v, source) for v in value]


def _check_matrix(key: str, spec: Key, value: Any, source: str) -> list[list[float]]:
    if not isinstance(value, list) or not value or not all(
            isinstance(r, list) and len(r) == len(value[0]) for r in value):
        raise FecheckError(f"{source}: {key} must be a rectangular list of lists "
                           f"(c[i][j] multiplies x^i y^j)")
    return [[_finite(key, v, source) for v in r] for r in value]


def _check_number(key: str, spec: Key, value: Any, source: str) -> float | int:
    if spec.kind == "int" and (isinstance(value, bool) or not isinstance(value, int)):
        raise FecheckError(f"{source}: {key} must be an integer, got {value!r}")
    x = _finite(key, value, source, spec.allow_inf) if spec.kind == "float" else value
    lo_bad = spec.low is not None and (x < spec.low or (spec.low_open and x == spec.low))
    hi_bad = spec.high is not None and (x > spec.high or (spec.high_open and x == spec.high))
    if lo_bad or hi_bad:
        lo = "" if spec.low is None else ("> " if spec.low_open else ">= ") + f"{spec.low:g}"
        hi = "" if spec.high is None else ("< " if spec.high_open else "<= ") + f"{spec.high:g}"
        extra = (" (EF stiffness diverges as ν → 0.5)" if key.endswith("poisson") else "")
        raise FecheckError(f"{source}: {key} = {value!r} is out of range; it must be "
                           f"{' and '.join(s for s in (lo, hi) if s)}{extra}")
    return x


_CHECKS = {"bool": _check_bool, "str": _check_str, "strings": _check_strings,
           "table": _check_table, "vec3": _check_vector, "pair": _check_vector,
           "matrix": _check_matrix, "int": _check_number, "float": _check_number}
"""Key kind → its checker (key, spec, value, source) → the validated value."""


def _check(key: str, value: Any, source: str) -> Any:
    spec = SCHEMA[key]
    return _CHECKS[spec.kind](key, spec, value, source)


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
        for c in COMPARTMENTS:
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
