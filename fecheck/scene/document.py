"""Documents generated from the scene schema: the key list and documented scene files.

`scene_document` renders a scene's values as TOML with each key's documentation as a
comment, in sections; the packaged ``fecheck/scenes/baseline.toml`` is
`baseline_document()` (``fecheck keys --format toml``). `keys_text` and `keys_markdown`
list the keys with kind, unit, default and allowed values (``fecheck keys``,
``docs/scene-keys.md``).

>>> print(keys_text("contact.poisson"))
contact.poisson  float, dimensionless; default 0.3; allowed 0 <= value < 0.5
    Poisson's ratio ν of the cartilage, dimensionless, below 0.5 (the EF stiffness
    diverges as ν → 0.5).
"""

from __future__ import annotations

import json
import math
import textwrap
from collections.abc import Iterable, Mapping
from typing import Any

from fecheck.errors import FecheckError
from fecheck.scene.schema import SCHEMA, SECTIONS, Key, section_of, unit_of

WIDTH = 88
"""Line width of the generated comments and text."""

BASELINE_HEADER = """\
fecheck baseline scene: thesis §5.2.1 / Table 5.3 (Table B.1 knee, 800 N, E 20 MPa, ν 0.3,
h 6 mm): the elastic-foundation sphere-plane model of the baseline right knee, no ligaments.
Units: mm, N, MPa, kg, degrees. Frame: origin at the tibial plateau centre, x to the
subject's right, y anterior, z superior.
Every scene key is written below with its default value (the name excepted); all are
optional. Override any with `fecheck run --set KEY=VALUE`, or start a scene of your own
from this file (`fecheck keys --format toml > my-scene.toml`). A key that has no effect in
a scene's configuration is reported with a warning when given.
Generated from the key documentation of fecheck/scene/schema.py (`fecheck keys`)."""
"""The comment at the top of the packaged baseline scene."""

BASELINE_NAME = "baseline"


def select_keys(prefix: str = "") -> list[str]:
    """The scene keys starting with `prefix` (all for ""), in schema order; `FecheckError`
    if none does."""
    keys = [k for k in SCHEMA if k.startswith(prefix)]
    if not keys:
        sections = ", ".join(s for s in SECTIONS if s)
        raise FecheckError(f"no scene key starts with {prefix!r}; the sections are "
                           f"{sections} (or give no prefix for every key)")
    return keys


