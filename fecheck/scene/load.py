"""Scenes: TOML files describing one knee-contact problem, validated on load.

Every problem with a scene file or an override raises `FecheckError` with a one-line
message naming the file or key and what to change. A key the user gave that has no
effect in the scene's configuration is reported by an `InertKeyWarning`
(`fecheck.scene.relevance`).

>>> scene = load_scene(overrides=["contact.poisson=0.4"])
>>> scene["contact.poisson"], scene["contact.law"]
(0.4, 'ef')
"""

from __future__ import annotations

import difflib
import math
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from importlib import resources
from pathlib import Path
from typing import Any

import tomllib

from fecheck.errors import FecheckError
from fecheck.scene.constants import COMPARTMENTS, DOF_NAMES
from fecheck.scene.knee import PRESETS, Knee, knee_from_landmarks
from fecheck.scene.packaged import PACKAGE_PREFIX, data_dir, resolve_scene
from fecheck.scene.relevance import InertKeyWarning, inert_keys, inert_message
from fecheck.scene.schema import SCHEMA, Key


@dataclass(frozen=True)
class Scene:
    """A validated scene: `values` maps every dotted key of `SCHEMA` to its value;
    `overrides` are the ``KEY=VALUE`` texts (``--set``) applied to the file's values."""

    values: Mapping[str, Any]
    source: str
    overrides: tuple[str, ...] = ()

    def __getitem__(self, key: str) -> Any:
        return self.values[key]

    @property
    def set_keys(self) -> tuple[str, ...]:
        """The keys `overrides` set, in order, each once."""
        return tuple(dict.fromkeys(parse_override(text)[0] for text in self.overrides))

    @property
    def label(self) -> str:
        """The name shown in reports and results: ``name`` (else the file), followed by
        the ``--set`` overrides when there are any (a modified scene is not its file)."""
        name = self["name"] or self.source
        if not self.overrides:
            return name
        return f"{name} (modified: " + ", ".join(self.overrides) + ")"

    @property
    def knee(self) -> Knee:
        """The knee landmarks of this scene (not for knee.preset = 'fit', whose spheres
        are fitted to its femoral surface: `fecheck.model.condyles.scene_knee`)."""
        if self["knee.preset"] == "fit":
            raise FecheckError("knee.preset = 'fit' gives condyle spheres only, fitted to the "
                               "femoral surface by the sphere-tibia model")
        if self["knee.preset"] == "custom":
            if self["knee.landmarks"] is None:
                raise FecheckError(f"knee.preset = 'custom' needs a [knee.landmarks] table "
                                   f"(model.kind = {self['model.kind']!r} reads the condyle "
                                   "spheres, contact points or ligament attachments)")
            return knee_from_landmarks(self["knee.side"], self["knee.landmarks"])
        return PRESETS[self["knee.preset"]]

    @property
    def side(self) -> str:
        """"right" or "left": knee.side for a custom knee or a model that reads no
        landmark (femur-tibia), else the preset's side."""
        if self["knee.preset"] in ("custom", "fit") or not needs_landmarks(self):
            return self["knee.side"]
        return self.knee.side

    @property
    def free_dofs(self) -> tuple[str, ...]:
        """Free tibia DOFs in the canonical order x, y, z, abduction, internal."""
        return tuple(d for d in DOF_NAMES if d in self["dofs.free"])


def packaged_scene_path(name: str = "baseline") -> Path:
    """Path of a scene shipped in `fecheck/scenes` (`fecheck.scene.packaged`)."""
    return Path(str(resources.files("fecheck") / "scenes" / f"{name}.toml"))


KEY_PREFIXES = frozenset(".".join(k.split(".")[:i]) for k in SCHEMA
                    for i in range(1, k.count(".") + 1))
"""Dotted prefixes of the scene keys (``contact``, ``ligaments.ACL``): tables, not values."""

KIND_TEXT = {"int": "an integer", "float": "a number", "bool": "true or false",
             "str": "a string", "vec3": "a list of 3 numbers", "pair": "a list of 2 numbers",
             "strings": "a list of strings", "table": "a table",
             "matrix": "a list of lists of numbers"}
"""Key kind → what a value of it is, for messages."""


def _flatten(data: Mapping[str, Any], source: str, prefix: str = "") -> dict[str, Any]:
    """Nested TOML tables → dotted keys; a table where a value belongs (or the reverse)
    raises `FecheckError`. Unknown keys pass through (`validate` names them)."""
    out: dict[str, Any] = {}
    for k, v in data.items():
        key = f"{prefix}{k}"
        kind = SCHEMA[key].kind if key in SCHEMA else None
        if isinstance(v, Mapping) and kind not in (None, "table"):
            raise FecheckError(f"{source}: {key} must be {KIND_TEXT[kind]}, got a table")
        if key in KEY_PREFIXES and not isinstance(v, Mapping):
            raise _section_as_value(key, source)
        if isinstance(v, Mapping) and kind is None:
            out.update(_flatten(v, source, key + "."))
        else:
            out[key] = v
    return out


