"""The varied keys of a population study: ``KEY=DIST`` parsed, checked and turned into
scene overrides.

DIST is one of

* ``uniform:LO:HI`` — values from LO to HI (the key's units);
* ``normal:MEAN:SD`` — a normal distribution of the value;
* ``lognormal:MEAN:SD`` — a lognormal distribution whose value has that mean and
  standard deviation (not those of its logarithm);
* ``scale:LO:HI`` — a factor from LO to HI on the scene's own value; a vector key
  (``load.point_mm``) has every component scaled by the one factor.

A key may name one component of a vector key (``load.point_mm[0]``). A sample is a point
of the unit cube (one coordinate per varied key), mapped to values through each
distribution's inverse CDF. Tails are cut at `TAIL` and 1 − `TAIL`, so that every value
a study can draw is known before it runs: those extremes are checked against the scene
(its allowed ranges and its consistency rules) before the first solve.

>>> d = parse_distribution("uniform:10:30")
>>> float(d.value(0.25, 20.0))
15.0
>>> float(parse_distribution("scale:0.8:1.2").value(0.5, 6.0))
6.0
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from fecheck.errors import FecheckError
from fecheck.scene import SCHEMA, Scene, apply_overrides
from fecheck.scene.schema import unit_of

TAIL = 1e-6
"""Probability cut from each tail of the normal and lognormal distributions: the values a
study can draw lie between the quantiles TAIL and 1 − TAIL (±4.75 SD for a normal)."""

KINDS = ("uniform", "normal", "lognormal", "scale")
_VECTOR_KINDS = ("vec3", "pair")
_INDEXED = re.compile(r"^(?P<key>[\w.]+)\[(?P<index>\d+)\]$")


@dataclass(frozen=True)
class Distribution:
    """One ``KIND:A:B`` distribution (`KINDS`); `a`, `b` are LO, HI or MEAN, SD."""

    kind: str
    a: float
    b: float

    def value(self, u: np.ndarray | float, nominal: float | np.ndarray) -> np.ndarray:
        """The value(s) at unit-cube coordinate(s) `u` (normal tails cut at `TAIL`; LO and
        HI themselves at u = 0 and 1); `nominal`: the scene's value (``scale`` only)."""
        u = np.asarray(u, dtype=float)
        if self.kind == "uniform":
            return self.a + u * (self.b - self.a)
        if self.kind == "scale":
            return np.multiply.outer(self.a + u * (self.b - self.a), nominal)
        from scipy.special import ndtri

        u = np.clip(u, TAIL, 1.0 - TAIL)

        z = ndtri(u)
        if self.kind == "normal":
            return self.a + self.b * z
        sigma2 = math.log1p((self.b / self.a) ** 2)
        return np.exp(math.log(self.a) - 0.5 * sigma2 + math.sqrt(sigma2) * z)

    def text(self) -> str:
        """``KIND:A:B`` as given (numbers in short form)."""
        return f"{self.kind}:{self.a:g}:{self.b:g}"


def parse_distribution(text: str) -> Distribution:
    """``KIND:A:B`` → `Distribution`; `FecheckError` saying the accepted forms."""
    forms = ("uniform:LO:HI, normal:MEAN:SD, lognormal:MEAN:SD (of the value) or "
             "scale:LO:HI (a factor on the scene's value)")
    parts = text.split(":")
    if len(parts) != 3 or parts[0] not in KINDS:
        raise FecheckError(f"distribution {text!r}: expected {forms}")
    try:
        a, b = float(parts[1]), float(parts[2])
    except ValueError:
        raise FecheckError(f"distribution {text!r}: expected {forms}") from None
    kind = parts[0]
    if not (math.isfinite(a) and math.isfinite(b)):
        raise FecheckError(f"distribution {text!r}: give finite numbers")
    if kind in ("uniform", "scale") and not a < b:
        raise FecheckError(f"distribution {text!r}: LO must be below HI")
    if kind in ("normal", "lognormal") and not b > 0.0:
        raise FecheckError(f"distribution {text!r}: the standard deviation must be positive")
    if kind == "lognormal" and not a > 0.0:
        raise FecheckError(f"distribution {text!r}: a lognormal value has a positive mean")
    return Distribution(kind, a, b)


@dataclass(frozen=True)
class Varied:
    """One varied key: `name` as given (``key`` or ``key[i]``), the scene `key`, the
    component `index` (None for the whole key), its distribution and its scene value."""

    name: str
    key: str
    index: int | None
    dist: Distribution
    nominal: float | tuple[float, ...]

    @property
    def unit(self) -> str:
        """The key's unit (``scale`` of a vector: the factor, dimensionless)."""
        return "factor" if self.vector_scaled else unit_of(self.key)

    @property
    def vector_scaled(self) -> bool:
        """True when one factor scales every component of a vector key."""
        return isinstance(self.nominal, tuple)

    def column(self) -> str:
        """The CSV column of the drawn values (the factor for a scaled vector)."""
        return f"{self.name} (factor)" if self.vector_scaled else self.name

    def drawn(self, u: np.ndarray) -> np.ndarray:
        """The values to report for unit coordinates `u` (n,): the key's values, or the
        factors of a scaled vector key."""
        if self.vector_scaled:
            return Distribution("uniform", self.dist.a, self.dist.b).value(u, 0.0)
        return self.dist.value(u, self.nominal)


