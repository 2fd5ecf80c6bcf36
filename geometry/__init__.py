"""Geometry for fecheck: Gmsh builders, mesh I/O and checks, surface fits.

Knows nothing of mechanics. Units are mm; the frame is the thesis frame (x right,
y anterior, z superior, origin at the tibial plateau centre). Heavy dependencies
(gmsh, pygmsh, trimesh) are imported inside the functions that need them, and this
package imports nothing but its error type until a mesh class is asked for.
"""

from geometry.errors import FecheckError

__all__ = ["FecheckError", "TetMesh", "TriMesh"]


def __getattr__(name: str):
    if name in ("TriMesh", "TetMesh"):
        from geometry import mesh

        return getattr(mesh, name)
    raise AttributeError(f"module 'geometry' has no attribute {name!r}")