def _section_as_value(key: str, source: str) -> FecheckError:
    example = next(k for k in SCHEMA if k.startswith(key + "."))
    return FecheckError(f"{source}: {key} is a section of keys, not a value; give one of its "
                        f"keys, e.g. {example} (`fecheck keys {key}` lists them)")


def _unknown(key: str, source: str) -> FecheckError:
    if key in KEY_PREFIXES:
        return _section_as_value(key, source)
    close = difflib.get_close_matches(key, SCHEMA, n=1, cutoff=0.5)
    hint = (f"; did you mean {close[0]!r}?" if close
            else "; `fecheck keys` lists the scene keys")
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
    """A table of tables of 3-vectors (``knee.landmarks``); which tables and entries it
    must give is checked where it is read (`fecheck.scene.knee.knee_from_landmarks`)."""
    if not isinstance(value, Mapping):
        raise FecheckError(f"{source}: {key} must be a table, got {value!r}")
    vec3 = Key("vec3", None, "")
    out = {}
    for name, table in value.items():
        if not isinstance(table, Mapping):
            raise FecheckError(f"{source}: {key}.{name} must be a table of 3-coordinate "
                               f"points (mm), got {table!r}")
        out[name] = {k: _check_vector(f"{key}.{name}.{k}", vec3, v, source)
                     for k, v in table.items()}
    return out


def _check_vector(key: str, spec: Key, value: Any, source: str) -> list[float]:
    n = 3 if spec.kind == "vec3" else 2
    if not isinstance(value, list) or len(value) != n:
        raise FecheckError(f"{source}: {key} must be a list of {n} numbers, got {value!r}")
    return [_finite(key, v, source) for v in value]