def parse_vary(text: str, scene: Scene) -> Varied:
    """``KEY=DIST`` → `Varied`, checked against the schema and `scene`."""
    name, sep, dist_text = text.partition("=")
    name = name.strip()
    if not sep:
        raise FecheckError(f"--vary {text!r}: expected KEY=DIST, e.g. "
                           "contact.youngs_MPa=uniform:10:30")
    match = _INDEXED.match(name)
    key = match["key"] if match else name
    if key not in SCHEMA:
        raise FecheckError(f"--vary {name}: unknown scene key {key!r} (`fecheck keys` "
                           "lists them)")
    try:
        dist = parse_distribution(dist_text.strip())
    except FecheckError as err:
        raise FecheckError(f"--vary {name}: {err}") from None
    kind = SCHEMA[key].kind
    if match:
        if kind not in _VECTOR_KINDS:
            raise FecheckError(f"--vary {name}: {key} is a {kind}, not a vector")
        values = scene[key]
        index = int(match["index"])
        if values is None or index >= len(values):
            raise FecheckError(f"--vary {name}: {key} has {0 if values is None else len(values)}"
                               " components")
        return Varied(name, key, index, dist, float(values[index]))
    if kind in _VECTOR_KINDS:
        if dist.kind != "scale" or scene[key] is None:
            raise FecheckError(f"--vary {name}: a vector key takes scale:LO:HI (one factor "
                               f"on every component) or one component, {key}[i]")
        return Varied(name, key, None, dist, tuple(float(v) for v in scene[key]))
    if kind != "float":
        raise FecheckError(f"--vary {name}: populations vary real-valued keys; {key} is "
                           f"a {kind}")
    if scene[key] is None and dist.kind == "scale":
        raise FecheckError(f"--vary {name}: scale needs a value; {key} is unset in the scene")
    return Varied(name, key, None, dist, float(scene[key]) if scene[key] is not None else 0.0)


def parse_varied(texts: Sequence[str], scene: Scene) -> list[Varied]:
    """Every ``--vary``; a key given twice (or whole and by component) is refused."""
    varied = [parse_vary(t, scene) for t in texts]
    names = [v.name for v in varied]
    whole = {v.key for v in varied if v.index is None}
    for v in varied:
        if names.count(v.name) > 1 or (v.index is not None and v.key in whole):
            raise FecheckError(f"--vary {v.name}: {v.key} is varied twice")
    return varied


def _number(value: float) -> str:
    """A float as a TOML literal (repr keeps every digit)."""
    return repr(float(value))


def overrides_for(varied: Sequence[Varied], scene: Scene, u: np.ndarray,
                  fraction: float = 1.0) -> list[tuple[str, ...]]:
    """The ``KEY=VALUE`` overrides of each sample: `u` (n, len(varied)) unit coordinates.
    Components of one vector key are set in one override. A `fraction` below 1 moves
    each value only that far from the scene's value towards the sample's (a path from
    the scene to the sample, for a continuation of its equilibrium)."""
    n = u.shape[0]
    columns = {}
    for j, v in enumerate(varied):
        nominal = np.asarray(v.nominal)
        value = v.dist.value(u[:, j], nominal)
        columns[j] = value if fraction == 1.0 else nominal + fraction * (value - nominal)
    out: list[tuple[str, ...]] = []
    for i in range(n):
        vectors: dict[str, list[float]] = {}
        items = []
        for j, v in enumerate(varied):
            value = columns[j][i]
            if v.index is not None:
                vec = vectors.setdefault(v.key, [float(x) for x in scene[v.key]])
                vec[v.index] = float(value)
            elif v.vector_scaled:
                items.append(f"{v.key}=[{', '.join(_number(x) for x in value)}]")
            else:
                items.append(f"{v.key}={_number(value)}")
        items += [f"{k}=[{', '.join(_number(x) for x in vec)}]" for k, vec in vectors.items()]
        out.append(tuple(items))
    return out


def check_ranges(varied: Sequence[Varied], scene: Scene) -> None:
    """Check that every value each distribution can draw is accepted by the scene: its
    two extremes (tails cut at `TAIL`), each with the other keys at the scene's values.

    Raises
    ------
    FecheckError
        Naming the key, its distribution, the extreme and the scene's reason.
    """
    for v in varied:
        for edge in (0.0, 1.0):
            override = overrides_for([v], scene, np.array([[edge]]))[0]
            try:
                apply_overrides(scene, list(override))
            except FecheckError as err:
                drawn = float(v.drawn(np.array([edge]))[0])
                reason = re.sub(r"^--set( on [^:]*)?: ", "", str(err))
                what = "factor" if v.vector_scaled else "value"
                raise FecheckError(f"--vary {v.name}={v.dist.text()}: draws a {what} of "
                                   f"{drawn:.6g}, outside what the scene accepts ({reason}); "
                                   "narrow the distribution") from None
