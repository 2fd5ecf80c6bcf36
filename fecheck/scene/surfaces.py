"""The knee surfaces a scene reads from files: its ``[geometry]`` keys.

A scene names its femoral and tibial articular surfaces (and optionally their bones and
a ligament-bundle file) by path; relative paths resolve against ``geometry.dir``, itself
relative to the scene file's folder ("" = that folder; ``~`` and ``$VARIABLES`` are
expanded). Every file is read once per process and cached on disk by its content hash
and the conversion options (`geometry.cache`), so a second run of a scene reads no mesh
file. Conversion, in order: the length unit (``geometry.units``: millimetres or metres,
checked against the surface's extent), then the rigid transform (``rotation_deg``
about x, then y, then z, fixed axes; then ``translation_mm``) into the thesis frame:
mm, x right, y anterior, z superior, origin at the tibial plateau centre, femur and
tibia frames coinciding at the reference pose. ``geometry.dir = "fecheck:knee/lenhart2015"``
names the scanned knee packaged with fecheck (`fecheck.scene.packaged`).

The tibial surface is one file split into its compartments — its two largest connected
components (``tibia_split = "components"``) or the two sides of the sagittal plane
x = ``split_x_mm`` (``"sagittal"``) — or one file per compartment (``tibia`` medial,
``tibia_lateral`` lateral). The medial compartment is at -x in a right knee and +x in a
left one (``knee.side``). Articular normals must point out of the cartilage: up (+z) on
the tibia, down on an open femoral sheet (a closed femoral component: outward); a
surface whose normals point the other way is refused.
"""

from __future__ import annotations

import hashlib
import os
from functools import lru_cache
from pathlib import Path

import numpy as np

from fecheck.errors import FecheckError
from fecheck.scene import Scene, tibia_solid
from fecheck.scene.packaged import PACKAGE_PREFIX, data_dir
from geometry.cache import cached_build
from geometry.mesh import TriMesh, components, is_closed, submesh
from geometry.roughness import smooth_sheet

FILE_KEYS = ("femur", "tibia", "tibia_lateral", "femur_bone", "tibia_bone", "ligaments",
             "tibia_solid")
"""Keys of ``[geometry]`` that name a file."""
SHEET_KEYS = ("femur", "tibia", "tibia_lateral")
"""Keys of the articular sheets (``geometry.smooth_mm`` smooths them, not the bones)."""
BONE_KEYS = ("femur_bone", "tibia_bone")
"""Keys of the bones: only rays from the articular sheets read them (the bone-distance
thickness), so an edge shared by three or more faces is refused only where a ray meets
it (`fecheck.laws.layer.bone_distance_thickness`), not when the file is read."""
UNIT_SCALE = {"mm": 1.0, "m": 1000.0}
"""Millimetres per unit of each ``geometry.units``."""
KNEE_EXTENT_MM = (5.0, 1000.0)
"""Plausible bounding-box diagonal of a knee surface, mm: a cartilage sheet spans some
20-100 mm, a bone surface a few hundred."""
MIN_COMPONENT_SHARE = 0.01
"""Connected components with fewer than this share of a surface's faces are specks
(segmentation debris), not compartments."""


def base_dir(scene: Scene) -> Path:
    """The folder relative ``[geometry]`` paths resolve against."""
    scene_dir = Path(scene.source).expanduser().resolve().parent
    given = scene["geometry.dir"]
    if not given:
        return scene_dir
    if given.startswith(PACKAGE_PREFIX):
        return data_dir(given)
    folder = Path(os.path.expandvars(given)).expanduser()
    return folder if folder.is_absolute() else (scene_dir / folder).resolve()


def file_path(scene: Scene, key: str) -> Path | None:
    """The resolved path of ``geometry.<key>``, or None where the key is unset."""
    value = scene[f"geometry.{key}"]
    if not value:
        return None
    path = Path(os.path.expandvars(value)).expanduser()
    return path if path.is_absolute() else base_dir(scene) / path


