"""Plots of the FE cross-check: pressure maps (pyvista, off-screen) and radial profiles.

`pressure_maps` draws the FE and EF pressures on the same top-surface triangles side by
side with one colour scale (thesis Fig. 4.7); `radial_profile` draws pressure against the
distance from the first touch point with Hertz overlaid (thesis Fig. 4.8).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from fecheck.fe.crosscheck import CompartmentCheck
from fecheck.reference.closed_forms import column_stiffness


def ef_pressure(check: CompartmentCheck, E_MPa: float, nu: float,
                thickness_mm: float) -> np.ndarray:
    """EF pressure k·max(0, d - g0) at the FE top points under the same load, MPa."""
    k = column_stiffness(E_MPa, nu, thickness_mm)
    return k * np.maximum(0.0, check.ef.depth_mm - check.fe.gap0_mm)


def _radius(check: CompartmentCheck) -> np.ndarray:
    fe = check.fe
    center = fe.points[np.argmin(fe.gap0_mm), :2]
    return np.hypot(fe.points[:, 0] - center[0], fe.points[:, 1] - center[1])


def pressure_maps(check: CompartmentCheck, E_MPa: float, nu: float, thickness_mm: float,
                  path: str | Path) -> Path:
    """PNG of the FE (left) and EF (right) contact pressures, one colour bar in MPa."""
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    fe = check.fe
    faces = np.column_stack([np.full(len(fe.faces), 3), fe.faces]).ravel()
    ef = ef_pressure(check, E_MPa, nu, thickness_mm)
    clim = (0.0, float(max(fe.pressure_MPa.max(), ef.max())))
    plotter = pv.Plotter(shape=(1, 2), off_screen=True, window_size=(1400, 650))
    for col, (label, values) in enumerate((("FE", fe.pressure_MPa), ("EF", ef))):
        plotter.subplot(0, col)
        surf = pv.PolyData(fe.points, faces)
        surf.point_data["pressure (MPa)"] = values
        plotter.add_mesh(surf, scalars="pressure (MPa)", clim=clim, cmap="viridis",
                         show_edges=True, edge_color="grey", line_width=0.3,
                         scalar_bar_args={"title": "pressure (MPa)"})
        m = fe.metrics if label == "FE" else check.ef
        plotter.add_text(f"{check.name} {label}: p_max {m.max_pressure_MPa:.2f} MPa, "
                         f"area {m.area_mm2:.0f} mm², {check.load_N:.0f} N", font_size=10)
        plotter.view_xy()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    plotter.screenshot(str(path))
    plotter.close()
    return path


def radial_profile(check: CompartmentCheck, E_MPa: float, nu: float, thickness_mm: float,
                   path: str | Path) -> Path:
    """PNG of pressure against distance from the touch point: FE 3D, axisymmetric, EF, Hertz."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fe, hertz = check.fe, check.hertz
    r3 = _radius(check)
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.plot(r3, fe.pressure_MPa, ".", ms=3, color="C0", label="FE 3D (top vertices)")
    if check.axisym is not None:
        ax.plot(check.axisym.points[:, 0], check.axisym.pressure_MPa, "-", color="C1",
                label="FE axisymmetric")
    r = np.linspace(0.0, r3.max(), 400)
    a_h = np.sqrt(hertz.area_mm2 / np.pi)
    ax.plot(r, hertz.max_pressure_MPa * np.sqrt(np.clip(1 - (r / a_h) ** 2, 0, None)), "--",
            color="C2", label="Hertz (half-space)")
    order = np.argsort(r3)
    ax.plot(r3[order], ef_pressure(check, E_MPa, nu, thickness_mm)[order], ":", color="C3",
            label="elastic foundation")
    ax.set_xlabel("distance from the first touch point (mm)")
    ax.set_ylabel("contact pressure (MPa)")
    ax.set_title(f"{check.name}: {check.load_N:.1f} N, R {check.radius_mm:.1f} mm")
    ax.grid(alpha=0.3)
    ax.legend()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path
