"""Analytic master surfaces with closed-form signed depths (mm, master body frame).

Each master gives, for slave points ``y`` (and, for the sphere, the foundation normal
``u`` at each point), the signed depth ``d`` (positive inside the master) and its
gradients ``∂d/∂y`` and ``∂d/∂u``; `fecheck.contact.pair` turns them into twist
derivatives in the world frame. ``reach`` is a cheap, conservative signed distance used
by the broad phase (positive inside; at most the depth's magnitude outside).

* `Plane`: depth along the plane normal; foundation normal = the plane normal.
* `Sphere`: depth along the slave's foundation normal ``u`` (minus the slave face
  normal) from the slave point to the sphere (ray-sphere intersection), so a flat
  plateau face under a sphere integrates the exact cap volume. The formula is the
  compiled `fecheck.contact.kernels.sphere_ray_depth`, shared with the contact kernel.
* `PolynomialSurface` (inside = below ``z = f(x, y)``): depth
  ``(f(x, y) - z) / sqrt(1 + |∇f|²)``, the first-order normal distance. It is exact for
  a plane (a degree-1 polynomial gives the same depth as `Plane`), closed form (no
  closest-point iterations that could stop unconverged) with exact derivatives, and
  differs from the true normal distance by O(d²·|∇f|·κ) (κ the surface curvature): for
  a plateau sloped 10° with a 100 mm radius of curvature, about 2e-4 mm at d = 1 mm.
  The foundation normal of a face is the surface normal at the vertical foot of its
  centroid.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fecheck.contact.bvh import BALL, HALF_SPACE
from fecheck.contact.kernels import sphere_depths
from fecheck.errors import FecheckError
from geometry.polynomial import Polynomial2D


def _finite_vector(value, name: str) -> np.ndarray:
    v = np.asarray(value, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise FecheckError(f"{name} must be 3 finite numbers (mm), got {value!r}")
    return v


@dataclass(frozen=True, eq=False)
class Plane:
    """Half-space below the plane through `point` with outward unit `normal` (mm).

    >>> p = Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    >>> float(p.depth_values(np.array([[1.0, 2.0, -0.5]]))[0])
    0.5
    """

    point: np.ndarray
    normal: np.ndarray
    uses_slave_normal: bool = field(default=False, init=False)
    normal_body: str = field(default="master", init=False)

    def __post_init__(self) -> None:
        point = _finite_vector(self.point, "plane point")
        normal = _finite_vector(self.normal, "plane normal")
        length = np.linalg.norm(normal)
        if length < 1e-12:
            raise FecheckError("plane normal must be a non-zero vector")
        object.__setattr__(self, "point", point)
        object.__setattr__(self, "normal", normal / length)

    def describe(self) -> str:
        return "analytic plane"

    def region(self, margin_mm: float) -> tuple[int, np.ndarray]:
        """Where reach > -margin: the half-space n·y < n·point + margin
        (`fecheck.contact.bvh`)."""
        return HALF_SPACE, np.append(self.normal, self.normal @ self.point + margin_mm)

    def reach(self, y: np.ndarray) -> np.ndarray:
        """Signed distance below the plane, mm (1-Lipschitz)."""
        return (self.point - y) @ self.normal

    def depth_values(self, y: np.ndarray, u: np.ndarray | None = None) -> np.ndarray:
        """(…,) depth below the plane along its normal, mm."""
        return (self.point - y) @ self.normal

    def depth_gradients(self, y: np.ndarray, u: np.ndarray | None = None):
        """(∂d/∂y, None): minus the plane normal, (3,) for every point."""
        return -self.normal, None

    def foundation_normals(self, triangles: np.ndarray):
        """The plane normal (3,) for every face, and ∂normal/∂centroid (None: zero)."""
        return self.normal, None


@dataclass(frozen=True, eq=False)
class Sphere:
    """Solid ball of `radius` (mm) centred at `center` (mm).

    Depth of a slave point ``y`` along the unit foundation normal ``u``: the distance
    ``s`` with ``y + s·u`` on the sphere (the larger root), i.e. how far the slave
    surface must move along ``u`` to leave the ball.

    >>> s = Sphere([0.0, 0.0, 10.0], 10.5)
    >>> float(s.depth_values(np.zeros((1, 3)), np.array([[0.0, 0.0, -1.0]]))[0])
    0.5
    """

    center: np.ndarray
    radius: float
    uses_slave_normal: bool = field(default=True, init=False)
    normal_body: str = field(default="slave", init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _finite_vector(self.center, "sphere centre"))
        radius = float(self.radius)
        if not np.isfinite(radius) or radius <= 0:
            raise FecheckError(f"sphere radius must be a positive number of mm, got {radius}")
        object.__setattr__(self, "radius", radius)

    def describe(self) -> str:
        return "analytic sphere"

    def region(self, margin_mm: float) -> tuple[int, np.ndarray]:
        """Where reach > -margin: the ball |y - c| < R + margin (`fecheck.contact.bvh`)."""
        return BALL, np.append(self.center, self.radius + margin_mm)

    def reach(self, y: np.ndarray) -> np.ndarray:
        """Radial signed distance R - |y - c|, mm (1-Lipschitz; ≤ |depth| outside)."""
        r = y - self.center
        return self.radius - np.sqrt(np.einsum("...i,...i->...", r, r))

    def _depths(self, y: np.ndarray, u: np.ndarray):
        y, u = np.broadcast_arrays(np.asarray(y, dtype=float), np.asarray(u, dtype=float))
        shape = y.shape
        d, g, h = sphere_depths(np.ascontiguousarray(y.reshape(-1, 3)),
                                np.ascontiguousarray(u.reshape(-1, 3)), self.center,
                                self.radius)
        return d.reshape(shape[:-1]), g.reshape(shape), h.reshape(shape)

    def depth_values(self, y: np.ndarray, u: np.ndarray | None = None) -> np.ndarray:
        """(…,) depth along `u`, mm; where the line misses the ball, R - |y - c| (< 0)."""
        return self._depths(y, u)[0]

    def depth_gradients(self, y: np.ndarray, u: np.ndarray):
        """(∂d/∂y, ∂d/∂u), each (…, 3)."""
        return self._depths(y, u)[1:]

    def foundation_normals(self, triangles: np.ndarray):
        raise FecheckError("the sphere master uses the slave face normals")


@dataclass(frozen=True, eq=False)
class PolynomialSurface:
    """Region below ``z = f(x, y)`` (`geometry.polynomial.Polynomial2D`, mm).

    >>> import numpy as np
    >>> from geometry.polynomial import Polynomial2D
    >>> s = PolynomialSurface(Polynomial2D(np.array([[1.0]])))   # z = 1
    >>> float(s.depth_values(np.array([[0.0, 0.0, 0.25]]))[0])
    0.75
    """

    poly: Polynomial2D
    uses_slave_normal: bool = field(default=False, init=False)
    normal_body: str = field(default="master", init=False)

    def __post_init__(self) -> None:
        if not isinstance(self.poly, Polynomial2D):
            raise FecheckError("PolynomialSurface needs a geometry.polynomial.Polynomial2D")
        P = np.polynomial.polynomial

        def der(c: np.ndarray, axis: int) -> np.ndarray:
            return P.polyder(c, axis=axis) if c.shape[axis] > 1 else np.zeros((1, 1))

        c = self.poly.coeffs
        cx, cy = der(c, 0), der(c, 1)
        object.__setattr__(self, "_c", (c, cx, cy, der(cx, 0), der(cx, 1), der(cy, 1)))

    def describe(self) -> str:
        return "analytic polynomial surface z = f(x, y)"

    def _eval(self, y: np.ndarray, hessian: bool):
        val = np.polynomial.polynomial.polyval2d
        x1, x2 = y[..., 0], y[..., 1]
        c = self._c
        out = [val(x1, x2, ck) for ck in (c[:3] if not hessian else c)]
        return out

    def reach(self, y: np.ndarray) -> np.ndarray:
        """The depth itself (Lipschitz constant ≈ 1 for gently sloped surfaces)."""
        return self.depth_values(y)

    def depth_values(self, y: np.ndarray, u: np.ndarray | None = None) -> np.ndarray:
        """(…,) depth (f - z) / sqrt(1 + |∇f|²), mm."""
        f, fx, fy = self._eval(y, False)
        return (f - y[..., 2]) / np.sqrt(1.0 + fx * fx + fy * fy)

    def depth_gradients(self, y: np.ndarray, u: np.ndarray | None = None):
        """(∂d/∂y, None), exact (uses the Hessian of f)."""
        f, fx, fy, fxx, fxy, fyy = self._eval(y, True)
        s = np.sqrt(1.0 + fx * fx + fy * fy)
        h = (f - y[..., 2]) / s**3
        g = np.stack([fx / s - h * (fx * fxx + fy * fxy),
                      fy / s - h * (fx * fxy + fy * fyy),
                      -1.0 / s], axis=-1)
        return g, None

    def foundation_normals(self, triangles: np.ndarray):
        """(m, 3) upward unit normals at the vertical feet of the centroids of faces
        (m, 3, 3) and their (m, 3, 3) derivatives with respect to the centroid position."""
        centroids = triangles.sum(axis=1) / 3.0
        _, fx, fy, fxx, fxy, fyy = self._eval(centroids, True)
        a = np.stack([-fx, -fy, np.ones_like(fx)], axis=-1)
        s = np.linalg.norm(a, axis=-1)
        n = a / s[:, None]
        da = np.zeros(centroids.shape[:-1] + (3, 3))
        da[:, 0, 0], da[:, 0, 1] = -fxx, -fxy
        da[:, 1, 0], da[:, 1, 1] = -fxy, -fyy
        proj = np.eye(3) - n[:, :, None] * n[:, None, :]
        return n, (proj @ da) / s[:, None, None]


AnalyticMaster = Plane | Sphere | PolynomialSurface
