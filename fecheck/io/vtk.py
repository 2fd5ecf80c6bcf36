"""Per-face results as VTK unstructured grids (``.vtu``, meshio) and as a CSV table.

One ``<compartment>.vtu`` per contact surface, triangles in world coordinates (mm) with
the cell data

* ``pressure_MPa`` : mean contact pressure over the in-contact part of each face, MPa
  (0 off contact; the face pressure `fecheck run --plot` draws);
* ``contact_area_mm2`` : in-contact area of each face, mm² (the quadrature area: the
  face clipped at zero depth, projected as the contact law integrates it), so that
  Σ pressure_MPa · contact_area_mm2 is the compartment's normal force, N;
* ``depth_mm`` : mean depth over the in-contact part of each face, mm (0 off contact).

The per-face area and depth come from the run's `CompartmentResult` fields
``face_area_mm2`` and ``face_depth_mm``. Without them (results that do not carry them)
``contact_area_mm2`` is the whole area of each face under pressure — an overestimate at
the contact edge, ~0.5 % on Σ p·A for the baseline — and ``depth_mm`` is left out; the
writers say so in their notes.

FE cross-check (`write_fe_vtk`): one ``<compartment>.vtu`` per compartment, the EF run's
tibial faces in the tibia frame (mm) with the cell data ``fe_pressure_MPa`` (the FE
pressure averaged onto each face), ``ef_pressure_MPa`` and ``difference_MPa`` (FE − EF;
both only when the EF pressure lives on these faces), MPa.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from fecheck.io.outputs import write_output
from fecheck.model.results import CompartmentResult, RunResult

if TYPE_CHECKING:
    from fecheck.fe.knee.crosscheck import CompartmentCheck, CrossCheck

AREA_ESTIMATE_NOTE = ("contact_area_mm2 is the whole area of each face under pressure (this "
                      "result carries no per-face in-contact area), so Σ p·A overestimates "
                      "the force slightly; depth_mm is left out (no per-face depth)")
FACE_COLUMNS = ("compartment", "face", "x_mm", "y_mm", "z_mm", "pressure_MPa",
                "contact_area_mm2", "depth_mm")


def triangle_areas(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(m,) areas of the triangles `faces` over `points`, mm²."""
    p = np.asarray(points, dtype=float)[np.asarray(faces)]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)


def has_face_fields(comp: CompartmentResult) -> bool:
    """Whether the compartment carries per-face pressures and a slave mesh."""
    return comp.face_pressure_MPa is not None and comp.slave_points is not None


def exact_face_fields(comp: CompartmentResult) -> bool:
    """Whether the compartment carries its per-face in-contact area and depth."""
    return (getattr(comp, "face_area_mm2", None) is not None
            and getattr(comp, "face_depth_mm", None) is not None)


def face_fields(comp: CompartmentResult) -> dict[str, np.ndarray]:
    """Cell data of one contact surface: pressure_MPa (face mean), contact_area_mm2 (the
    in-contact area; the whole area of the faces under pressure without
    `exact_face_fields`) and depth_mm (face mean, only with `exact_face_fields`)."""
    p = np.asarray(comp.face_pressure_MPa, dtype=float)
    if exact_face_fields(comp):
        return {"pressure_MPa": p,
                "contact_area_mm2": np.asarray(comp.face_area_mm2, dtype=float),
                "depth_mm": np.asarray(comp.face_depth_mm, dtype=float)}
    whole = triangle_areas(comp.slave_points, comp.slave_faces)
    return {"pressure_MPa": p, "contact_area_mm2": np.where(p > 0, whole, 0.0)}


def field_notes(result: RunResult) -> list[str]:
    """What the per-face outputs of `result` lack (empty when they are complete)."""
    comps = [c for c in result.compartments.values() if has_face_fields(c)]
    return [] if all(exact_face_fields(c) for c in comps) else [AREA_ESTIMATE_NOTE]


