"""Outputs of `fecheck flex`: CSV and JSON tables, a ParaView time series, plots.

The time series is a ``flex.pvd`` collection (timestep = the flexion angle, deg, world
frame, mm) of three parts (five with the patella): part 0, ``flex_NNN.vtu`` per angle, both
tibial articular surfaces at the angle's pose with cell data ``pressure_MPa`` and
``compartment``; part 1, ``femur.vtu`` (written once, the femur is fixed), the femoral
articular surface and bone with cell data ``part`` (0 surface, 1 bone); part 2,
``ligaments_NNN.vtu`` per angle, each bundle a straight line cell with cell data
``tension_N`` and ``length_mm``; with the patella (patella.dir), part 3,
``patella_NNN.vtu`` per angle, its cartilage sheet and bone at the angle's pose with cell
data ``pressure_MPa`` (0 on the bone) and ``part`` (0 cartilage, 1 bone), and part 4,
``patella_ligaments_NNN.vtu``, its 20 bundles as lines (``tension_N``, ``length_mm``).
Its size is estimated before writing (`vtk_size_bytes`). The plots are ``kinematics.png``
(secondary kinematics, compartment forces and ligament forces against flexion) and
``contact_paths.png`` (each compartment's centre of pressure on the tibial plateau,
coloured by flexion).
"""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from fecheck.errors import FecheckError
from fecheck.model.patella import PF_COORDINATES, PF_SIGNS
from fecheck.scene import Scene
from fecheck.scene.provenance import provenance
from fecheck.studies.flex import FLEX_SIGNS, LIGAMENT_GROUPS, PATELLA_GROUPS, FlexRun
from geometry.files import write_output
from geometry.mesh import TriMesh

VTK_CAP_BYTES = 2.0e9
"""The largest VTK series `write_vtk_series` writes without force=True, bytes."""


def csv_text(run: FlexRun) -> str:
    """One CSV row per solved angle (`FlexPoint.row`)."""
    buf = io.StringIO()
    rows = [p.row() for p in run.points]
    if not rows:
        return ""
    writer = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return buf.getvalue()


def _num(v: float | str) -> float | str | None:
    if isinstance(v, str):
        return v
    return None if not math.isfinite(v) else float(v)


def json_text(run: FlexRun, scene: Scene | None = None) -> str:
    """The axis, the build time, how the run ended, every angle (bundles by name) and the
    provenance of `scene` (`fecheck.scene.provenance`)."""
    axis = run.axis
    doc = {"axis": {"point_mm": axis.point.tolist(), "direction": axis.direction.tolist(),
                    "source": axis.source,
                    "spheres": {k: {"center_mm": c.tolist(), "radius_mm": r}
                                for k, (c, r) in axis.spheres.items()}},
           "signs": dict(FLEX_SIGNS) | (dict(PF_SIGNS) if run.patella is not None else {}),
           "build_seconds": run.build_seconds, "stopped": run.stopped,
           "angles": [{**{k: _num(v) for k, v in p.row().items()},
                       "ligaments_N": p.ligaments}
                      | ({} if p.patella is None else
                         {"patella_ligaments_N": p.patella.ligaments,
                          "quadriceps_muscles_N": p.patella.quadriceps})
                      for p in run.points],
           "fe": [{k: _num(v) for k, v in r.items() if k != "check"} for r in run.fe],
           "provenance": provenance(scene)}
    return json.dumps(doc, indent=2) + "\n"


def _vtu_bytes(n_points: int, n_cells: int, corners: int, n_fields: int) -> int:
    """Bytes of an uncompressed binary .vtu: 24 per point, per cell its corner indices and
    offset (8 each), its type (1) and its data (8 per field); meshio compresses, so the
    file is at most this (plus a small header)."""
    return 24 * n_points + n_cells * (8 * corners + 9 + 8 * n_fields) + 2048


