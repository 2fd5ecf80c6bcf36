"""Import a knee's surface files as a checked, documented femur-tibia scene (`fecheck knee
import`).

The femoral and tibial articular surfaces (and optionally the two bones) are read as a
scene reads them (`fecheck.scene.surfaces.read_surface`: unit by extent, NaN, degenerate
and duplicate faces, edges shared by three or more faces) and checked, one printed line
per check: extent, size, open or closed, connected pieces, normals (tibia up, femoral
sheet down, closed femur outward) and, per tibial compartment, the signed rest gap to the
femoral surface (+ gap, - overlap, mm) and the tibial area within `NEAR_MM` of it; files
that look swapped (femur and tibia, or the two bones: each bone on the far side of its
sheet) are refused with the options to give; with both bones, each sheet's bone-distance
thickness (a bone's non-manifold edge warned with its place, refused where the thickness
rays meet it). The tibia is split into its medial and lateral compartments (connected
components, a sagittal plane checked against the femoral condyles over the tibia, or one
file each). Inverted
normals are repaired: a copy with reversed face winding is written beside the scene
(``<scene-stem>_<role>_fixed.stl``) and the scene names it. Then a ``model.kind =
"femur-tibia"`` scene is written with a comment above each key and reloaded as a check;
what the FE meets in it is checked (`fe_checks`: the layer's extrusion as `fecheck fe`
extrudes it, faces facing down, slivers; warnings naming the file, place and key), and a
preview PNG is drawn beside it (`fecheck.io.knee_preview`). Messages name the options of
`fecheck knee import`. Units mm.

Only the standard library is imported at module level; the mesh work inside the functions.
"""

from __future__ import annotations

import os
import textwrap
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np

    from geometry.mesh import TriMesh

ROLES = ("femur", "tibia", "tibia_lateral", "femur_bone", "tibia_bone")
"""The files of a knee, by their ``[geometry]`` key."""
OVERLAP_LIMIT_MM = 2.0
"""A rest-pose overlap deeper than this means the meshes do not share a frame/pose, mm."""
GAP_LIMIT_MM = 10.0
"""A smallest rest gap wider than this means different frames or units, mm."""
NEAR_MM = 1.0
"""The rest-gap threshold of the printed near-contact area, mm."""
ANKLE_Z_MM = -300.0
"""z of the default load point (on the joint axis, about an ankle below the knee), mm."""
THICKNESS_MM = 6.0
"""Uniform cartilage thickness when the bones are not both given (the thesis's), mm."""
CONDYLE_NEAR_MM = 3.0
"""Faces within this of the closest femur-tibia approach are over a condyle's contact, mm."""
SLIVER_DEG = 5.0
"""A face with an angle under this is a sliver: its tetrahedra make the FE ill-conditioned."""
SHORT_EDGE_SHARE = 0.1
"""A face with an edge under this share of the sheet's median edge is a sliver too."""
ROUGH_RMS_MM = 0.05
"""A sheet further than this (RMS) from its smoothed copy is rough for the FE: its vertex
peaks follow the segmentation's terraces, mm (a smooth scanned sheet: about 0.02)."""
MAX_FACES = 200_000
"""Most faces of one file the import checks: its roughness and gap checks grow faster than
the faces (measured on the synthetic test knee, two dishes under two caps, refined, on 2
cores under a load of about 15: 48,400 faces a file 64 s and 0.77 GB, 193,600 a file 8.2
min and 8.0 GB). A segmented knee's sheets have a few thousand to a hundred thousand faces
(the packaged one: 4,244 medial; the test knee voxelized at 0.3 mm: 126,433 femoral)."""
MISPLIT_SHARE = 0.1
"""A sagittal plane that puts more than this share of the tibial area under the femoral
condyles on the other side than its condyle cuts a plateau: an error."""


@dataclass(frozen=True)
class Options:
    """The import's choices: length unit of the files ("mm" or "m"), knee side ("right"
    or "left"), tibia split ("components", "sagittal" or "files"), x of the sagittal
    plane (mm, None: 0), axial load (N), the fecheck version named in the scene's header."""

    units: str = "mm"
    side: str = "right"
    split: str = "components"
    split_x: float | None = None
    load_N: float = 800.0
    version: str = "unknown"


def _option(role: str) -> str:
    return "--" + role.replace("_", "-")


def _say(who: str, check: str, text: str) -> None:
    """One printed check line."""
    print(f"{who:<13} {check:<11} {text}")



@dataclass
class Surface:
    """One input file: its mesh (mm, normals repaired) and the file the scene names."""

    role: str
    source: Path
    mesh: TriMesh
    parts: list[np.ndarray]           # face indices of its real connected pieces
    file: Path                        # `source`, or its repaired copy
    flipped: np.ndarray | None = None  # (n_faces,) bool: winding reversed by the repair



