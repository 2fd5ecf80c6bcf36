"""Geometry for fecheck: Gmsh builders, mesh I/O and checks, surface fits.

Knows nothing of mechanics. Units are mm; the frame is the thesis frame (x right,
y anterior, z superior, origin at the tibial plateau centre). Heavy dependencies
(gmsh, pygmsh, trimesh) are imported inside the functions that need them.
"""

from geometry.errors import FecheckError
from geometry.mesh import TetMesh, TriMesh

__all__ = ["FecheckError", "TetMesh", "TriMesh"]
