"""Outputs of `fecheck flex`: CSV and JSON tables, a ParaView time series, plots.

The time series is a ``flex.pvd`` collection with one ``.vtu`` per angle (timestep = the
flexion angle, deg): both tibial articular surfaces at the angle's pose (world frame, mm)
with cell data ``pressure_MPa``. The plots are ``kinematics.png`` (secondary kinematics,
compartment forces and ligament forces against flexion) and ``contact_paths.png`` (each
compartment's centre of pressure on the tibial plateau, coloured by flexion).
"""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from fecheck.scene import Scene
from fecheck.scene.provenance import provenance
from fecheck.studies.flex import LIGAMENT_GROUPS, FlexRun
from geometry.files import write_output


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


def _num(v: float) -> float | None:
    return None if not math.isfinite(v) else float(v)


def json_text(run: FlexRun, scene: Scene | None = None) -> str:
    """The axis, the build time, how the run ended, every angle (bundles by name) and the
    provenance of `scene` (`fecheck.scene.provenance`)."""
    axis = run.axis
    doc = {"axis": {"point_mm": axis.point.tolist(), "direction": axis.direction.tolist(),
                    "source": axis.source,
                    "spheres": {k: {"center_mm": c.tolist(), "radius_mm": r}
                                for k, (c, r) in axis.spheres.items()}},
           "build_seconds": run.build_seconds, "stopped": run.stopped,
           "angles": [{**{k: _num(v) for k, v in p.row().items()},
                       "ligaments_N": p.ligaments} for p in run.points],
           "fe": [{k: _num(v) for k, v in r.items() if k != "check"} for r in run.fe],
           "provenance": provenance(scene)}
    return json.dumps(doc, indent=2) + "\n"


def write_vtk_series(run: FlexRun, directory: Path) -> Path:
    """DIR/flex_NNN.vtu per angle and DIR/flex.pvd listing them (timestep = flexion deg)."""
    from fecheck.io.vtk import write_vtu

    directory = Path(directory)
    names = list(run.slaves)
    sizes = np.cumsum([0] + [run.slaves[c].n_points for c in names])
    faces = np.vstack([run.slaves[c].faces + sizes[i] for i, c in enumerate(names)])
    local = np.vstack([run.slaves[c].points for c in names])
    region = np.concatenate([np.full(run.slaves[c].n_faces, i) for i, c in enumerate(names)])
    entries = []
    for i, p in enumerate(run.points):
        name = f"flex_{i:03d}.vtu"
        pressure = np.concatenate([p.fields[c] for c in names])
        write_vtu(directory / name, local @ p.rot.T + p.t, faces,
                  {"pressure_MPa": pressure, "compartment": region})
        entries.append(f'    <DataSet timestep="{p.flexion_deg:.10g}" part="0" '
                       f'file={quoteattr(name)}/>')
    text = ('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n'
            "  <Collection>\n" + "\n".join(entries) + "\n  </Collection>\n</VTKFile>\n")
    pvd = directory / "flex.pvd"
    write_output(pvd, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    return pvd


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
    ax[0, 0].plot(phi, _series(run, "internal_deg"), label="internal rotation")
    ax[0, 0].plot(phi, _series(run, "abduction_deg"), label="abduction θy")
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