def import_knee(files: dict[str, Path], output: Path, opts: Options) -> Path:
    """Check the knee surface `files` ({role in `ROLES`: path}; femur and tibia needed),
    write the scene `output` (a ``.toml`` file), the repaired copies and the preview beside it,
    printing one line per check; the scene's path. `FecheckError` on one line naming the
    file and the fix for what no scene can run."""
    import warnings

    from fecheck.errors import FecheckError
    from fecheck.io.knee_preview import write_knee_preview
    from fecheck.io.outputs import check_output, write_text
    from geometry.io import face_count
    from geometry.mesh import is_closed

    split = opts.split
    if not opts.load_N > 0:
        raise FecheckError(f"--load-N {opts.load_N:g}: the load must be a positive force, N")
    if output.suffix.lower() != ".toml":
        raise FecheckError(f"-o {output}: the scene is a TOML file; name it *.toml")
    out = check_output(output)
    for r, p in files.items():                  # every file's size before reading any
        if Path(p).is_file():
            _check_faces(_option(r), Path(p), face_count(p))
    surf = {r: _read(r, Path(p), opts.units) for r, p in files.items()}
    _check_order(surf)
    _femur_normals(surf["femur"])
    parts = _split(surf, split, 0.0 if opts.split_x is None else opts.split_x, opts.side)
    tibia = _tibia_normals(surf, parts)
    gaps = _rest_gaps(surf["femur"].mesh, tibia)
    bones = [r for r in ("femur_bone", "tibia_bone") if r in surf]
    if len(bones) == 2:
        _check_bones(surf, tibia)
    for s in surf.values():
        _write_repaired(s, out, opts.units)
    if len(bones) == 1:
        print(f"note: {_option(bones[0])} alone: the bone-distance thickness needs both "
              f"bones; the scene uses a uniform {THICKNESS_MM:g} mm layer")
    scene_files = {r: s.file for r, s in surf.items() if len(bones) == 2 or r not in bones}
    write_text(out, scene_text(out, scene_files, opts, tibia, gaps,
                               is_closed(surf["femur"].mesh)))
    _say("scene", "written", f"{out}  (run it: fecheck run {out})")
    with warnings.catch_warnings():      # a bone's defect: warned once above, in our words
        warnings.filterwarnings("ignore", message=r"geometry\.(femur|tibia)_bone ")
        _reload(out, tibia)
        fe_checks(out, {c: surf[role].source for c, (role, _) in parts.items()})
    names = " + ".join(surf[r].source.name for r in ("tibia", "tibia_lateral") if r in surf)
    png = write_knee_preview(
        out.with_name(f"{out.stem}_preview.png"), surf["femur"].mesh, tibia, gaps,
        {r.split("_")[0]: surf[r].mesh for r in bones},
        f"{out.name}: {surf['femur'].source.name} on {names} ({opts.side} knee, rest pose)")
    _say("preview", "written", str(png))
    return out



# ------------------------------------------------------------------------- reading
def _read(role: str, path: Path, units: str) -> Surface:
    """Read one file as a scene would and print its checks; `FecheckError` naming the
    option and the file when it is missing, unreadable or not a knee surface in `units`
    (a bone's non-manifold edges: a warning, `fecheck.scene.surfaces.BONE_KEYS`)."""
    import warnings

    import numpy as np

    from fecheck.errors import FecheckError
    from fecheck.scene.surfaces import (
        BONE_KEYS,
        MIN_COMPONENT_SHARE,
        bone_defect,
        read_surface,
    )
    from geometry.checks import edge_counts
    from geometry.mesh import components

    who = _option(role)
    if path.is_dir():
        raise FecheckError(f"{who} {path} is a directory: give the mesh file in it")
    if not path.is_file():
        raise FecheckError(f"{who} {path}: file not found")
    try:
        mesh = read_surface(path, units, manifold=role not in BONE_KEYS)
    except FecheckError as err:            # the scene's wording names its key: name ours
        text = str(err)
        for unit in ("m", "mm"):
            text = text.replace(f"set geometry.units = '{unit}'", f"give --units {unit}")
        raise FecheckError(f"{who}: {text}" if str(path) in text
                           else f"{who} {path}: {text}") from None
    except OSError as err:
        raise FecheckError(f"{who} {path}: cannot read: {err.strerror or err}") from None
    _check_faces(who, path, mesh.n_faces)
    name = role.replace("_", "-")
    ext = np.ptp(mesh.points, axis=0)
    _say(name, "file", str(path))
    _say(name, "units", f"read in {units}: extent {ext[0]:.1f} x {ext[1]:.1f} x {ext[2]:.1f} "
         f"mm (diagonal {np.linalg.norm(ext):.0f} mm; a knee surface spans 5-1000 mm): ok")
    defect = bone_defect(mesh, f"{who} {path}") if role in BONE_KEYS else ""
    _say(name, "mesh", f"{mesh.n_points:,} vertices, {mesh.n_faces:,} faces; no NaN, no "
         "degenerate or duplicate face" + ("" if defect else ", no edge shared by 3+ faces"))
    if defect:
        warnings.warn(defect, stacklevel=2)
    boundary, _, opposed = edge_counts(mesh.faces)
    closure = ("closed (every edge shared by two faces)" if boundary == 0
               else f"open sheet ({boundary:,} boundary edges)")
    winding = (f"; {opposed:,} edges join faces of opposite winding (normals flip across "
               "them)" if opposed else "; winding consistent")
    _say(name, "closure", closure + winding)
    pieces = components(mesh)
    parts = [p for p in pieces if len(p) >= MIN_COMPONENT_SHARE * mesh.n_faces]
    specks = len(pieces) - len(parts)
    _say(name, "components", f"{len(parts)} ({', '.join(f'{len(p):,}' for p in parts)} faces)"
         + (f" + {specks} specks under 1% of the faces (left out)" if specks else ""))
    return Surface(role, path, mesh, parts, path)


