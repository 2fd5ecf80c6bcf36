"""Ctrl-C inside long native calls (Gmsh meshing, sparse factorizations, dense solves).

Python runs its SIGINT handler only between bytecodes, so a KeyboardInterrupt waits for
a native call to return: minutes for a large Gmsh build. Inside `interruptible` SIGINT
takes its default action instead, and the process ends at once (killed by the signal:
exit status 130 in the shell, no message). Nothing half-written remains: the mesh
cache and the output writers write to a temporary file renamed into place, and the
native calls wrapped here write nothing. Outside the block, Ctrl-C raises
KeyboardInterrupt as usual (the command line prints one line and exits 130).

Only the plain Python handler is replaced: where SIGINT is ignored (pool workers) or
handled by the caller (a sweep that keeps its finished points), the block changes
nothing; so too outside the main thread, where signal actions cannot be set.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def interruptible() -> Iterator[None]:
    """Let SIGINT end the process at once inside the block (module docstring).

    >>> with interruptible():
    ...     pass
    """
    if (threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGINT) is not signal.default_int_handler):
        yield
        return
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, signal.default_int_handler)
