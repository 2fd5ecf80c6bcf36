"""A synthetic knee that looks like a segmentation: `geometry.synthetic.knee`'s smooth
knee, voxelized and turned back into surfaces by marching cubes (scikit-image).

The labels are drawn on a grid of spacing `spacing` mm (0.3-0.6 mm, like an MRI
segmentation) from the very surfaces of `geometry.synthetic.knee` (so the smooth knee is the
reference the voxel knee converges to):

* femoral cartilage: inside the condyle ellipsoid, outside the same ellipsoid shrunk by
  `CARTILAGE_MM` along every axis (the femoral bone), on the lower cap only
  ((X/a)² + (Y/b)² ≤ CAP_RHO² (`CAP_RHO`), below the centre);
* tibial cartilage: `CARTILAGE_MM` under the plateau surface z = plateau_height(x, y),
  over the compartment's square patch; the tibial bone below it, down to `Z_MIN`.

The articular sheets are the marching-cubes surfaces of the cartilage labels, kept where
the surface lies farther than half the cartilage thickness from its bone: the joint side,
with what segmentations give — voxel terraces, sliver faces (marching cubes on a binary
volume makes triangles with edges down to a few µm near grid points) and rims that curl
down over the edge of the cartilage. The bones are closed marching-cubes surfaces.
Variants: ``"noisy"`` (noise added to the labels before the blur, `NOISE`) and
``"decimated"`` (VTK's quadric decimation to `DECIMATED_FRACTION` of the faces).

Units mm; frame x right, y anterior, z superior; a right knee (medial at -x).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy import ndimage

from geometry.mesh import TriMesh
from geometry.synthetic.knee import CAP_RHO, COMPARTMENTS, CONDYLES, PATCH_HALF_MM, plateau_height
from geometry.synthetic.knee import write_mesh as _write

CARTILAGE_MM = 2.0
Z_MIN, Z_MAX = -8.0, 24.0
"""The grid's z range, mm: the tibial bone below, the femoral caps (rim at z ≈ 12.7) above."""
X_HALF, Y_HALF = 44.0, 28.0
NOISE = 0.35
"""Standard deviation of the white noise added to a label before its blur (variant
"noisy"): after the blur it moves the surface by about a tenth of a voxel (rms)."""
DECIMATED_FRACTION = 0.3
VARIANTS = ("raw", "noisy", "decimated")
SMOOTH_VOXELS = 1.0
"""Gaussian blur of a label before marching cubes, voxels (the partial-volume smoothing of
segmentation tools): the iso-surface then crosses grid edges anywhere, which makes slivers."""


