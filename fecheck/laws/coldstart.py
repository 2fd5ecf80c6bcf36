"""Say when the compiled kernels are not in numba's on-disk cache yet.

A fresh install compiles the contact and law kernels at its first run (about 30 s, in
silence). `announce_cold_kernels` prints one line on stderr first when none of the
kernels every run uses has a cached copy for today's sources (numba's cache index,
which numba drops when its source file changed); `python -m fecheck.laws.warm` fills
the cache ahead.
"""

from __future__ import annotations

import sys

CORE_KERNELS = (("fecheck.laws.fused", "pack"), ("fecheck.laws.kernel", "law_values"),
                ("fecheck.laws.kernel", "pressure_resultant"),
                ("fecheck.contact.kernels", "surface_quadrature"))
"""(module, name) of compiled kernels every contact run calls."""
MESSAGE = "fecheck: compiling the contact kernels once (about 30 s)…"

_announced = False


def _cached(module: str, name: str) -> bool | None:
    """Whether numba's cache holds a compiled copy of the kernel (None: cannot tell)."""
    import importlib

    dispatcher = getattr(importlib.import_module(module), name)
    try:
        return bool(dispatcher._cache._cache_file._load_index())
    except (AttributeError, OSError, EOFError, ValueError):
        return None


def kernels_cold() -> bool:
    """True when none of `CORE_KERNELS` is in numba's on-disk cache (a first run)."""
    return all(_cached(module, name) is False for module, name in CORE_KERNELS)


def announce_cold_kernels(stream=None) -> None:
    """Print `MESSAGE` on `stream` (default stderr) once per process, when the kernels
    are cold (`kernels_cold`)."""
    global _announced
    if _announced:
        return
    _announced = True
    if kernels_cold():
        print(MESSAGE, file=sys.stderr if stream is None else stream, flush=True)