def required_path(scene: Scene, key: str, why: str) -> Path:
    """`file_path`, or `FecheckError` saying which key to set and why, or which file is
    missing."""
    path = file_path(scene, key)
    if path is None:
        raise FecheckError(f"{scene.source}: {why} needs geometry.{key}, the path of its mesh "
                           "file (relative to geometry.dir, or to the scene file's folder)")
    if not path.is_file():
        where = (f" (geometry.dir = {scene['geometry.dir']!r})" if scene["geometry.dir"]
                 else "")
        what = (f"{path} is a directory: give the mesh file in it" if path.is_dir()
                else f"file not found at {path}")
        raise FecheckError(f"{scene.source}: geometry.{key} = {scene[f'geometry.{key}']!r}: "
                           f"{what}{where}")
    return path


def check_length_unit(points_mm: np.ndarray, path: str | Path, units: str = "mm") -> None:
    """`FecheckError` when a surface read as `units` does not span a knee's size in mm."""
    diagonal = float(np.linalg.norm(np.ptp(points_mm, axis=0))) if len(points_mm) else 0.0
    low, high = KNEE_EXTENT_MM
    if low <= diagonal <= high:
        return
    other = "m" if units == "mm" else "mm"
    as_other = diagonal * UNIT_SCALE[other] / UNIT_SCALE[units]
    hint = (f": it looks like {'metres' if other == 'm' else 'millimetres'} - set "
            f"geometry.units = '{other}'" if low <= as_other <= high else
            ": check its unit and scale")
    raise FecheckError(f"{path} spans {diagonal:.4g} mm across read in {units}; a knee surface "
                       f"spans {low:g}-{high:g} mm{hint}")


def rotation_matrix(angles_deg) -> np.ndarray:
    """R = R_z R_y R_x of rotations about the fixed x, y and z axes (deg), applied in that
    order."""
    ax, ay, az = np.radians(np.asarray(angles_deg, dtype=float))
    cx, sx, cy, sy, cz, sz = np.cos(ax), np.sin(ax), np.cos(ay), np.sin(ay), np.cos(az), np.sin(az)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


def file_digest(path: Path) -> str:
    """sha256 of a file's bytes (the cache key of its content)."""
    return _digest(str(path), path.stat().st_mtime_ns, path.stat().st_size)


@lru_cache(maxsize=64)
def _digest(path: str, mtime_ns: int, size: int) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def read_surface(path: str | Path, units: str = "mm", rotation_deg=(0.0, 0.0, 0.0),
                 translation_mm=(0.0, 0.0, 0.0), *, manifold: bool = True) -> TriMesh:
    """A triangle surface from any mesh file meshio reads, converted to mm and moved by
    the rigid transform; cached on disk by content and options, and kept in this
    process (the same mesh object for the same content and options).

    Raises `FecheckError` naming the file when it cannot be read, holds no triangles,
    has degenerate (zero-area) faces, or its extent says the unit is wrong; and, with
    `manifold`, when an edge is shared by three or more faces (`check_topology`).
    """
    path = Path(path)
    if path.is_dir():
        raise FecheckError(f"{path} is a directory, not a mesh file: give the mesh file in it")
    if not path.is_file():
        raise FecheckError(f"{path}: mesh file not found")
    return _converted(str(path), file_digest(path), units,
                      tuple(float(a) for a in rotation_deg),
                      tuple(float(t) for t in translation_mm), manifold)