def grid(spacing: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The voxel centres' x, y, z axes, mm."""
    return (np.arange(-X_HALF, X_HALF + 1e-9, spacing),
            np.arange(-Y_HALF, Y_HALF + 1e-9, spacing), np.arange(Z_MIN, Z_MAX + 1e-9, spacing))


def labels(spacing: float) -> dict[str, np.ndarray]:
    """Binary volumes (nx, ny, nz) of femoral and tibial cartilage and bone."""
    x, y, z = grid(spacing)
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    out = {k: np.zeros(X.shape, dtype=bool)
           for k in ("femur", "femur_bone", "tibia", "tibia_bone")}
    for name in COMPARTMENTS:
        c = CONDYLES[name]
        (x0, y0, z0), (a, b, cz) = c.centre, c.axes
        u, v, w = X - x0, Y - y0, Z - z0
        inner = (u / (a - CARTILAGE_MM)) ** 2 + (v / (b - CARTILAGE_MM)) ** 2 \
            + (w / (cz - CARTILAGE_MM)) ** 2 <= 1.0
        outer = (u / a) ** 2 + (v / b) ** 2 + (w / cz) ** 2 <= 1.0
        cap = ((u / a) ** 2 + (v / b) ** 2 <= CAP_RHO ** 2) & (w < 0)
        out["femur_bone"] |= inner
        out["femur"] |= outer & ~inner & cap
        px, py = c.patch_centre
        patch = (np.abs(X - px) <= PATCH_HALF_MM) & (np.abs(Y - py) <= PATCH_HALF_MM)
        top = plateau_height(c, X[:, :, :1], Y[:, :, :1])                     # (nx, ny, 1)
        out["tibia"] |= patch & (Z <= top) & (Z > top - CARTILAGE_MM)
        base = (np.abs(X - px) <= PATCH_HALF_MM + 2) & (np.abs(Y - py) <= PATCH_HALF_MM + 2)
        out["tibia_bone"] |= base & (Z <= top - CARTILAGE_MM)
    return out


def _marching(volume: np.ndarray, spacing: float, rng: np.random.Generator | None = None
              ) -> TriMesh:
    """The closed marching-cubes surface (level ½) of a binary volume, mm, normals out;
    with `rng`, of the blurred volume plus smoothed noise (`NOISE`)."""
    from skimage.measure import marching_cubes

    field = np.pad(volume.astype(np.float32), 2)
    if rng is not None:
        field += rng.normal(0.0, NOISE, field.shape).astype(np.float32)
    blurred = ndimage.gaussian_filter(field, SMOOTH_VOXELS)
    padded = blurred[1:-1, 1:-1, 1:-1]
    verts, faces, _, _ = marching_cubes(padded, 0.5, spacing=(spacing,) * 3,
                                        allow_degenerate=False)
    origin = np.array([-X_HALF, -Y_HALF, Z_MIN]) - spacing
    return TriMesh(verts + origin, faces[:, ::-1].astype(np.int64))


def _keep(mesh: TriMesh, faces: np.ndarray) -> TriMesh:
    used = np.unique(mesh.faces[faces])
    remap = np.full(mesh.n_points, -1)
    remap[used] = np.arange(len(used))
    return TriMesh(mesh.points[used], remap[mesh.faces[faces]])


def _sheet(cartilage: np.ndarray, bone: np.ndarray, spacing: float,
           rng: np.random.Generator | None = None) -> TriMesh:
    """The joint side of a cartilage label: its marching-cubes faces farther than half the
    cartilage thickness from the bone."""
    surface = _marching(cartilage, spacing, rng)
    distance = ndimage.distance_transform_edt(~bone) * spacing
    x, y, z = grid(spacing)
    centroid = surface.points[surface.faces].mean(axis=1)
    ijk = np.rint((centroid - [x[0], y[0], z[0]]) / spacing).astype(int)
    ijk = np.clip(ijk, 0, np.array(bone.shape) - 1)
    far = distance[ijk[:, 0], ijk[:, 1], ijk[:, 2]] > 0.5 * CARTILAGE_MM
    return _keep(surface, np.flatnonzero(far))


def voxel_knee(spacing: float = 0.5, variant: str = "raw", seed: int = 0
               ) -> dict[str, TriMesh]:
    """{"femur", "tibia", "femur_bone", "tibia_bone"}: the voxelized knee's sheets and
    bones (mm), marching cubes of labels drawn at `spacing` mm; `variant` in `VARIANTS`."""
    if variant not in VARIANTS:
        raise ValueError(f"unknown variant {variant!r}")
    vol = labels(spacing)
    rng = np.random.default_rng(seed) if variant == "noisy" else None
    out = {"femur": _sheet(vol["femur"], vol["femur_bone"], spacing, rng),
           "tibia": _sheet(vol["tibia"], vol["tibia_bone"], spacing, rng),
           "femur_bone": _marching(vol["femur_bone"], spacing, rng),
           "tibia_bone": _marching(vol["tibia_bone"], spacing, rng)}
    if variant == "decimated":
        out = {k: _decimated(m) for k, m in out.items()}
    return out


def _decimated(mesh: TriMesh) -> TriMesh:
    """VTK's quadric decimation (pyvista) to `DECIMATED_FRACTION` of the faces, as a
    segmentation tool would export it (`geometry.decimate`'s qslim gives up on these
    sheets: it returns no faces)."""
    import pyvista as pv

    poly = pv.PolyData(mesh.points, np.column_stack([np.full(mesh.n_faces, 3), mesh.faces]))
    out = poly.decimate(1.0 - DECIMATED_FRACTION)
    return TriMesh(np.asarray(out.points, dtype=float),
                   np.asarray(out.faces).reshape(-1, 4)[:, 1:].astype(np.int64))


def write_voxel_knee(folder: Path, spacing: float = 0.5, variant: str = "raw",
                     bones: bool = True) -> dict[str, Path]:
    """Write the voxel knee's STL files (mm) into `folder`; {role: path}."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    meshes = voxel_knee(spacing, variant)
    roles = ("femur", "tibia", "femur_bone", "tibia_bone") if bones else ("femur", "tibia")
    return {r: _write(meshes[r], folder / f"{r}.stl") for r in roles}