def _check_matrix(key: str, spec: Key, value: Any, source: str) -> list[list[float]]:
    if not isinstance(value, list) or not value or not value[0] or not all(
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


def validate(data: Mapping[str, Any], source: str = "scene", where: str = "") -> Scene:
    """Check a nested scene mapping against `SCHEMA`; fill defaults; return the `Scene`.

    Messages start with `where` (default: `source`, the file the scene came from).
    """
    where = where or source
    values = {k: spec.default for k, spec in SCHEMA.items()}
    for key, value in _flatten(data, where).items():
        if key not in SCHEMA:
            raise _unknown(key, where)
        values[key] = _check(key, value, where)
    scene = Scene(values, source)
    _check_consistent(scene, where)
    return scene


def needs_landmarks(scene: Scene) -> bool:
    """Whether the scene's model reads knee landmarks: every model but femur-tibia (its
    surfaces come from files) without the three-ligament model."""
    return scene["model.kind"] != "femur-tibia" or scene["ligaments.model"] != "none"


def _check_consistent(scene: Scene, source: str) -> None:
    """Rules across keys: custom landmarks, polynomial coefficients, load, free DOFs."""
    if scene["knee.preset"] == "fit":
        if scene["model.kind"] != "sphere-tibia" or scene["ligaments.model"] != "none":
            raise FecheckError(f"{source}: knee.preset = 'fit' fits the condyle spheres of the "
                               "sphere-tibia model and gives no ligament attachment: use it "
                               "with model.kind = 'sphere-tibia' and ligaments.model = 'none'")
    elif scene["knee.landmarks"] is not None or needs_landmarks(scene):
        try:
            _ = scene.knee                       # validates custom landmarks
        except FecheckError as err:
            raise FecheckError(f"{source}: {err}") from None
    if not scene["dofs.free"]:
        raise FecheckError(f"{source}: dofs.free is empty: at least one tibia DOF must be "
                           f"free to solve the equilibrium, e.g. dofs.free = ['z'] "
                           f"(allowed: {', '.join(DOF_NAMES)})")
    if scene["plateau.kind"] == "polynomial":
        for c in COMPARTMENTS:
            if scene[f"plateau.{c}_coefficients"] is None:
                raise FecheckError(f"{source}: plateau.kind = 'polynomial' needs "
                                   f"plateau.{c}_coefficients")
    if scene["load.force_N"] > 0 and not any(scene["load.direction"]):
        raise FecheckError(f"{source}: load.direction must not be the zero vector")
    if scene["geometry.dir"].startswith(PACKAGE_PREFIX):
        try:
            data_dir(scene["geometry.dir"])
        except FecheckError as err:
            raise FecheckError(f"{source}: {err}") from None


def _read_scene_file(path: Path) -> dict[str, Any]:
    """The parsed TOML of a scene file; `FecheckError` saying what is wrong with it."""
    if path.is_dir():
        raise FecheckError(f"{path} is a directory, not a scene file; give the path of a "
                           f"scene TOML file (or none for the packaged baseline scene)")
    if path.exists() and not path.is_file():
        raise FecheckError(f"{path} is not a regular file; give the path of a scene TOML file")
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise FecheckError(f"scene file not found: {path}; check the path (give none for "
                           f"the packaged baseline scene; `fecheck scenes` lists the packaged "
                           f"scenes by name)") from None
    except OSError as err:
        raise FecheckError(f"cannot read scene file {path}: {err.strerror}") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        raise FecheckError(f"{path} is not a text file (byte 0x{raw[err.start]:02x} at offset "
                           f"{err.start} is not UTF-8); a scene is a TOML text file, e.g. "
                           f"the output of `fecheck keys --format toml`") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise FecheckError(f"{path}: not valid TOML: {err}") from None
    if not data:
        what = "" if not text.strip() else " but for comments"
        raise FecheckError(f"scene {path} is empty{what}: it sets no key; give the keys "
                           f"that differ from the baseline (`fecheck keys --format toml` "
                           f"writes them all), or no scene file to run the baseline")
    return data


def load_scene(path: str | Path | None = None, overrides: Sequence[str] = ()) -> Scene:
    """Read and validate a scene TOML file (None → the packaged baseline; a name that is
    not an existing file → that packaged scene, `fecheck.scene.packaged.resolve_scene`).

    `overrides` are ``KEY=VALUE`` strings (``--set``) applied before validation.
    Raises `FecheckError` naming the file or key on any problem. Warns
    (`InertKeyWarning`, one warning per key) for each key the user gave that has no
    effect in the scene's configuration: every ``--set`` key, and the keys of the file
    whose value differs from the default (a file that writes out a default, like the
    packaged baseline, documents it rather than sets it).
    """
    path = packaged_scene_path() if path is None else resolve_scene(path)
    scene = validate(_read_scene_file(path), str(path))
    given = [k for k, v in scene.values.items() if v != SCHEMA[k].default]
    scene, keys = _overridden(scene, overrides)
    warn_inert(scene, given + keys)
    return scene


def warn_inert(scene: Scene, given_keys: Iterable[str]) -> None:
    """Warn (`InertKeyWarning`) for each of `given_keys` with no effect in `scene`."""
    for key, reason in inert_keys(scene, given_keys):
        warnings.warn(inert_message(key, reason), InertKeyWarning, stacklevel=3)


def apply_overrides(scene: Scene, overrides: Sequence[str]) -> Scene:
    """A copy of `scene` with ``KEY=VALUE`` overrides applied and validated (no warning
    for inert keys: `load_scene` gives those)."""
    return _overridden(scene, overrides)[0]


def _overridden(scene: Scene, overrides: Sequence[str]) -> tuple[Scene, list[str]]:
    """`scene` with ``KEY=VALUE`` overrides applied and validated, and the keys set.

    Only the keys set are checked again (the others were checked when `scene` was made),
    then the rules across keys: a sweep applies one override per point."""
    if not overrides:
        return scene, []
    values = dict(scene.values)
    keys = []
    for text in overrides:
        key, value = parse_override(text)
        if key not in SCHEMA:
            raise _unknown(key, "--set")
        values[key] = _check(key, value, "--set")
        keys.append(key)
    out = Scene(values, scene.source, scene.overrides + tuple(
        f"{key}={text.partition('=')[2].strip()}" for key, text in zip(keys, overrides,
                                                                       strict=True)))
    _check_consistent(out, f"--set on {scene.source}")
    return out, keys


def with_values(scene: Scene, **dotted: Any) -> Scene:
    """A copy of `scene` with some keys replaced (dotted keys, '.' written as '__')."""
    values = dict(scene.values)
    for k, v in dotted.items():
        values[k.replace("__", ".")] = v
    return replace(validate(_nest(values), scene.source), overrides=scene.overrides)


def scene_from_values(values: Mapping[str, Any], source: str, overrides: Sequence[str] = (),
                      where: str = "") -> Scene:
    """The scene of resolved dotted `values` (a recorded scene), validated again, with the
    ``--set`` texts that made it; messages start with `where`."""
    return replace(validate(_nest(values), source, where), overrides=tuple(overrides))


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