def vtk_size_bytes(run: FlexRun, bone: TriMesh | None = None) -> int:
    """Upper estimate of the bytes `write_vtk_series` writes for `run`."""
    tibia = _vtu_bytes(sum(m.n_points for m in run.slaves.values()),
                       sum(m.n_faces for m in run.slaves.values()), 3, 2)
    n_lig = len(run.bundles[0])
    lines = _vtu_bytes(2 * n_lig, n_lig, 2, 2) if n_lig else 0
    femur = list(run.femur.values()) + ([bone] if bone is not None else [])
    fixed = _vtu_bytes(sum(m.n_points for m in femur), sum(m.n_faces for m in femur), 3, 1)
    if run.patella is not None:
        sheet, bone = run.patella.compartment.pair.slave, run.patella.bone
        n_pl = len(run.patella.tendon_names) + len(run.patella.femoral_names)
        tibia += (_vtu_bytes(sheet.n_points + bone.n_points, sheet.n_faces + bone.n_faces, 3,
                             2) + _vtu_bytes(2 * n_pl, n_pl, 2, 2) + 300)
    return len(run.points) * (tibia + lines + 300) + fixed


def check_vtk_size(run: FlexRun, bone: TriMesh | None, force: bool) -> int:
    """The estimate of `vtk_size_bytes`; `FecheckError` above `VTK_CAP_BYTES` unless
    `force`."""
    size = vtk_size_bytes(run, bone)
    if size > VTK_CAP_BYTES and not force:
        raise FecheckError(f"--vtk would write about {size / 1e6:.0f} MB for "
                           f"{len(run.points)} angles (cap {VTK_CAP_BYTES / 1e6:.0f} MB): "
                           "fewer angles (--angles with a larger step), a decimated scene, "
                           "or --force")
    return size


def _femur_vtu(run: FlexRun, bone: TriMesh | None, path: Path) -> list[str]:
    """Write the fixed femur to `path`; [its file name] ([] for a run without one)."""
    from fecheck.io.vtk import write_vtu

    parts = list(run.femur.values()) + ([bone] if bone is not None else [])
    if not parts:
        return []
    sizes = np.cumsum([0] + [m.n_points for m in parts])
    write_vtu(path, np.vstack([m.points for m in parts]),
              np.vstack([m.faces + sizes[i] for i, m in enumerate(parts)]),
              {"part": np.concatenate([np.full(m.n_faces, min(i, 1))
                                       for i, m in enumerate(parts)])})
    return [path.name]