# ------------------------------------------------------------------------- order
def _height(mesh: TriMesh) -> float:
    """Area-weighted mean z of the faces of `mesh`, mm."""
    import numpy as np

    return float(np.average(mesh.face_centroids[:, 2], weights=mesh.face_areas))


def _check_order(surf: dict[str, Surface]) -> None:
    """`FecheckError` when the femoral and tibial files look swapped: the femoral surface
    lies below the tibial one (their area-weighted mean heights) and each one's normals
    point the way the other's should (an open femoral sheet's up, the tibia's down)."""
    from fecheck.errors import FecheckError
    from fecheck.scene.surfaces import mean_normal_z
    from geometry.mesh import is_closed

    femur = surf["femur"].mesh
    tibia = [surf[r] for r in ("tibia", "tibia_lateral") if r in surf]
    below = max(_height(s.mesh) for s in tibia) - _height(femur)
    facing = (not is_closed(femur) and mean_normal_z(femur) > 0
              and all(mean_normal_z(s.mesh) < 0 for s in tibia))
    if below < 0 or not facing:
        return
    f = surf["femur"].source
    fix = (f"give --femur {tibia[0].source} --tibia {f}" if len(tibia) == 1 else
           "give the femoral surface in --femur and the tibial compartments in --tibia "
           "and --tibia-lateral")
    raise FecheckError(f"--femur {f} lies {below:.1f} mm below the tibial surface (mean "
                       "heights; z is superior) and each one's normals point the way the "
                       f"other's should: the femoral and tibial files look swapped: {fix}")


def _check_faces(who: str, path: Path, faces: int | None) -> None:
    """`FecheckError` before the checks when the file has more than `MAX_FACES` faces
    (None: not known yet)."""
    from fecheck.errors import FecheckError

    if faces is None or faces <= MAX_FACES:
        return
    raise FecheckError(f"{who} {path}: {faces:,} faces, more than the {MAX_FACES:,} the import "
                       f"checks in minutes (its checks grow faster than the faces: 194k "
                       f"faces took 8 min and 8 GB): decimate it to at most {MAX_FACES:,} "
                       "faces (a quadric edge collapse, e.g. MeshLab's or Open3D's "
                       "simplify_quadric_decimation) and import it again")


# ------------------------------------------------------------------------- normals
def _flip(s: Surface, faces: np.ndarray) -> None:
    """Reverse the winding of `faces` of `s` (its normals point the other way)."""
    import numpy as np

    from geometry.mesh import TriMesh

    if s.flipped is None:
        s.flipped = np.zeros(s.mesh.n_faces, dtype=bool)
    s.flipped[faces] = ~s.flipped[faces]
    new = s.mesh.faces.copy()
    new[faces] = new[faces, ::-1]
    s.mesh = TriMesh(s.mesh.points, new)


def _femur_normals(s: Surface) -> None:
    """Check (and repair) the femur's normals: down for a sheet, outward if closed."""
    from geometry.mesh import is_closed

    if is_closed(s.mesh):
        volume = s.mesh.signed_volume
        ok, found = volume > 0, f"closed, signed volume {volume:+,.0f} mm³"
        want = "outward"
    else:
        from fecheck.scene.surfaces import mean_normal_z

        nz = mean_normal_z(s.mesh)
        ok, found = nz < 0, f"area-weighted mean n_z = {nz:+.2f}"
        want = "down, toward the tibia"
    if ok:
        _say("femur", "normals", f"{want}: {found}: ok")
        return
    _flip(s, slice(None))
    _say("femur", "normals", f"inverted ({found}); repaired: winding reversed, {want}")


def _tibia_normals(surf: dict[str, Surface], parts: dict) -> dict[str, TriMesh]:
    """Check (and repair) each tibial compartment's normals (up, toward the femur);
    the compartment meshes, mm."""
    from fecheck.errors import FecheckError
    from fecheck.scene.surfaces import mean_normal_z
    from geometry.mesh import is_closed, submesh

    out = {}
    for c, (role, faces) in parts.items():
        s = surf[role]
        if is_closed(submesh(s.mesh, faces)):
            raise FecheckError(f"{_option(role)} {s.source}: the {c} tibial compartment is a "
                               "closed surface; give its articular (top) surface as an open "
                               "sheet, normals up")
        nz = mean_normal_z(s.mesh, faces)
        if nz > 0:
            _say(c, "normals", f"up, toward the femur: area-weighted mean n_z = {nz:+.2f}: ok")
        else:
            _flip(s, faces)
            _say(c, "normals", f"inverted (area-weighted mean n_z = {nz:+.2f}); repaired: "
                 "winding reversed, up")
        out[c] = submesh(s.mesh, faces)
    return out