@lru_cache(maxsize=32)
def _converted(path: str, digest: str, units: str, rotation_deg: tuple,
               translation_mm: tuple, manifold: bool) -> TriMesh:
    from geometry.io import load_mesh

    path = Path(path)
    params = {"sha256": digest, "units": units, "rotation_deg": list(rotation_deg),
              "translation_mm": list(translation_mm)}

    def build() -> TriMesh:
        mesh = load_mesh(path)
        if not isinstance(mesh, TriMesh):
            raise FecheckError(f"{path}: holds tetrahedra; give its articular surface as "
                               "triangles")
        rot = rotation_matrix(rotation_deg)
        points = mesh.points * UNIT_SCALE[units]
        check_length_unit(points, path, units)
        return TriMesh(points @ rot.T + np.asarray(translation_mm, dtype=float), mesh.faces)

    mesh = cached_build("surface", params, build, version=1)
    area = mesh.face_areas
    bad = int(np.count_nonzero(area <= 1e-12 * max(float(area.max(initial=0.0)), 1e-300)))
    if bad:
        raise FecheckError(f"{path}: {bad} of {mesh.n_faces} faces have zero area "
                           "(degenerate triangles); clean the mesh (merge duplicate "
                           "vertices, remove collapsed faces) and export it again")
    check_topology(mesh, path, manifold=manifold)
    return mesh


def around(points: np.ndarray) -> str:
    """Where `points` (k, 3) are, for a message: "around (x, y, z) mm" of their mean."""
    x, y, z = points.reshape(-1, 3).mean(axis=0)
    return f"around ({x:+.1f}, {y:+.1f}, {z:+.1f}) mm"


def check_topology(mesh: TriMesh, path: str | Path, *, manifold: bool = True) -> None:
    """`FecheckError` naming the file for faces that repeat another face's three vertices
    (counted twice by one part of a run and once by another) and, with `manifold`, for
    edges shared by three or more faces (no sheet: its normals and sides are undefined
    there)."""
    tri = np.sort(mesh.faces, axis=1)
    order = np.lexsort(tri.T[::-1])
    repeat = np.flatnonzero((tri[order[1:]] == tri[order[:-1]]).all(axis=1))
    if len(repeat):
        copies = order[repeat + 1]
        raise FecheckError(f"{path}: {len(copies)} of {mesh.n_faces} faces repeat the three "
                           f"vertices of another face (duplicate faces, "
                           f"{around(mesh.face_centroids[copies])}); remove the duplicates "
                           "(e.g. MeshLab: Remove Duplicate Faces) and export it again")
    if not manifold:
        return
    edges = tri[:, [0, 1, 1, 2, 0, 2]].reshape(-1, 2).astype(np.int64)
    key = np.sort(edges[:, 0] * mesh.n_points + edges[:, 1])
    shared = np.unique(key[2:][key[2:] == key[:-2]])         # on three faces or more
    if len(shared):
        ends = np.column_stack(np.divmod(shared, mesh.n_points))
        raise FecheckError(f"{path}: {len(shared)} edges are shared by three or more faces "
                           f"(non-manifold, {around(mesh.points[ends])}), where a surface "
                           "is one sheet; remove the extra faces there (e.g. MeshLab: Select "
                           "Non Manifold Edges, then delete) and export it again")


def surface(scene: Scene, key: str, why: str) -> TriMesh:
    """The surface of ``geometry.<key>`` (mm, thesis frame); `why` names its use in the
    message when it is unset."""
    path = required_path(scene, key, why)
    mesh = read_surface(path, scene["geometry.units"], tuple(scene["geometry.rotation_deg"]),
                        tuple(scene["geometry.translation_mm"]), manifold=key not in BONE_KEYS)
    return smooth_sheet(mesh, scene["geometry.smooth_mm"]) if key in SHEET_KEYS else mesh


SCENE_SPLIT_FIX = ("set geometry.tibia_split = 'sagittal' (with geometry.split_x_mm, the x "
                   "between the plateaus) or give one file per compartment "
                   "(geometry.tibia_lateral)")
"""What to change when a scene's tibia does not split into its two connected pieces."""