def write_vtk_series(run: FlexRun, directory: Path, bone: TriMesh | None = None) -> Path:
    """DIR/flex.pvd listing per angle DIR/flex_NNN.vtu (the tibial surfaces) and
    DIR/ligaments_NNN.vtu (the bundles, when the run has them), and DIR/femur.vtu (the
    fixed femur: its articular surface and `bone`) at every step (timestep = flexion deg)."""
    from fecheck.io.vtk import write_lines, write_vtu

    directory = Path(directory)
    names = list(run.slaves)
    sizes = np.cumsum([0] + [run.slaves[c].n_points for c in names])
    faces = np.vstack([run.slaves[c].faces + sizes[i] for i, c in enumerate(names)])
    local = np.vstack([run.slaves[c].points for c in names])
    region = np.concatenate([np.full(run.slaves[c].n_faces, i) for i, c in enumerate(names)])
    bundle_names, femur_points, tibia_points = run.bundles
    femur = _femur_vtu(run, bone, directory / "femur.vtu")
    entries = []
    for i, p in enumerate(run.points):
        name = f"flex_{i:03d}.vtu"
        pressure = np.concatenate([p.fields[c] for c in names])
        write_vtu(directory / name, local @ p.rot.T + p.t, faces,
                  {"pressure_MPa": pressure, "compartment": region})
        files = [name, *femur]
        if len(bundle_names):
            ends = tibia_points @ p.rot.T + p.t
            files.append(f"ligaments_{i:03d}.vtu")
            write_lines(directory / files[-1], femur_points, ends,
                        {"tension_N": np.array([p.ligaments[b] for b in bundle_names]),
                         "length_mm": np.linalg.norm(ends - femur_points, axis=1)})
        if p.patella is not None:
            files += _patella_vtus(run, p, i, directory, write_vtu, write_lines)
        entries += [f'    <DataSet timestep="{p.flexion_deg:.10g}" part="{k}" '
                    f'file={quoteattr(f)}/>' for k, f in enumerate(files)]
    text = ('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n'
            "  <Collection>\n" + "\n".join(entries) + "\n  </Collection>\n</VTKFile>\n")
    pvd = directory / "flex.pvd"
    write_output(pvd, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    return pvd


def _patella_vtus(run: FlexRun, p, i: int, directory: Path, write_vtu, write_lines
                  ) -> list[str]:
    """Write the patella (cartilage and bone, pressure on the cartilage) and its bundles
    at angle `p` (index `i`) with the writers of `fecheck.io.vtk`; their file names."""
    model, state = run.patella, p.patella
    sheet, bone = model.compartment.pair.slave, model.bone
    names = [f"patella_{i:03d}.vtu", f"patella_ligaments_{i:03d}.vtu"]
    points = np.vstack([sheet.points, bone.points]) @ state.rot.T + state.t
    write_vtu(directory / names[0], points,
              np.vstack([sheet.faces, bone.faces + sheet.n_points]),
              {"pressure_MPa": np.concatenate([state.contact.face_pressure_MPa,
                                               np.zeros(bone.n_faces)]),
               "part": np.repeat([0, 1], [sheet.n_faces, bone.n_faces])})
    tendon, femoral = model.tendon, model.femoral
    starts = np.vstack([tendon.points_a @ p.rot.T + p.t, femoral.femur_points])
    ends = np.vstack([tendon.points_b, femoral.tibia_points]) @ state.rot.T + state.t
    tension = [state.ligaments[n] for n in (*model.tendon_names, *model.femoral_names)]
    write_lines(directory / names[1], starts, ends,
                {"tension_N": np.array(tension),
                 "length_mm": np.linalg.norm(ends - starts, axis=1)})
    return names


def table_text(run: FlexRun) -> str:
    """The per-angle table of standard output: kinematics (signs stated above it),
    compartment force (N), contact area (mm²) and p_max (MPa), ligament group tensions
    (N)."""
    comps = list(run.slaves)
    groups = [g for g in LIGAMENT_GROUPS
              if any(k.startswith(g) for k in (run.points[0].ligaments if run.points else {}))]
    head = (f"{'flex°':>6s} {'add°':>6s} {'int°':>6s} {'ml mm':>6s} {'ap mm':>6s} "
            f"{'si mm':>6s}" + "".join(f" | {c[:3]} F N  A mm²  p MPa" for c in comps)
            + ("  |" + "".join(f" {g + ' N':>7s}" for g in groups) if groups else ""))
    lines = ["per angle: flex° knee flexion (+ flexed); add° adduction (+ varus: the distal "
             "tibia medially, - abduction); int° internal rotation (+ internal: the tibia's "
             "anterior turns medially); ml, ap, si: the tibial point at the axis point moved "
             "along the axis (+ right), anterior, superior", head]
    for p in run.points:
        d = p.translation_mm
        text = (f"{p.flexion_deg:6g} {p.adduction_deg:6.2f} {p.internal_rotation_deg:6.2f} "
                f"{d[0]:6.2f} {d[1]:6.2f} {d[2]:6.2f}")
        for c in comps:
            v = p.compartments[c]
            text += (f" | {v['force_N']:7.1f} {v['area_mm2']:6.1f} "
                     f"{v['max_pressure_MPa']:6.2f}")
        if groups:
            text += "  |" + "".join(
                f" {sum(t for k, t in p.ligaments.items() if k.startswith(g)):7.1f}"
                for g in groups)
        lines.append(text)
    if run.points and run.points[0].patella is not None:
        lines += _patella_table(run)
    return "\n".join(lines) + "\n"


def _patella_table(run: FlexRun) -> list[str]:
    """The patella's lines of the per-angle table: its coordinates (the source model's
    pf_r), the patellofemoral contact and its bundle groups."""
    names = [k.removesuffix("_deg").removesuffix("_mm") for k in PF_COORDINATES]
    head = (f"{'flex°':>6s} " + " ".join(f"{n:>7s}" for n in names)
            + " | PF F N  A mm²  p MPa  CoP x, y, z mm (femur frame) |"
            + "".join(f" {g + ' N':>7s}" for g in PATELLA_GROUPS))
    lines = ["patella per angle: pf_flex° (+ flexed with the knee), pf_rot°, pf_tilt° and "
             "pf_tx, pf_ty, pf_tz mm (anterior, superior, right), the source model's pf_r "
             "coordinates of the patella relative to the femur", head]
    for p in run.points:
        r = p.row()
        lines.append(f"{p.flexion_deg:6g} " + " ".join(f"{r[k]:7.2f}" for k in PF_COORDINATES)
                     + f" | {r['PF_force_N']:6.1f} {r['PF_area_mm2']:6.1f} "
                     f"{r['PF_max_pressure_MPa']:6.2f}  {r['PF_cop_x_mm']:6.1f} "
                     f"{r['PF_cop_y_mm']:6.1f} {r['PF_cop_z_mm']:6.1f} |"
                     + "".join(f" {r[g + '_N']:7.1f}" for g in PATELLA_GROUPS))
    return lines


def _series(run: FlexRun, key: str) -> np.ndarray:
    return np.array([p.row()[key] for p in run.points], dtype=float)


def write_plots(run: FlexRun, directory: Path) -> list[Path]:
    """DIR/kinematics.png and DIR/contact_paths.png (matplotlib, Agg)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    directory = Path(directory)
    phi = _series(run, "flexion_deg")
    fig, ax = plt.subplots(2, 2, figsize=(11, 8), constrained_layout=True)
    ax[0, 0].plot(phi, _series(run, "internal_rotation_deg"),
                  label="internal rotation (+ internal)")
    ax[0, 0].plot(phi, _series(run, "adduction_deg"), label="adduction (+ varus)")
    ax[0, 0].set_ylabel("deg")
    for key, label in (("ml_mm", "medio-lateral (+ along axis)"), ("ap_mm", "anterior"),
                       ("si_mm", "superior")):
        ax[0, 1].plot(phi, _series(run, key), label=label)
    ax[0, 1].set_ylabel("tibial point at the axis point, mm")
    for c in run.slaves:
        ax[1, 0].plot(phi, _series(run, f"{c}_force_N"), label=f"{c} force")
    ax[1, 0].set_ylabel("contact force, N")
    for group in LIGAMENT_GROUPS:
        ax[1, 1].plot(phi, _series(run, f"{group}_N"), label=group)
    ax[1, 1].set_ylabel("ligament tension, N")
    for a in ax.flat:
        a.set_xlabel("knee flexion, deg")
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    fig.suptitle(f"Driven flexion; {run.axis.describe()}", fontsize=9)
    paths = [directory / "kinematics.png", directory / "contact_paths.png"]
    directory.mkdir(parents=True, exist_ok=True)
    write_output(paths[0], lambda tmp: fig.savefig(tmp, format="png", dpi=110))
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(9, 6.5), constrained_layout=True)
    for mesh in run.slaves.values():
        ax.triplot(mesh.points[:, 0], mesh.points[:, 1], mesh.faces, color="0.85", lw=0.3)
    for c, marker in zip(run.slaves, ("o", "s"), strict=False):
        sc = ax.scatter(_series(run, f"{c}_cop_x_mm"), _series(run, f"{c}_cop_y_mm"),
                        c=phi, cmap="viridis", s=14, marker=marker, label=c)
    fig.colorbar(sc, ax=ax, label="knee flexion, deg")
    ax.set_aspect("equal")
    ax.set_xlabel("x, mm (right)")
    ax.set_ylabel("y, mm (anterior)")
    ax.set_title("Centres of pressure on the tibial plateau (tibia frame, seen from above)")
    ax.legend()
    write_output(paths[1], lambda tmp: fig.savefig(tmp, format="png", dpi=110))
    plt.close(fig)
    return paths