def _write_repaired(s: Surface, out: Path, units: str) -> None:
    """Write the repaired copy of a surface whose winding was reversed beside the scene
    (in the file's own unit) and point the scene at it."""
    from geometry.io import load_mesh, save_mesh
    from geometry.mesh import TriMesh

    if s.flipped is None or not s.flipped.any():
        return
    raw = load_mesh(s.source)                # the file's points, unconverted
    faces = raw.faces.copy()
    faces[s.flipped] = faces[s.flipped, ::-1]
    s.file = save_mesh(TriMesh(raw.points, faces), out.with_name(f"{out.stem}_{s.role}_fixed"
                                                                 ".stl"))
    print(f"note: {_option(s.role)} {s.source.name} had inverted normals: the scene reads "
          f"the repaired copy {s.file} ({int(s.flipped.sum()):,} faces with reversed "
          f"winding, in {units})")


# ------------------------------------------------------------------------- split
def _split(surf: dict[str, Surface], split: str, split_x: float, side: str) -> dict:
    """{medial, lateral}: (role, face indices) of each tibial compartment, as the scene
    splits them (`fecheck.scene.surfaces.tibial_compartments`); printed."""
    from fecheck.errors import FecheckError

    if split == "files":
        parts, how = _split_files(surf), {"medial": "--tibia file",
                                          "lateral": "--tibia-lateral file"}
    else:
        over = _condyles(surf["femur"].mesh, surf["tibia"].mesh)
        parts, label = _split_one(surf["tibia"], split, split_x, side, over)
        how = dict.fromkeys(parts, label)
        if split == "sagittal" and over is not None:
            _check_plane(surf["tibia"], split_x, over)
    centre = {c: _centroid(surf[role].mesh, faces) for c, (role, faces) in parts.items()}
    medial_at = "-" if side == "right" else "+"
    if split == "files" and (centre["medial"][0] > centre["lateral"][0]) == (side == "right"):
        raise FecheckError(
            f"--tibia {surf['tibia'].source} is the medial compartment, but it lies at "
            f"x = {centre['medial'][0]:+.1f} mm and --tibia-lateral at "
            f"x = {centre['lateral'][0]:+.1f} mm, while the medial compartment of a {side} "
            f"knee is at {medial_at}x: swap the files or check --side")
    for c, (_, faces) in parts.items():
        x, y, z = centre[c]
        _say(c, "split", f"{how[c]}: {len(faces):,} faces, centroid ({x:+.1f}, {y:+.1f}, "
             f"{z:+.1f}) mm ({side} knee: medial at {medial_at}x)")
    return parts


def _split_files(surf: dict[str, Surface]) -> dict:
    """One compartment per file (specks left out); `FecheckError` if a file has more, or
    if both name the same surface."""
    from fecheck.errors import FecheckError
    from fecheck.scene.surfaces import file_digest

    a, b = surf["tibia"].source, surf["tibia_lateral"].source
    if file_digest(a) == file_digest(b):
        raise FecheckError(f"--tibia {a} and --tibia-lateral {b} are the same surface: give "
                           "the lateral compartment's own file in --tibia-lateral, or leave "
                           "it out and split --tibia into its compartments (--split)")
    for role in ("tibia", "tibia_lateral"):
        s = surf[role]
        if len(s.parts) > 1:
            sizes = ", ".join(f"{len(p):,}" for p in s.parts)
            raise FecheckError(
                f"{_option(role)} {s.source}: one compartment per file was expected, but "
                f"the surface has {len(s.parts)} separate pieces ({sizes} faces); give "
                "one compartment per file, or both in --tibia alone (split by --split)")
    return {"medial": ("tibia", surf["tibia"].parts[0]),
            "lateral": ("tibia_lateral", surf["tibia_lateral"].parts[0])}


def _split_one(s: Surface, split: str, split_x: float, side: str,
               over: Condyles | None) -> tuple[dict, str]:
    """One tibia file split into its two pieces or by the plane x = `split_x`, as the
    scene splits it (`fecheck.scene.surfaces.split_faces`); the parts and how they were
    found."""
    from fecheck.scene.surfaces import split_faces

    plane = "" if over is None else f" {over.gap_x:.1f}"
    fix = (f"give --split sagittal --split-x{plane} (the plane between the femoral "
           "condyles) or one file per compartment (--tibia-lateral)")
    faces = split_faces(s.mesh, split, split_x, side, f"--tibia {s.source}", fix)
    label = "connected piece" if split == "components" else f"x vs {split_x:g} mm"
    return {c: ("tibia", f) for c, f in faces.items()}, label


@dataclass(frozen=True)
class Condyles:
    """The tibia under the two femoral condyles: the x of the gap between the condyles'
    contact regions (mm), their centres' x (mm), and per tibial face whether it lies under
    a condyle (within `CONDYLE_NEAR_MM` of the closest approach) and under which (True:
    the condyle at larger x)."""

    gap_x: float
    centres_x: tuple[float, float]
    near: np.ndarray
    high: np.ndarray


