"""Off-screen pictures of a run's results (pyvista, imported lazily)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fecheck.model.results import RunResult


def write_pressure_plots(result: RunResult, directory: str | Path) -> list[Path]:
    """Off-screen PNGs of the face pressures (MPa colour bar), one per compartment.

    Imports pyvista lazily (off-screen EGL rendering). Returns the written paths.
    """
    import os

    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    out_dir = Path(directory)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, comp in result.compartments.items():
        if comp.slave_points is None or comp.face_pressure_MPa is None:
            continue
        cells = np.hstack([np.full((len(comp.slave_faces), 1), 3), comp.slave_faces]).ravel()
        mesh = pv.PolyData(comp.slave_points, cells)
        mesh.cell_data["pressure (MPa)"] = comp.face_pressure_MPa
        hot = comp.face_pressure_MPa > 0
        plotter = pv.Plotter(off_screen=True, window_size=(900, 700))
        plotter.add_mesh(mesh, scalars="pressure (MPa)", cmap="viridis", show_edges=False,
                         scalar_bar_args={"title": "pressure (MPa)"})
        if hot.any():
            centre = mesh.extract_cells(np.flatnonzero(hot)).center
            plotter.camera.focal_point = centre
            plotter.camera.position = np.asarray(centre) + np.array([0.0, 0.0, -60.0])
            plotter.camera.up = (0.0, 1.0, 0.0)
        plotter.add_text(f"{result.scene}: {name}, F = {comp.force_N:.1f} N, "
                         f"p_max = {comp.max_pressure_MPa:.2f} MPa", font_size=10)
        path = out_dir / f"{name}_pressure.png"
        plotter.screenshot(str(path))
        plotter.close()
        paths.append(path)
    return paths

