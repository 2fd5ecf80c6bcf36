"""A model's built parts reused across the runs of a sweep.

A sweep solves one scene for many values of one key, and most keys (the load, the start
pose) do not change what a model builds: meshes, contact pairs with their trees, laws.
Inside `reusing_builds`, a build function marked `reusable` remembers what it built and
which scene keys it read to build it; a later call whose scene has the same values for
all of those keys (and the same source) gets the same parts back. The keys are recorded
as the build reads them, so a swept key that changes what is built (a mesh refinement, a
material, a file) always rebuilds, whichever function reads it. Outside the context,
or for another thread's context, nothing is kept.

The parts are reused as they are, with their contact pairs' candidate sets and warm
closest-point states, which Newton reuses between its own iterations: they are exact
(a set is reused only while no face outside it can touch), so a run's numbers equal a
fresh build's to round-off.
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from typing import Any, TypeVar

from fecheck.scene import Scene

T = TypeVar("T")

_active = threading.local()
"""The running context's memo (``memo``: build function → (source, keys and values
read, parts)), per thread: a thread's parts are never handed to another thread."""


class _Recording(Mapping):
    """A scene's values that note each key read (every key, when iterated)."""

    def __init__(self, values: Mapping[str, Any], seen: dict[str, Any]) -> None:
        self._values = values
        self._seen = seen

    def __getitem__(self, key: str) -> Any:
        value = self._values[key]
        self._seen[key] = value
        return value

    def __iter__(self) -> Iterator[str]:
        self._seen.update(self._values)
        return iter(self._values)

    def __len__(self) -> int:
        return len(self._values)


@contextmanager
def reusing_builds(memo: dict | None = None) -> Iterator[None]:
    """Within the block, `reusable` builds in this thread are remembered and reused.

    memo : where they are remembered (new by default); a dict kept from one block to the
        next reuses across them (a sweep worker's, between its points of one sweep)
    """
    outer = getattr(_active, "memo", None)
    _active.memo = {} if memo is None else memo
    try:
        yield
    finally:
        _active.memo = outer


@contextmanager
def building_once() -> Iterator[None]:
    """Within the block, each `reusable` build runs once for the scene's values: one run
    or one cross-check reads one knee (its surfaces, contact pairs and thickness maps),
    whichever of its parts asks. A context already open (a sweep's, a population's) is
    kept, with what it holds."""
    if getattr(_active, "memo", None) is not None:
        yield
        return
    with reusing_builds():
        yield


def reusable(build: Callable[[Scene], T]) -> Callable[[Scene], T]:
    """Mark `build` (a function of the scene alone) as reusable within `reusing_builds`."""

    @functools.wraps(build)
    def reused_or_built(scene: Scene) -> T:
        memo = getattr(_active, "memo", None)
        if memo is None:
            return build(scene)
        if build in memo:
            source, read, parts = memo[build]
            # (read through `scene`: an enclosing build's record gets them too)
            if source == scene.source and all(scene[k] == v for k, v in read.items()):
                return parts
        seen: dict[str, Any] = {}
        parts = build(Scene(_Recording(scene.values, seen), scene.source))
        memo[build] = (scene.source, seen, parts)
        return parts

    return reused_or_built