def _condyles(femur: TriMesh, tibia: TriMesh) -> Condyles | None:
    """The femoral faces over the tibia split into two condyles by the least-squares
    two-cluster split of their x (area-weighted), and the tibial faces under each; None
    when fewer than two femoral faces are over the tibia."""
    import numpy as np
    from scipy.spatial import cKDTree

    centroids = femur.face_centroids
    dist = cKDTree(tibia.points).query(centroids)[0]
    over = dist <= dist.min() + CONDYLE_NEAR_MM
    if np.count_nonzero(over) < 2:
        return None
    x, w = centroids[over, 0], femur.face_areas[over]
    order = np.argsort(x)
    x, w = x[order], w[order]
    s0, s1, s2 = np.cumsum(w), np.cumsum(w * x), np.cumsum(w * x * x)
    l0, l1, l2 = s0[:-1], s1[:-1], s2[:-1]
    r0, r1, r2 = s0[-1] - l0, s1[-1] - l1, s2[-1] - l2
    k = int(np.argmin(l2 - l1 ** 2 / l0 + r2 - r1 ** 2 / r0))
    gap = 0.5 * float(x[k] + x[k + 1])
    reach, which = cKDTree(centroids[over]).query(tibia.face_centroids)
    return Condyles(gap, (float(l1[k] / l0[k]), float(r1[k] / r0[k])),
                    reach <= reach.min() + CONDYLE_NEAR_MM, centroids[over, 0][which] > gap)


def _check_plane(s: Surface, split_x: float, over: Condyles) -> None:
    """`FecheckError` when the sagittal plane x = `split_x` puts more than `MISPLIT_SHARE`
    of the tibial area under the femoral condyles on the other side than its condyle."""
    from fecheck.errors import FecheckError

    area = s.mesh.face_areas
    wrong = over.near & ((s.mesh.face_centroids[:, 0] >= split_x) != over.high)
    share = float(area[wrong].sum() / area[over.near].sum())
    if share > MISPLIT_SHARE:
        a, b = over.centres_x
        raise FecheckError(
            f"--tibia {s.source}: the plane x = {split_x:g} mm puts {share:.0%} of the tibial "
            f"area under the femoral condyles (at x = {a:+.1f} and {b:+.1f} mm) on the far "
            f"side from its condyle: it cuts a plateau; give --split-x {over.gap_x:.1f} (the "
            "gap between the condyles) or one file per compartment (--tibia-lateral)")


def _centroid(mesh: TriMesh, faces) -> np.ndarray:
    """Area-weighted centroid of `faces`, mm."""
    import numpy as np

    return np.average(mesh.face_centroids[faces], axis=0, weights=mesh.face_areas[faces])


# ------------------------------------------------------------------------- rest pose
def _rest_gaps(femur: TriMesh, tibia: dict[str, TriMesh]) -> dict[str, np.ndarray]:
    """{compartment: (n_points,) signed rest gap of each tibial vertex to the femoral
    surface, mm (+ gap, - overlap)}, with the depth sign of the contact model (side of the
    closest femoral face's normal); `FecheckError` when a compartment overlaps by more
    than `OVERLAP_LIMIT_MM` or stands off by more than `GAP_LIMIT_MM`."""
    from fecheck.contact.mesh_master import MeshMaster
    from fecheck.errors import FecheckError

    master = MeshMaster(femur)
    gaps = {c: -master.depth_values(m.points) for c, m in tibia.items()}
    for c, mesh in tibia.items():
        g = gaps[c]
        i = int(g.argmin())
        low = round(float(g[i]), 2) + 0.0
        near = float(mesh.face_areas[g[mesh.faces].mean(axis=1) < NEAR_MM].sum())
        x, y, z = mesh.points[i]
        _say(c, "rest gap", f"smallest {low:+.2f} mm ({'gap' if low >= 0 else 'overlap'}) "
             f"at ({x:+.1f}, {y:+.1f}, {z:+.1f}) mm; {near:,.0f} mm² of tibial faces within "
             f"{NEAR_MM:g} mm of the femur")
    for c, g in gaps.items():
        low = float(g.min())
        if low < -OVERLAP_LIMIT_MM:
            raise FecheckError(
                f"the {c} tibial compartment overlaps the femoral surface by {-low:.2f} mm at "
                f"rest (more than {OVERLAP_LIMIT_MM:g} mm): the meshes do not share a "
                "frame/rest pose; export femur and tibia in one frame at the same pose")
        if low > GAP_LIMIT_MM:
            raise FecheckError(
                f"the {c} tibial compartment is {low:.1f} mm from the femoral surface at its "
                f"closest (more than {GAP_LIMIT_MM:g} mm): the meshes are probably in "
                "different frames or units; export femur and tibia in one frame at the "
                "rest pose (check --units)")
    return gaps