def write_vtu(path: str | Path, points: np.ndarray, faces: np.ndarray,
              cell_data: Mapping[str, np.ndarray],
              point_data: Mapping[str, np.ndarray] | None = None) -> Path:
    """Write a triangle surface (mm) with cell and point data to `path` (.vtu, meshio),
    by `write_output` (a regular file replaced in one step)."""
    import meshio

    path = Path(path)
    mesh = meshio.Mesh(np.asarray(points, dtype=float),
                       [("triangle", np.asarray(faces, dtype=np.int64))],
                       point_data={k: np.asarray(v) for k, v in (point_data or {}).items()},
                       cell_data={k: [np.asarray(v)] for k, v in cell_data.items()})
    write_output(path, lambda tmp: meshio.write(tmp, mesh, file_format="vtu"))
    return path


def write_lines(path: str | Path, starts: np.ndarray, ends: np.ndarray,
                cell_data: Mapping[str, np.ndarray]) -> Path:
    """Write straight segments from `starts` (n, 3) to `ends` (n, 3), mm, one line cell
    each with `cell_data` (n,), to `path` (.vtu, meshio), by `write_output`."""
    import meshio

    path = Path(path)
    n = len(starts)
    points = np.vstack([np.asarray(starts, dtype=float), np.asarray(ends, dtype=float)])
    lines = np.column_stack([np.arange(n), n + np.arange(n)]).astype(np.int64)
    mesh = meshio.Mesh(points, [("line", lines)],
                       cell_data={k: [np.asarray(v)] for k, v in cell_data.items()})
    write_output(path, lambda tmp: meshio.write(tmp, mesh, file_format="vtu"))
    return path


def write_run_vtk(result: RunResult, directory: str | Path) -> list[Path]:
    """Write ``<compartment>.vtu`` (see the module docstring) for every compartment with
    per-face results into `directory`; returns the written paths (none for the rigid
    model)."""
    paths = []
    for name, comp in result.compartments.items():
        if has_face_fields(comp):
            paths.append(write_vtu(Path(directory) / f"{name}.vtu", comp.slave_points,
                                   comp.slave_faces, face_fields(comp)))
    return paths


def face_rows(result: RunResult) -> list[dict[str, object]]:
    """One row per slave face of every compartment (columns `FACE_COLUMNS`): centroid
    (mm), pressure (MPa), in-contact area (mm²) and depth (mm, empty when unknown)."""
    rows = []
    for name, comp in result.compartments.items():
        if not has_face_fields(comp):
            continue
        fields = face_fields(comp)
        centroids = np.asarray(comp.slave_points)[np.asarray(comp.slave_faces)].mean(axis=1)
        depth = fields.get("depth_mm")
        for i, (x, y, z) in enumerate(centroids):
            rows.append({"compartment": name, "face": i, "x_mm": float(x), "y_mm": float(y),
                         "z_mm": float(z), "pressure_MPa": float(fields["pressure_MPa"][i]),
                         "contact_area_mm2": float(fields["contact_area_mm2"][i]),
                         "depth_mm": "" if depth is None else float(depth[i])})
    return rows


def faces_csv_text(result: RunResult) -> str:
    """`face_rows` as CSV text with a header row ('' for a model without faces)."""
    rows = face_rows(result)
    if not rows:
        return ""
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=FACE_COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return buf.getvalue()


# ---------------------------------------------------------------------- FE cross-check
def fe_cell_data(comp: CompartmentCheck) -> dict[str, np.ndarray]:
    """Cell data of one compartment's EF faces: fe_pressure_MPa (the FE pressure averaged
    onto each face) and, when the EF pressure lives on these faces, ef_pressure_MPa and
    difference_MPa (FE − EF), MPa."""
    fe = np.asarray(comp.fe_face_pressure_MPa, dtype=float)
    if comp.ef_face_pressure_MPa is None:
        return {"fe_pressure_MPa": fe}
    ef = np.asarray(comp.ef_face_pressure_MPa, dtype=float)
    return {"fe_pressure_MPa": fe, "ef_pressure_MPa": ef, "difference_MPa": fe - ef}


def write_fe_vtk(check: CrossCheck, directory: str | Path) -> list[Path]:
    """Write ``<compartment>.vtu`` of every compartment's EF faces (tibia frame, mm) with
    the cell data of `fe_cell_data` into `directory`; returns the written paths."""
    paths = []
    for name, comp in check.compartments.items():
        surface = comp.layer.body.surface
        paths.append(write_vtu(Path(directory) / f"{name}.vtu", surface.points,
                               surface.faces, fe_cell_data(comp)))
    return paths
