"""Size guards: the elements and memory a mesh build will need, from its parameters alone,
checked against this machine's memory before any meshing starts.

Counts (an element of size s, mm):

- triangles of a surface of area A meshed at size s: ``TRIANGLE_FILL · A / (√3/4 · s²)``
  (the equilateral triangle of edge s has area √3/4·s²);
- tetrahedra of a volume V at size s: ``TET_FILL · V / (s³ / (6√2))`` (the regular
  tetrahedron of edge s has volume s³/(6√2));
- a refined zone (element size ``fine`` within ``inner`` mm of a point or a circle, growing
  linearly to the global size at ``outer`` mm) adds ∫ m(d) (1/v(s(d)) − 1/v(size)) dd over
  the distance d, with m(d) the measure of the domain at distance d (its area for
  volumes, its length for surfaces), clipped to the whole domain;
- an icosphere of level n: exactly 20·4^n triangles.

Memory is the count times the measured peak bytes per element (`BYTES_PER_ELEMENT`).

Two limits, checked by `guard`: an estimate beyond the memory this machine has available
(``MemAvailable``) is refused, always; an estimate beyond its element limit (`MAX_ELEMENTS`:
memory still fits, but the build takes minutes) is refused unless the caller runs it inside
``policy(force=True)`` (``--force`` on the command line). Both refusals are one-line
`FecheckError` naming the builder, the estimate, the limit and the size key to change,
with the value that fits. Callers name their keys with `policy` (``--size`` on the
command line, ``mesh.plateau_size_mm`` in a scene); without it the messages use the
builders' own parameter names.

>>> round(tetrahedra(1000.0, 1.0))         # a 10 mm cube at 1 mm: 0.5 · 1000 · 6√2
4243
>>> icosphere_estimate(3).count
1280.0
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field

import numpy as np

from geometry.errors import FecheckError

TET_FILL = 0.5
"""Gmsh tetrahedra per regular tetrahedron's volume at the same size: measured 0.48
(size 0.5 mm), 0.50 (1 mm), 0.54 (1.5 mm), 0.55 (2 mm) and 0.64 (4 mm) on the default
60 x 60 x 6 mm cartilage layer (HXT, Gmsh 4.15)."""
TRIANGLE_FILL = 1.0
"""Gmsh triangles per equilateral triangle's area at the same size: measured 1.00 on a
disc of radius 20 mm at 0.2 and 0.1 mm (frontal-Delaunay)."""
BYTES_PER_ELEMENT = {"tetrahedra": 500.0, "quadratic tetrahedra": 1500.0,
                     "triangles": 1500.0}
"""Peak resident memory per element of a Gmsh build, bytes (rounded up from the peak RSS
of builds at decreasing sizes: linear tetrahedra 480 B at 259k and 400 B at 707k,
quadratic 1,280 B at 259k, triangles 1,420 B at 73k and 1,100 B at 291k)."""
MAX_ELEMENTS = {"tetrahedra": 2_000_000, "quadratic tetrahedra": 1_000_000,
                "triangles": 500_000}
"""Most elements a build makes without ``--force``: about a minute or two of Gmsh here
(measured 26 µs per linear and 44 µs per quadratic tetrahedron, 90 to 220 µs per
frontal-Delaunay triangle, on a shared core)."""
GB = 1e9


@dataclass(frozen=True)
class Estimate:
    """What a build will make: `count` elements of kind `what`, needing `bytes` of memory."""

    what: str
    count: float
    bytes: float
    limit: float = math.inf


@dataclass(frozen=True)
class Zone:
    """A refined zone: element size `fine` within `inner` mm of its centre (a point or a
    circle), growing linearly to the global size at `outer` mm; `measure(d)` is the area
    (volumes) or length (surfaces) of the domain at distance d (mm) from the centre."""

    fine: float
    inner: float
    outer: float
    measure: Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class Policy:
    """How refusals read and whether the element limit may be passed.

    label : who builds (e.g. ``"fecheck mesh layer"``); None: the builder's name
    keys : builder parameter → the key the user sets (``{"size": "--size"}``)
    force : pass the element limits (never the machine's memory)
    force_hint : how the user forces (``"--force"``), None where there is no way
    """

    label: str | None = None
    keys: Mapping[str, str] = field(default_factory=dict)
    force: bool = False
    force_hint: str | None = None


_POLICY: ContextVar[Policy | None] = ContextVar("budget_policy", default=None)


def _policy() -> Policy:
    return _POLICY.get() or Policy()


@contextmanager
def policy(label: str | None = None, keys: Mapping[str, str] | None = None, *,
           force: bool | None = None, force_hint: str | None = None) -> Iterator[None]:
    """Within the block, refusals name `label` and `keys`, and `force` passes the element
    limit; unset arguments keep the enclosing policy's."""
    old = _policy()
    token = _POLICY.set(Policy(old.label if label is None else label,
                               {**old.keys, **(keys or {})},
                               old.force if force is None else force,
                               force_hint or old.force_hint))
    try:
        yield
    finally:
        _POLICY.reset(token)


def available_memory_bytes() -> float:
    """Memory this machine can give a new build now, bytes: ``MemAvailable`` of
    /proc/meminfo, else the free physical pages, else all physical memory."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except OSError:
        pass
    for name in ("SC_AVPHYS_PAGES", "SC_PHYS_PAGES"):
        try:
            return float(os.sysconf(name) * os.sysconf("SC_PAGE_SIZE"))
        except (ValueError, OSError, AttributeError):
            continue
    return math.inf


# ---------------------------------------------------------------------- counts
def triangle_area(size: float) -> float:
    """Area of the equilateral triangle of edge `size`, mm²."""
    return math.sqrt(3.0) / 4.0 * size**2


def tet_volume(size: float) -> float:
    """Volume of the regular tetrahedron of edge `size`, mm³."""
    return size**3 / (6.0 * math.sqrt(2.0))


def _excess(zone: Zone, size: float, per: Callable[[np.ndarray], np.ndarray],
            total: float) -> float:
    """Elements a refined zone adds over the global size's count, before the fill factor:
    ∫ measure(d) (1/per(s(d)) − 1/per(size)) dd, its domain measure clipped to `total`."""
    fine = min(zone.fine, size)
    if fine >= size or zone.outer <= 0:
        return 0.0
    tiny = min(fine, zone.outer) * 1e-6
    d = np.unique(np.concatenate([[0.0], np.geomspace(tiny, zone.outer, 2000),
                                  np.linspace(0.0, zone.outer, 2000)]))
    ramp = (d - zone.inner) / max(zone.outer - zone.inner, 1e-300)
    s = np.where(d <= zone.inner, fine, fine + (size - fine) * np.clip(ramp, 0.0, 1.0))
    m = zone.measure(d)
    shell = 0.5 * (m[1:] + m[:-1]) * np.diff(d)
    reach = np.cumsum(shell)
    shell = np.where(reach <= total, shell, np.maximum(total - (reach - shell), 0.0))
    dens = 1.0 / per(s) - 1.0 / per(np.full_like(s, size))
    return float(np.sum(shell * 0.5 * (dens[1:] + dens[:-1])))


def tetrahedra(volume_mm3: float, size: float, zones: Sequence[Zone] = ()) -> float:
    """Estimated Gmsh tetrahedra of a volume meshed at `size` mm with refined `zones`."""
    base = volume_mm3 / tet_volume(size)
    return TET_FILL * (base + sum(_excess(z, size, lambda s: s**3 / (6.0 * math.sqrt(2.0)),
                                          volume_mm3) for z in zones))


def triangles(area_mm2: float, size: float, zones: Sequence[Zone] = ()) -> float:
    """Estimated Gmsh triangles of a surface meshed at `size` mm with refined `zones`."""
    base = area_mm2 / triangle_area(size)
    return TRIANGLE_FILL * (base + sum(_excess(z, size, lambda s: math.sqrt(3.0) / 4.0 * s**2,
                                               area_mm2) for z in zones))


def point_on_slab(thickness: float) -> Callable[[np.ndarray], np.ndarray]:
    """Area at distance d of a slab of `thickness` from a point on its top (no side
    walls): the half sphere 2πd², then the zone 2πd·h."""
    return lambda d: 2.0 * np.pi * d * np.minimum(d, thickness)


def circle_on_slab(radius: float, thickness: float) -> Callable[[np.ndarray], np.ndarray]:
    """Area at distance d of a slab of `thickness` from a circle of `radius` on its top:
    the circle's length times the arc of the tube of radius d inside the slab."""
    def measure(d: np.ndarray) -> np.ndarray:
        ratio = np.minimum(1.0, thickness / np.maximum(d, 1e-300))
        arc = np.where(d <= thickness, np.pi, 2.0 * np.arcsin(ratio)) * d
        return 2.0 * np.pi * radius * arc
    return measure


def point_on_plane(d: np.ndarray) -> np.ndarray:
    """Length at distance d of a plane from a point on it: the circle 2πd."""
    return 2.0 * np.pi * d


def mesh_estimate(what: str, count: float) -> Estimate:
    """`count` elements of kind `what` (a key of `BYTES_PER_ELEMENT`), their memory and
    their `MAX_ELEMENTS`."""
    return Estimate(what, float(count), float(count) * BYTES_PER_ELEMENT[what],
                    MAX_ELEMENTS[what])


def icosphere_estimate(subdivisions: int) -> Estimate:
    """A level-n icosphere: exactly 20·4^n triangles, with no element limit (refining a
    sphere is fast: its builder's level cap bounds it), only the memory's."""
    count = 20.0 * 4.0 ** int(subdivisions)
    return Estimate("triangles", count, count * BYTES_PER_ELEMENT["triangles"])


# ---------------------------------------------------------------------- the guard
def _fits(estimate: Estimate, force: bool, memory: float) -> bool:
    return estimate.bytes <= memory and (force or estimate.count <= estimate.limit)


def _search(estimate_at: Callable[[float], Estimate], value: float, upper: float | None,
            ok: Callable[[Estimate], bool]) -> float | None:
    """The smallest size >= `value` (at most `upper`) whose estimate is `ok`, rounded up
    to 2 significant digits; None when even `upper` is not."""
    hi = value * 2.0
    limit = upper if upper is not None else value * 1e12
    while not ok(estimate_at(min(hi, limit))):
        if hi >= limit:
            return None
        hi *= 2.0
    hi, lo = min(hi, limit), value
    for _ in range(60):
        mid = math.sqrt(lo * hi)
        lo, hi = (lo, mid) if ok(estimate_at(mid)) else (mid, hi)
    digits = 1 - math.floor(math.log10(hi))
    return math.ceil(hi * 10**digits) / 10**digits


def _level_search(estimate_at: Callable[[float], Estimate], value: int,
                  ok: Callable[[Estimate], bool]) -> int | None:
    """The largest level <= `value` whose estimate is `ok` (None: not even 0)."""
    return next((n for n in range(int(value), -1, -1) if ok(estimate_at(n))), None)


def guard(builder: str, key: str, value: float, estimate_at: Callable[[float], Estimate], *,
          unit: str = "mm", level: bool = False, upper: float | None = None,
          otherwise: str = "coarsen the other sizes") -> None:
    """Raise FecheckError when `estimate_at(value)` is beyond this machine's memory, or
    beyond its element limit outside ``policy(force=True)``.

    Parameters
    ----------
    builder : the builder's name, used when no `policy` label is set
    key : the parameter the remedy changes (a size: larger is smaller; with `level` an
        integer level: lower is smaller), named through the policy's keys
    value : its value
    estimate_at : the builder's estimate as a function of that parameter alone
    unit : the parameter's unit in the message ("" for a level)
    upper : the largest size the remedy may propose (e.g. the global size for a
        refinement size)
    otherwise : the remedy when no value of `key` alone fits
    """
    pol = _policy()
    estimate = estimate_at(value)
    memory = available_memory_bytes()
    if _fits(estimate, pol.force, memory):
        return
    name = pol.keys.get(key, key)
    shown = f"{value:g}{' ' + unit if unit else ''}"
    head = (f"{pol.label or builder}: {name} {shown} would make about "
            f"{_approx(estimate.count)} {estimate.what} (~{_approx(estimate.bytes / GB)} GB")
    if estimate.bytes > memory:
        head += f"; this machine has {memory / GB:.3g} GB available)"
    else:
        head += f"; more than the {estimate.limit:,.0f} allowed without "
        head += f"{pol.force_hint})" if pol.force_hint else "forcing)"
    soft = _remedy(estimate_at, value, level, upper, lambda e: _fits(e, pol.force, memory))
    hard = _remedy(estimate_at, value, level, upper, lambda e: _fits(e, True, memory))
    op = "<=" if level else ">="
    if soft is None:
        raise FecheckError(f"{head}: no value of {name} alone fits; {otherwise}")
    units = f" {unit}" if unit else ""
    tail = f"use {name} {op} {soft:g}{units}"
    if pol.force_hint and not pol.force and estimate.bytes <= memory:
        tail += f", or {pol.force_hint}"
    elif pol.force_hint and not pol.force and hard is not None and hard != soft:
        tail += f", or {pol.force_hint} with {name} {op} {hard:g}{units}"
    raise FecheckError(f"{head}: {tail}")


def _approx(x: float) -> str:
    """`x` to 2 significant digits: plainly below 100,000, else in e-notation."""
    return f"{x:.2g}" if x >= 1e5 else f"{float(f'{x:.2g}'):,g}"


def _remedy(estimate_at: Callable[[float], Estimate], value: float, level: bool,
            upper: float | None, ok: Callable[[Estimate], bool]) -> float | None:
    """The value of the parameter nearest `value` whose estimate is `ok`."""
    if level:
        return _level_search(estimate_at, int(value), ok)
    return _search(estimate_at, float(value), upper, ok)


def guard_mesh(builder: str, what: str, measure: float, size: float,
               zones_at: Callable[[float, float], Sequence[Zone]], *,
               refine_size: float | None = None, copies: float = 1.0,
               size_key: str = "size", refine_key: str = "refine_size") -> None:
    """`guard` a Gmsh build of `copies` meshes of a domain of `measure` (mm³ for
    tetrahedra, mm² for triangles) at global `size` mm, refined by ``zones_at(size,
    fine)``; the remedy names `refine_key` when an explicit `refine_size` makes most of
    the elements, else `size_key` (the refinement following the size when not given).

    >>> guard_mesh("demo", "triangles", 100.0, 1.0, lambda s, f: [])
    """
    count = tetrahedra if what.endswith("tetrahedra") else triangles

    def at(s: float, fine: float) -> Estimate:
        return mesh_estimate(what, copies * count(measure, s, zones_at(s, min(fine, s))))

    if refine_size is not None and at(size, refine_size).count > 2 * at(size, size).count:
        guard(builder, refine_key, refine_size, lambda f: at(size, f), upper=size)
    else:
        refine_name = _policy().keys.get(refine_key, refine_key)
        guard(builder, size_key, size,
              lambda s: at(s, s if refine_size is None else refine_size),
              otherwise=("coarsen the other sizes" if refine_size is None
                         else f"raise {refine_name} too"))