# ------------------------------------------------------------------------- bones
def _check_bones(surf: dict[str, Surface], tibia: dict[str, TriMesh]) -> None:
    """Each bone on the far side of its articular sheet (the femoral bone above the
    femoral sheet, the tibial bone below the tibial sheet; `FecheckError` naming the swap
    otherwise), and the bone-distance thickness of each sheet (refused where its rays meet
    a bone's non-manifold edge), printed."""
    import numpy as np

    from fecheck.errors import FecheckError
    from fecheck.laws.layer import bone_distance_thickness

    femur, tibia_z = surf["femur"].mesh, min(_height(m) for m in tibia.values())
    above = _height(surf["femur_bone"].mesh) - _height(femur)
    below = _height(surf["tibia_bone"].mesh) - tibia_z
    if above <= 0 or below >= 0:
        f, t = surf["femur_bone"].source, surf["tibia_bone"].source
        swapped = above <= 0 and below >= 0
        where = (f"--femur-bone {f} lies {-above:.1f} mm below the femoral sheet and "
                 f"--tibia-bone {t} {below:.1f} mm above the tibial sheet" if swapped else
                 f"--femur-bone {f} lies {-above:.1f} mm below the femoral sheet" if above <= 0
                 else f"--tibia-bone {t} lies {below:.1f} mm above the tibial sheet")
        fix = ("the bone files look swapped: give --femur-bone "
               f"{t} --tibia-bone {f}" if swapped else
               "each bone must lie on the far side of its cartilage (the femoral bone above "
               "the femoral sheet, the tibial bone below the tibial sheet): check the files "
               "and their frame")
        raise FecheckError(f"{where}; {fix}")
    sheets = {"femoral sheet": (femur, "femur_bone")} | {
        f"{c} tibial sheet": (m, "tibia_bone") for c, m in tibia.items()}
    for what, (mesh, role) in sheets.items():
        bone = surf[role]
        h = bone_distance_thickness(mesh, bone.mesh, name=f"{_option(role)} {bone.source}")
        _say(role.replace("_", "-"), "thickness", f"{what}: {np.median(h):.2f} mm median "
             f"({h.min():.2f}-{h.max():.2f}) to the bone along its inward normals")


# ------------------------------------------------------------------------- FE
def fe_checks(out: Path, files: dict[str, Path]) -> None:
    """What `fecheck fe` and `fecheck calibrate` meet in the written scene: per tibial
    compartment the layer's extrusion (`geometry.extrude.extrusion_directions`, as the FE
    calls it, with the scene's thickness and levels, and where that inverts the FE's
    prepared copy, ``fe.prepare``), rim curl (faces facing down) and slivers; a check line
    when all is well (or the FE prepares the sheet), else one warning line per finding
    naming the file, the place (mm) and the key to change."""
    import warnings

    import numpy as np

    from fecheck.fe.bodies.scene_bodies import scene_bodies
    from fecheck.fe.bodies.settings import FESettings
    from fecheck.scene import load_scene

    scene = load_scene(out)
    settings = FESettings.from_scene(scene)
    levels = settings.levels(scene["contact.poisson"])
    for body in scene_bodies(scene):
        c, mesh, h = body.name, body.surface, body.thickness_mm
        where = f"the {c} tibial sheet ({files[c].name})"
        inverted, prepared = _inversion(body, levels, settings, scene)
        found = [inverted, _curl(mesh), _slivers(mesh), _rough(c, files[c].name, mesh)]
        for text in filter(None, found):
            warnings.warn(f"{where}: {text}", stacklevel=2)
        if prepared:
            _say(c, "FE layer", prepared)
        elif not any(found):
            _say(c, "FE layer", f"{np.median(h):.2f} mm layer (median) extrudes with no "
                 f"inverted prism; no face down, no sliver: ok")


def _inversion(body, levels: int, settings, scene) -> tuple[str, str]:
    """(warning, note) on the FE's extrusion of `body`'s layer (an `FEBody`): both "" when
    it extrudes as read; a note when it does not but the FE's prepared copy of the sheet
    does (``fe.prepare`` 'auto' or 'on', `fecheck.fe.solve.press.prepared_body`: what `fecheck
    fe` and `fecheck calibrate` then mesh); else a warning naming the place and a thickness
    that extrudes."""
    import numpy as np

    from fecheck.errors import FecheckError
    from fecheck.fe.solve.press import prepared_body
    from fecheck.scene.surfaces import around
    from geometry.extrude import extrusion_directions, extrusion_offsets

    mesh, h = body.surface, body.thickness_mm

    def inverts(surface, thickness) -> bool:
        try:
            extrusion_directions(surface, thickness, layers=levels, ratio=settings.grading)
        except FecheckError:
            return True
        return False

    if not inverts(mesh, h):
        return "", ""
    bottom = mesh.points - extrusion_offsets(mesh, h)
    t = bottom[mesh.faces]
    crossed = np.einsum("ij,ij->i", np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]),
                        mesh.face_cross) <= 0
    place = (f" {around(mesh.face_centroids[crossed])}" if crossed.any() else "")
    layer = f"its {np.median(h):.2f} mm layer (median)"
    if settings.prepare != "off":
        try:
            sheet, prepared = prepared_body(body, settings.size_mm, settings.smooth_mm,
                                            settings.terraces == "on")
            ready = not inverts(sheet.surface, sheet.thickness_mm)
        except FecheckError:
            ready = False
        if ready:
            return "", (f"{layer} has prisms that invert as read{place}: `fecheck fe` and "
                        "`fecheck calibrate` mesh a prepared copy of the sheet instead "
                        f"(fe.prepare = '{settings.prepare}': {prepared.trimmed_faces} rim or "
                        f"sliver faces trimmed, remeshed at fe.size_mm = {settings.size_mm:g} "
                        f"mm, smoothed over fe.smooth_mm = {settings.smooth_mm:g} mm), which "
                        "extrudes: ok")
    thinner = [f * float(np.median(h)) for f in (0.75, 0.5, 0.25)]
    works = next((t for t in thinner if not inverts(mesh, t)), None)
    key = ("contact.thickness_mm" if scene["scanned.thickness"] == "uniform" else
           "scanned.thickness = 'uniform' with contact.thickness_mm")
    fix = (f"set {key} = {works:g} (that layer extrudes)" if works is not None else
           f"smooth the sheet (even a {thinner[-1]:g} mm layer inverts)")
    how = ("as read (fe.prepare = 'off')" if settings.prepare == "off" else
           "as read and as the FE prepares it (fe.prepare)")
    return (f"{layer} has prisms that invert under the FE's extrusion {how}{place}: "
            f"`fecheck fe` and `fecheck calibrate` will refuse it; {fix}"), ""


