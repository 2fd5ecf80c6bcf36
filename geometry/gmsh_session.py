"""A quiet Gmsh session: initialise, build one model, clean up.

Gmsh keeps global state; every builder in `geometry` goes through `gmsh_session` so
that nothing is printed, no model leaks between builds and Gmsh is finalised when the
session that initialised it ends.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from geometry.native import interruptible


@contextmanager
def gmsh_session(model_name: str = "fecheck") -> Iterator[Any]:
    """Yield the `gmsh` module with a fresh, silent model named `model_name`.

    Nested sessions share the Gmsh instance; only the outermost one finalises it. Ctrl-C
    ends the process at once inside a session (`geometry.native.interruptible`: Gmsh
    does not return to Python while it meshes).

    >>> with gmsh_session("demo") as gmsh:
    ...     _ = gmsh.model.occ.addBox(0, 0, 0, 1, 1, 1)
    """
    import gmsh

    with interruptible():
        owner = not gmsh.isInitialized()
        if owner:
            gmsh.initialize(readConfigFiles=False, interruptible=False)
            _ignore_broken_pipes()
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.Verbosity", 0)
        gmsh.model.add(model_name)
        try:
            yield gmsh
        finally:
            gmsh.model.remove()
            if owner:
                gmsh.finalize()


def _ignore_broken_pipes() -> None:
    """Ignore SIGPIPE again, as Python does: Gmsh's initialisation restores its default
    action, after which a write to a closed pipe (a sweep worker that has exited, output
    piped into `head`) kills the process without a word instead of raising
    BrokenPipeError. Only the main thread may set signal actions."""
    import signal
    import threading

    if hasattr(signal, "SIGPIPE") and threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGPIPE, signal.SIG_IGN)


def surface_triangles(gmsh: Any, dim: int = 2, tag: int = -1) -> tuple[Any, Any]:
    """Nodes (n, 3) and linear triangles (m, 3) of the current model's mesh, 0-based.

    Only the nodes used by the returned triangles are kept.
    """
    import numpy as np

    node_tags, coords, _ = gmsh.model.mesh.getNodes(dim, tag, includeBoundary=True,
                                                    returnParametricCoord=False)
    _, elem_nodes = gmsh.model.mesh.getElementsByType(2, tag)
    node_tags = node_tags.astype(np.int64)
    lookup = np.full(node_tags.max() + 1, -1, dtype=np.int64)
    lookup[node_tags] = np.arange(len(node_tags))
    faces = lookup[elem_nodes.astype(np.int64)].reshape(-1, 3)
    points = coords.reshape(-1, 3)
    used, inverse = np.unique(faces, return_inverse=True)
    return points[used], inverse.reshape(-1, 3)