def split_faces(mesh: TriMesh, split: str, x_mm: float, side: str, name: str,
                fix: str = SCENE_SPLIT_FIX) -> dict[str, np.ndarray]:
    """{medial, lateral}: the face indices of each compartment of one tibial surface, its
    two connected pieces (`split` "components", specks left out) or the two sides of the
    plane x = `x_mm` ("sagittal"); medial at -x in a right knee (`side`). `FecheckError`
    (naming the surface `name`, and `fix` when it is not in two pieces) when the surface
    does not split so."""
    if split == "components":
        pair = [p for p in components(mesh) if len(p) >= MIN_COMPONENT_SHARE * mesh.n_faces]
        if len(pair) != 2:
            sizes = ", ".join(str(len(p)) for p in pair)
            raise FecheckError(f"{name}: a split into connected pieces needs the two "
                               f"compartments as two separate pieces, but the surface has "
                               f"{len(pair)} ({sizes} faces); {fix}")
    else:
        left = mesh.face_centroids[:, 0] < x_mm
        if left.all() or not left.any():
            raise FecheckError(f"{name}: the sagittal plane x = {x_mm:g} mm leaves every "
                               f"face on one side; the surface spans x = "
                               f"{mesh.points[:, 0].min():.1f} to "
                               f"{mesh.points[:, 0].max():.1f} mm")
        pair = [np.flatnonzero(left), np.flatnonzero(~left)]
    area, x = mesh.face_areas, mesh.face_centroids[:, 0]
    mean_x = [float(np.average(x[p], weights=area[p])) for p in pair]
    low, high = (pair[0], pair[1]) if mean_x[0] < mean_x[1] else (pair[1], pair[0])
    return {"medial": low, "lateral": high} if side == "right" else {"medial": high,
                                                                      "lateral": low}


def _one_piece(mesh: TriMesh, path: Path) -> TriMesh:
    """`mesh` without specks; `FecheckError` if it has several real components."""
    parts = components(mesh)
    real = [p for p in parts if len(p) >= MIN_COMPONENT_SHARE * mesh.n_faces]
    if len(real) > 1:
        sizes = ", ".join(str(len(p)) for p in real)
        raise FecheckError(f"{path}: one compartment per file was expected, but the surface "
                           f"has {len(real)} separate pieces ({sizes} faces); give one "
                           "compartment per file, or both in geometry.tibia with "
                           "geometry.tibia_split")
    return mesh if len(parts) == 1 else submesh(mesh, real[0])


def tibial_compartments(scene: Scene) -> dict[str, TriMesh]:
    """{medial, lateral}: the tibial articular surface split into its compartments (mm,
    thesis frame; their winding is checked with the other sheet checks before the
    solve, `geometry.sheet_checks.check_winding`). Without ``geometry.tibia`` but
    with a closed ``geometry.tibia_solid``: the solid's up-facing part
    (`articular_sheets`)."""
    if file_path(scene, "tibia") is None and file_path(scene, "tibia_solid") is not None:
        return articular_sheets(scene)
    why = f"model.kind = {scene['model.kind']!r} (the tibial articular surface)"
    path = required_path(scene, "tibia", why)
    side = scene.side
    if file_path(scene, "tibia_lateral") is not None:
        lateral_path = required_path(scene, "tibia_lateral", why)
        if file_digest(lateral_path) == file_digest(path):
            raise FecheckError(f"{scene.source}: geometry.tibia and geometry.tibia_lateral name "
                               f"the same surface ({path.name}, {lateral_path.name}); give "
                               "the lateral compartment's own file in geometry.tibia_lateral, "
                               "or leave it unset to split geometry.tibia "
                               "(geometry.tibia_split)")
        medial = _one_piece(surface(scene, "tibia", why), path)
        lateral = _one_piece(surface(scene, "tibia_lateral", why), lateral_path)
        out = {"medial": medial, "lateral": lateral}
    else:
        mesh = surface(scene, "tibia", why)
        faces = split_faces(mesh, scene["geometry.tibia_split"], scene["geometry.split_x_mm"],
                            side, f"{path} (geometry.tibia_split)")
        out = {c: submesh(mesh, f) for c, f in faces.items()}
    return out


