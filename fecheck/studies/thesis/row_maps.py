"""Pressure maps (thesis Figs. 5.18, 5.21): pyvista off-screen renderings of the face
pressures for three load points, on the scanned knee without and with ligaments, and on
the baseline sphere-plane model for comparison.

    python validation/row_maps.py [--quick] [--out DIR]
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from fecheck.io.plots import printed_max_pressure
from fecheck.studies.thesis import thesis_values as tv
from fecheck.studies.thesis.report import (
    CANNOT,
    DEVIATES,
    Line,
    Row,
    guarded,
    knee_scene,
    table_row,
)
from fecheck.studies.thesis.row_rigid import run, scene

SHIFTS_MM = (-8.0, 0.0, 8.0)
P_MAX_FORMAT = "%.2f"
"""How the panels print p_max (MPa) and how the colour bar labels its ticks: the bar's
top tick reads as the largest printed p_max."""


def _solve(name: str | None, shifts: tuple[float, ...]) -> list:
    x0, y0, z0 = scene(name)["load.point_mm"]
    return [run(name, f"load.point_mm=[{x0 + s}, {y0}, {z0}]") for s in shifts]


def pressure_figure(results: list, shifts: tuple[float, ...], title: str):
    """The pyvista plotter (off-screen, not shown) of `pressure_png`."""
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv


    pmax = max(printed_max_pressure(r)[0] for r in results)
    plotter = pv.Plotter(off_screen=True, shape=(1, len(results)),
                         window_size=(max(900, 520 * len(results)), 600), border=False)
    for k, (res, shift) in enumerate(zip(results, shifts, strict=True)):
        plotter.subplot(0, k)
        hot_normals, hot_points = [], []
        for comp in res.compartments.values():
            faces = np.asarray(comp.slave_faces)
            cells = np.hstack([np.full((len(faces), 1), 3), faces]).ravel()
            mesh = pv.PolyData(np.asarray(comp.slave_points, dtype=float), cells)
            mesh.cell_data["pressure, MPa"] = comp.face_pressure_MPa
            plotter.add_mesh(mesh, scalars="pressure, MPa", cmap="viridis", clim=(0.0, pmax),
                             lighting=False, show_scalar_bar=(k == len(results) - 1),
                             scalar_bar_args={"title": "pressure, MPa", "vertical": True,
                                              "position_x": 0.78, "position_y": 0.15,
                                              "height": 0.7, "width": 0.08,
                                              "fmt": P_MAX_FORMAT})
            hot = np.flatnonzero(comp.face_pressure_MPa > 0)
            if hot.size:
                tri = np.asarray(comp.slave_points, dtype=float)[faces[hot]]
                hot_normals.append(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
                                   .sum(axis=0))
                hot_points.append(tri.reshape(-1, 3))
        if hot_points:
            pts = np.vstack(hot_points)
            centre = pts.mean(axis=0)
            view = np.mean(hot_normals, axis=0)
            view /= np.linalg.norm(view)
            span = float(np.ptp(pts[:, 0])) + 40.0
            plotter.camera.focal_point = centre
            plotter.camera.position = centre + view * 2.5 * span
            plotter.camera.up = (0.0, 1.0, 0.0)
        m, lat = res.compartments["medial"], res.compartments["lateral"]
        plotter.add_text(f"load shift {shift:+g} mm along x\nmedial {m.force_N:.0f} N, "
                         f"p_max {P_MAX_FORMAT % m.max_pressure_MPa} MPa\nlateral "
                         f"{lat.force_N:.0f} N, p_max {P_MAX_FORMAT % lat.max_pressure_MPa} MPa",
                         position="lower_edge", font_size=9)
        if k == 0:
            plotter.add_text(title + "\nseen from the contact side; x right, y anterior, mm; "
                             "face means, colour bar up to the largest printed p_max",
                             position="upper_left", font_size=10)
        plotter.add_axes(xlabel="x", ylabel="y", zlabel="z")
    return plotter


def pressure_png(results: list, shifts: tuple[float, ...], title: str, path: Path) -> Path:
    """One viewport per load shift, both compartments' slave surfaces coloured by the face
    pressure (MPa, unlit, one colour scale from 0 to the largest p_max the panels print),
    seen from the side the pressure acts on."""
    plotter = pressure_figure(results, shifts, title)
    path.parent.mkdir(parents=True, exist_ok=True)
    plotter.screenshot(str(path))
    plotter.close()
    return path


def fig_5_18(quick: bool, out: Path) -> Row:
    name = knee_scene("femur_tibia")
    shifts = (0.0,) if quick else SHIFTS_MM
    scanned = _solve(name, shifts)
    base = _solve(None, shifts)
    png = pressure_png(scanned, shifts, "Fig. 5.18: scanned femur on tibia, no ligaments",
                       out / "fig_5_18.png")
    png_b = pressure_png(base, shifts, "Baseline sphere-plane (plateaus under condyle spheres)",
                         out / "fig_5_18_baseline.png")
    ref = scanned[shifts.index(0.0)]
    lines = [Line(f"{c} max pressure MPa", tv.TABLE_5_11_SCANNED[c]["max_pressure_MPa"],
                  ref.compartments[c].max_pressure_MPa, "reference load point")
             for c in ("medial", "lateral")]
    note = ("Pressure on the scanned lenhart2015 cartilage (another subject than the "
            "thesis's); as in the thesis, the pressure is highest in the middle of each "
            "contact and grows on the condyle the load moves towards. The second picture is "
            "the baseline sphere-plane model at the same shifts (pressure on the meshed "
            "plateau discs under the analytic condyles).")
    return table_row("fig_5_18", "pressure maps, scanned knee without ligaments", "Fig. 5.18",
                     lines, out, DEVIATES, note, (png, png_b))


def fig_5_21(quick: bool, out: Path) -> Row:
    name = knee_scene("femur_tibia_ligaments")
    shifts = (0.0,) if quick else SHIFTS_MM
    res = _solve(name, shifts)
    png = pressure_png(res, shifts, "Fig. 5.21: scanned femur on tibia, ligament springs",
                       out / "fig_5_21.png")
    ref = res[shifts.index(0.0)]
    lines = [Line(f"{c} max pressure MPa", None, ref.compartments[c].max_pressure_MPa,
                  "reference load point") for c in ("medial", "lateral")]
    note = ("With the subject's ligament bundles as Blankevoort springs (Lenhart 2015) "
            "rather than the thesis's rods; the thesis gives no numbers for this figure.")
    return table_row("fig_5_21", "pressure maps, scanned knee with ligaments", "Fig. 5.21",
                     lines, out, CANNOT, note, (png,))


def rows(quick: bool, out: Path) -> list[Row]:
    """Figs. 5.18 and 5.21 (pyvista, off-screen)."""
    return [guarded("fig_5_18", "pressure maps, scanned knee without ligaments", "Fig. 5.18",
                    out, lambda: fig_5_18(quick, out)),
            guarded("fig_5_21", "pressure maps, scanned knee with ligaments", "Fig. 5.21",
                    out, lambda: fig_5_21(quick, out))]