def toml_value(value: Any) -> str:
    """A value as a TOML literal (inline): ``true``, ``0.3``, ``inf``, ``"ef"``, ``[1, 2]``."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        return ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, Mapping):
        return "{" + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + "}"
    return "[" + ", ".join(toml_value(v) for v in value) + "]"


def _bound(x: float) -> str:
    return f"{x:g}"


def allowed_text(spec: Key) -> str:
    """The values a key allows, in words: choices, numeric bounds or shape."""
    if spec.kind == "strings":
        return "any of " + ", ".join(spec.choices)
    if spec.choices:
        return "one of " + ", ".join(spec.choices)
    if spec.kind in ("int", "float"):
        return _range_text(spec)
    return {"bool": "true or false", "str": "any text", "vec3": "3 finite numbers",
            "pair": "2 finite numbers", "matrix": "rows of finite numbers, all of one length",
            "table": "tables of 3-coordinate points"}[spec.kind]


def _range_text(spec: Key) -> str:
    lo = None if spec.low is None else (_bound(spec.low), "<" if spec.low_open else "<=")
    hi = None if spec.high is None else (_bound(spec.high), "<" if spec.high_open else "<=")
    if lo and hi:
        text = f"{lo[0]} {lo[1]} value {hi[1]} {hi[0]}"
    elif lo:
        text = f"value {'>' if spec.low_open else '>='} {lo[0]}"
    elif hi:
        text = f"value {hi[1]} {hi[0]}"
    else:
        text = "any finite number" if spec.kind == "float" else "any integer"
    return text + (", or inf" if spec.allow_inf else "")


def default_text(key: str) -> str:
    """The default of a key as a TOML literal, or "not set"."""
    default = SCHEMA[key].default
    return "not set" if default is None else toml_value(default)


def _summary(key: str) -> str:
    spec = SCHEMA[key]
    unit = unit_of(key)
    kind = f"{spec.kind}, {unit}" if unit else spec.kind
    return f"{kind}; default {default_text(key)}; allowed {allowed_text(spec)}"


def keys_text(prefix: str = "") -> str:
    """Every key starting with `prefix`: a line of kind, unit, default and allowed values,
    then its documentation, indented."""
    blocks = []
    for key in select_keys(prefix):
        doc = textwrap.fill(SCHEMA[key].doc, WIDTH, initial_indent="    ",
                            subsequent_indent="    ")
        blocks.append(f"{key}  {_summary(key)}\n{doc}")
    return "\n".join(blocks)


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def keys_markdown(prefix: str = "") -> str:
    """The keys starting with `prefix` as Markdown: one table per section."""
    lines = ["# Scene keys", "", *textwrap.wrap(
        "Every key of a fecheck scene (TOML), generated from the scene schema by "
        "`fecheck keys --format markdown`; `fecheck keys` prints the same list. Units: mm, "
        "N, MPa, kg, degrees; frame: origin at the tibial plateau centre, x to the "
        "subject's right, y anterior, z superior. A scene file gives the keys in sections "
        "(`[contact]`, then `poisson = 0.4`); `fecheck run --set contact.poisson=0.4` "
        "overrides one. The packaged baseline scene (`fecheck/scenes/baseline.toml`, or "
        "`fecheck keys --format toml`) writes every key with its default. A key given "
        "where it has no effect (for example `mesh.sphere_subdivisions` when the condyles "
        "are exact spheres) is reported with a warning.", WIDTH, break_on_hyphens=False)]
    for section, keys in _by_section(select_keys(prefix)).items():
        title = f"`[{section}]` {SECTIONS[section]}" if section else "Top-level keys"
        lines += ["", f"## {title}", "",
                  "| key | kind | unit | default | allowed | description |",
                  "|---|---|---|---|---|---|"]
        for key in keys:
            spec = SCHEMA[key]
            lines.append("| " + " | ".join(_cell(c) for c in (
                f"`{key}`", spec.kind, unit_of(key) or "–", f"`{default_text(key)}`",
                allowed_text(spec), spec.doc)) + " |")
    return "\n".join(lines) + "\n"


def _by_section(keys: Iterable[str]) -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    for key in keys:
        out.setdefault(section_of(key), []).append(key)
    return out


def _comment(text: str) -> list[str]:
    return textwrap.wrap(text, WIDTH - 2, initial_indent="# ", subsequent_indent="# ",
                         break_on_hyphens=False)


def _key_lines(key: str, value: Any, section: str) -> list[str]:
    """The documentation comment and assignment of one key inside its section."""
    spec = SCHEMA[key]
    leaf = key[len(section) + 1:] if section else key
    lines = _comment(f"{spec.doc} Allowed: {allowed_text(spec)}.")
    if spec.kind == "table":
        example = value is None
        lines += ["# Not set. Example:"] if example else []
        for name, table in (spec.example if example else value).items():
            rows = [f"[{key}.{name}]"] + [f"{k} = {toml_value(v)}" for k, v in table.items()]
            lines += [f"# {r}" for r in rows] if example else rows
    elif value is None:
        lines.append(f"# Not set. Example: {leaf} = {toml_value(spec.example)}")
    else:
        lines.append(f"{leaf} = {toml_value(value)}")
    return lines


def scene_document(values: Mapping[str, Any], header: str = "",
                   keys: Iterable[str] | None = None) -> str:
    """A scene as documented TOML: `header` as a comment, then each key of `keys` (all
    by default) with its documentation as a comment above its value, in sections.

    `values` maps dotted keys to values (a `Scene`'s ``values``); a key whose value is
    None is written as a comment with an example. Table keys (``knee.landmarks``) are
    written last in their section, as sub-tables.
    """
    keys = list(SCHEMA if keys is None else keys)
    out = [line.rstrip() for line in textwrap.indent(header, "# ").splitlines()]
    for section, members in _by_section(keys).items():
        members.sort(key=lambda k: SCHEMA[k].kind == "table" and values[k] is not None)
        out.append("")
        if section:
            out += _comment(SECTIONS[section] + ".") + [f"[{section}]"]
        for key in members:
            out += _key_lines(key, values[key], section)
    return "\n".join(out).lstrip("\n") + "\n"


def baseline_values() -> dict[str, Any]:
    """The values of the packaged baseline scene: every default, named "baseline"."""
    return {k: spec.default for k, spec in SCHEMA.items()} | {"name": BASELINE_NAME}


def baseline_document(prefix: str = "") -> str:
    """The packaged baseline scene file (``fecheck/scenes/baseline.toml``), or the part of
    it holding the keys that start with `prefix`."""
    header = BASELINE_HEADER if not prefix else (
        f"fecheck scene keys starting with {prefix!r}, at their defaults (`fecheck keys`).")
    return scene_document(baseline_values(), header, select_keys(prefix))