def solid_surface(scene: Scene) -> TriMesh:
    """The closed tibial solid of ``geometry.tibia_solid`` (mm, thesis frame, outward)."""
    path = required_path(scene, "tibia_solid", "the tibial solid")
    return tibia_solid.outward(surface(scene, "tibia_solid", "the tibial solid"), str(path))


def articular_sheets(scene: Scene) -> dict[str, TriMesh]:
    """{medial, lateral}: the up-facing part of the solid split by
    ``geometry.tibia_split`` (the EF's sheet when no ``geometry.tibia`` is given)."""
    solid = solid_surface(scene)
    faces = tibia_solid.up_facing(solid)
    if len(faces) == 0:
        raise FecheckError(f"{tibia_solid.KEY}: no face of the solid faces up (+z, toward "
                           "the femur): check geometry.rotation_deg")
    top = submesh(solid, faces)
    split = split_faces(top, scene["geometry.tibia_split"],
                        scene["geometry.split_x_mm"], scene.side,
                        f"{tibia_solid.KEY} (its up-facing part, geometry.tibia_split)")
    return {c: submesh(top, f) for c, f in split.items()}


def mean_normal_z(mesh: TriMesh, faces: np.ndarray | None = None) -> float:
    """Area-weighted mean z of the unit normals of `faces` (all if None)."""
    faces = np.arange(mesh.n_faces) if faces is None else faces
    area = mesh.face_areas[faces]
    return float(np.sum(mesh.face_normals[faces, 2] * area) / max(area.sum(), 1e-300))


def check_normals(mesh: TriMesh, name: str, *, up: bool) -> None:
    """`FecheckError` when an articular surface's area-weighted mean normal points the
    wrong way along z (tibia: up, toward the femur; femur: down, toward the tibia)."""
    mean = mean_normal_z(mesh)
    if (mean > 0) != up:
        want, got = ("up (+z)", "down") if up else ("down (-z)", "up")
        raise FecheckError(f"{name}: its normals point {got} (mean n_z = {mean:+.2f}), but an "
                           f"articular surface's normals point out of the cartilage, "
                           f"{want}: reverse the face winding (or check "
                           "geometry.rotation_deg)")


def femoral_surface(scene: Scene) -> TriMesh:
    """The femoral articular surface (mm, thesis frame): an open sheet with normals
    pointing down, or a closed surface (an implant component) with outward normals."""
    mesh = surface(scene, "femur", f"model.kind = {scene['model.kind']!r} (the femoral "
                   "articular surface)")
    if not is_closed(mesh):         # a closed component: the contact refuses it inside out
        check_normals(mesh, required_path(scene, "femur", "").name, up=False)
    return mesh


def bone(scene: Scene, which: str) -> TriMesh:
    """The femoral or tibial bone surface (``which`` "femur" or "tibia"), mm; a warning
    naming the place of its non-manifold edges (`bone_defect`), if any."""
    import warnings

    key = f"{which}_bone"
    mesh = surface(scene, key, f"scanned.thickness = 'bone-distance' (the {which}'s bone, "
                   "for the cartilage thickness)")
    defect = bone_defect(mesh, f"geometry.{key} ({required_path(scene, key, '').name})")
    if defect:
        warnings.warn(defect, stacklevel=2)
    return mesh


def bone_defect(mesh: TriMesh, name: str) -> str:
    """What a bone's non-manifold edges mean for the run, with their place, or "" (none)."""
    from geometry.checks import non_manifold_faces

    faces = non_manifold_faces(mesh)
    if len(faces) == 0:
        return ""
    edges = int(np.count_nonzero(mesh.edge_table.counts > 2))
    return (f"{name}: {edges} edges shared by three or more faces (non-manifold, "
            f"{around(mesh.face_centroids[faces])}): the bone-distance thickness reads the "
            "bone only along rays from the articular sheets, and a run is refused only where "
            "one meets these faces")