def _rough(compartment: str, name: str, mesh: TriMesh) -> str:
    """The sheet's roughness (`geometry.roughness`), printed; a warning text when it is
    terraced or further than `ROUGH_RMS_MM` from its smoothed copy, else ""."""
    from geometry.roughness import default_radius, roughness

    r = roughness(mesh, default_radius(mesh))
    _say(compartment, "roughness", r.summary(name))
    if r.terrace_mm <= 0 and r.rms_mm <= ROUGH_RMS_MM:
        return ""
    return (f"it is rough (RMS {r.rms_mm:.3f} mm from its copy smoothed over "
            f"{r.radius_mm:.2f} mm, terraces {r.terrace_mm:.3f} mm): FE vertex peaks will "
            f"follow it; set geometry.smooth_mm = {r.radius_mm:.1f} to smooth the sheets for "
            "the EF and the FE alike")


def _curl(mesh: TriMesh) -> str:
    """The tibial faces that face down (a rim curled over), or ""."""
    from fecheck.scene.surfaces import around

    down = mesh.face_normals[:, 2] < 0
    if not down.any():
        return ""
    return (f"{int(down.sum()):,} of {mesh.n_faces:,} faces face down (a rim curled over, "
            f"{around(mesh.face_centroids[down])}): the contact meets them from below; "
            "trim them from the sheet")


def _slivers(mesh: TriMesh) -> str:
    """The sliver faces of `mesh` (an angle under `SLIVER_DEG` or an edge under
    `SHORT_EDGE_SHARE` of the median edge), or ""."""
    import numpy as np

    from fecheck.scene.surfaces import around

    t = mesh.points[mesh.faces]
    e = np.stack([t[:, 1] - t[:, 0], t[:, 2] - t[:, 1], t[:, 0] - t[:, 2]], axis=1)
    length = np.linalg.norm(e, axis=2)
    cos = -np.einsum("fij,fij->fi", e, np.roll(e, 1, axis=1)) / (
        length * np.roll(length, 1, axis=1))
    angle = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    median = float(np.median(length))
    bad = (angle.min(axis=1) < SLIVER_DEG) | (length.min(axis=1) < SHORT_EDGE_SHARE * median)
    if not bad.any():
        return ""
    return (f"{int(bad.sum()):,} sliver faces (an angle under {SLIVER_DEG:g}° or an edge under "
            f"{SHORT_EDGE_SHARE * median:.2g} mm, {SHORT_EDGE_SHARE:g} of the median edge; "
            f"smallest angle {angle.min():.2g}°, shortest edge {length.min():.2g} mm) "
            f"{around(mesh.face_centroids[bad])}: their tetrahedra make the FE "
            "ill-conditioned; set scanned.decimate_faces (decimation collapses short edges) "
            "or remesh the sheet")


# ------------------------------------------------------------------------- scene
def scene_text(out: Path, files: dict[str, Path], opts: Options,
               tibia: dict[str, TriMesh], gaps: dict[str, np.ndarray],
               femur_closed: bool) -> str:
    """The documented scene TOML (paths relative to the folder of `out`)."""
    import numpy as np

    from fecheck.scene.document import toml_value

    split = opts.split
    lines: list[str] = []

    def put(key: str, value, *comment: str) -> None:
        lines.extend(textwrap.wrap(" ".join(comment), 86, initial_indent="# ",
                                   subsequent_indent="# ", break_on_hyphens=False))
        lines.append(f"{key} = {toml_value(value)}")

    def rel(path: Path) -> str:
        return os.path.relpath(Path(path).resolve(), out.resolve().parent)

    centres = [np.average(m.face_centroids, axis=0, weights=m.face_areas)
               for m in tibia.values()]
    x_c, y_c = (round(float(v), 3) + 0.0 for v in np.mean(centres, axis=0)[:2])
    bones = "femur_bone" in files and "tibia_bone" in files
    rest = "; ".join(f"{c} smallest gap {float(g.min()):+.2f} mm" for c, g in gaps.items())
    header = (f"Femur-tibia scene written by `fecheck knee import` (fecheck "
              f"{opts.version}): the femoral articular surface (master, fixed) on the "
              "two tibial compartments (slaves). Units: mm, N, MPa, kg, degrees; thesis frame "
              "(x right, y anterior, z superior, origin at the tibial plateau centre): the "
              f"meshes are read as they are. Rest pose at import: {rest} (- = overlap). "
              f"Preview: {out.stem}_preview.png. Run: fecheck run {out.name}")
    lines += textwrap.wrap(header, 86, initial_indent="# ", subsequent_indent="# ",
                           break_on_hyphens=False)
    put("name", out.stem)
    put("gravity", False, "The tibia's weight is left out: the shank's mass and centre of mass "
        "are unknown", "(to add it: gravity = true, tibia.mass_kg, tibia.com_mm).")
    lines += ["", "[model]"]
    put("kind", "femur-tibia", "Mesh on mesh: no knee landmark is read.")
    lines += ["", "[geometry]"]
    put("dir", "", "Folder the paths below are relative to: '' = this file's folder.")
    put("units", opts.units, "Length unit of every mesh file (checked against its extent).")
    femur_kind = ("a closed implant component, normals outward" if femur_closed
                  else "an open sheet, normals out of the cartilage, down")
    put("femur", rel(files["femur"]), f"Femoral articular surface ({femur_kind}).")
    if split == "files":
        put("tibia", rel(files["tibia"]), "Tibial articular surface, one file per compartment "
            "(normals up): medial ...")
        put("tibia_lateral", rel(files["tibia_lateral"]), "... and lateral.")
    else:
        what = ("its two connected pieces" if split == "components" else
                "the two sides of the plane x = split_x_mm")
        put("tibia", rel(files["tibia"]), "Tibial articular surface, both compartments "
            f"(normals up), split into {what}; the medial one is at "
            f"{'-' if opts.side == 'right' else '+'}x in a {opts.side} knee.")
        put("tibia_split", split)
        if split == "sagittal":
            put("split_x_mm", float(opts.split_x or 0.0), "x of the sagittal split plane, mm.")
    if bones:
        put("femur_bone", rel(files["femur_bone"]), "Bone surfaces, for the bone-distance "
            "cartilage thickness.")
        put("tibia_bone", rel(files["tibia_bone"]))
    lines += ["", "[scanned]"]
    if bones:
        put("thickness", "bone-distance", "Foundation thickness: per tibial face the tibial "
            "and femoral cartilage in series,", "each its distance to its bone along the "
            "inward normal (OpenSim-JAM).")
    else:
        put("thickness", "uniform", "Foundation thickness: contact.thickness_mm everywhere "
            "(give --femur-bone and", "--tibia-bone for the bone-distance thickness).")
    put("decimate_faces", 0, "0 = the full meshes; N = about N tibial faces in total (the "
        "femoral surface decimated in the same proportion), for a quicker first look.")
    lines += ["", "[knee]"]
    put("preset", "custom", "The side says which compartment is medial (right: -x, left: "
        "+x).")
    put("side", opts.side)
    lines += ["", "[contact]"]
    put("law", "ef", "Linear elastic foundation (thesis eq. 4.1-4.3).")
    put("youngs_MPa", 20.0, "Natural cartilage: E = 20 MPa, ν = 0.3. For an implant's UHMWPE "
        "insert use", "E ~ 460 MPa, ν ~ 0.45 (and the insert's thickness).")
    put("poisson", 0.3)
    if not bones:
        put("thickness_mm", THICKNESS_MM, "Uniform layer thickness h, mm (no bone files: "
            "scanned.thickness = 'uniform').")
    lines += ["", "[load]"]
    put("force_N", float(opts.load_N), "Axial load on the tibia, N, pushing it up into the "
        "femur.")
    put("direction", [0.0, 0.0, 1.0])
    put("point_mm", [x_c, y_c, ANKLE_Z_MM], "Where the load acts, mm: on the joint axis "
        f"{-ANKLE_Z_MM:g} mm below the knee (x, y = the mean", "of the two compartments' "
        "centroids). Set the subject's ankle centre here.")
    lines += ["", "[dofs]"]
    put("free", ["z", "abduction"], "Free: the vertical translation and the varus-valgus "
        "rotation; the others are held.")
    return "\n".join(lines) + "\n"


def _reload(out: Path, tibia: dict[str, TriMesh]) -> None:
    """Load the written scene back and check it splits the tibia as printed."""
    from fecheck.errors import FecheckError
    from fecheck.scene import load_scene, surfaces

    scene = load_scene(out)
    surfaces.femoral_surface(scene)
    got = surfaces.tibial_compartments(scene)
    counts = {c: (got[c].n_faces, tibia[c].n_faces) for c in tibia}
    if any(a != b for a, b in counts.values()):
        raise FecheckError(f"{out}: the scene reads other compartments than the import split "
                           f"(faces {counts}); please report this")
    if scene["scanned.thickness"] == "bone-distance":
        for which in ("femur", "tibia"):
            surfaces.bone(scene, which)
    _say("scene", "reloaded", "loads; " + ", ".join(f"{c} {n:,} tibial faces" for c, (n, _)
                                                   in counts.items()) + ", as split above")
