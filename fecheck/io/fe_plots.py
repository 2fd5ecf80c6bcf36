"""Plots of the FE cross-check: one pressure-map figure (pyvista, off-screen) and radial
profiles (matplotlib), both imported lazily.

`pressure_map_figure` draws, for both compartments at once and with the conventions of
`fecheck.io.plots` (seen from the contact side, +x right, unlit colours, labels, outline,
axes, mm scale bar): the 3D FE contact pressure, the EF law's pressure at the same top
points under the same load (one colour scale for both, thesis Fig. 4.7), and their
difference FE − EF. Each compartment's FE top surface is drawn with its first touch
point on the knee's tibial contact point. `radial_profile` draws pressure against the
distance from the first touch point with Hertz overlaid (thesis Fig. 4.8).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from fecheck.fe.crosscheck import CompartmentCheck, CrossCheck
from fecheck.io.plots import INK, ColourScale, Figure, Panel, Patch, draw_maps
from fecheck.reference.closed_forms import column_stiffness

MAP_FILE = "fe_pressure_map.png"
"""The pressure-map file `write_fe_plots` writes into its folder."""

EF_OUTLINE = "magenta"


def ef_depth(check: CompartmentCheck) -> np.ndarray:
    """EF overlap max(0, d - g0) at the FE top points under the same load, mm (d the
    closed-form EF depth, g0 the initial gap of each point)."""
    return np.maximum(0.0, check.ef.depth_mm - check.fe.gap0_mm)


def ef_pressure(check: CompartmentCheck, E_MPa: float, nu: float,
                thickness_mm: float) -> np.ndarray:
    """EF pressure k·max(0, d - g0) at the FE top points under the same load, MPa."""
    return column_stiffness(E_MPa, nu, thickness_mm) * ef_depth(check)


def placed_points(check: CompartmentCheck, contact_point: np.ndarray | None) -> np.ndarray:
    """The FE top points (mm) moved so that the first touch point lies on
    `contact_point` (the knee's tibial contact point, world; unmoved for None)."""
    pts = np.asarray(check.fe.points, dtype=float)
    if contact_point is None:
        return pts
    return pts + (np.asarray(contact_point, dtype=float) - pts[np.argmin(check.fe.gap0_mm)])


def _all_positive(faces: np.ndarray, values: np.ndarray) -> np.ndarray:
    """(k,) faces whose three vertices all have a positive value."""
    return np.all(values[faces] > 0, axis=1)


def compartment_patches(check: CompartmentCheck, material: Mapping[str, float],
                        contact_point: np.ndarray | None) -> dict[str, Patch]:
    """The "FE", "EF" and "FE - EF" patches of one compartment (nodal values, MPa),
    outlined where the FE nodes are active (black) and the EF overlap is positive
    (black on the EF map, magenta on the difference map)."""
    fe = check.fe
    pts, faces = placed_points(check, contact_point), np.asarray(fe.faces)
    ef = ef_pressure(check, material["E_MPa"], material["nu"], material["thickness_mm"])
    fe_in = _all_positive(faces, np.asarray(fe.active, dtype=float))
    ef_in = _all_positive(faces, ef)
    name = check.name

    def patch(values, outlines, note):
        return Patch(name, pts, faces, values, outlines, note, per_point=True)

    m = fe.metrics
    return {"FE": patch(fe.pressure_MPa, ((fe_in, INK),),
                        f"p_max {m.max_pressure_MPa:.3f} MPa, {m.area_mm2:.1f} mm²"),
            "EF": patch(ef, ((ef_in, INK),), f"p_max {check.ef.max_pressure_MPa:.3f} MPa, "
                                             f"{check.ef.area_mm2:.1f} mm²"),
            "FE - EF": patch(fe.pressure_MPa - ef, ((fe_in, INK), (ef_in, EF_OUTLINE)),
                             f"{check.load_N:.1f} N")}


def _pressure_top(cross: CrossCheck) -> tuple[float, str]:
    """The largest printed p_max of the FE 3D and EF (closed form) rows, MPa, and where."""
    best = (0.0, "")
    for name, chk in cross.compartments.items():
        for label, m in (("FE 3D", chk.fe.metrics), ("EF", chk.ef)):
            if np.isfinite(m.max_pressure_MPa) and m.max_pressure_MPa > best[0]:
                best = (float(m.max_pressure_MPa), f"{label} {name}")
    return best


def fe_heading(scene: str, cross: CrossCheck, top: float, where: str, diff: float) -> str:
    """The heading of the FE pressure-map figure."""
    loads = ", ".join(f"{c} {chk.load_N:.1f} N" for c, chk in cross.compartments.items())
    return (f"{scene}: FE 3D vs elastic foundation (EF) under the EF compartment loads "
            f"({loads}); seen from above (the contact side), +x right, +y anterior up\n"
            f"each compartment's FE top surface is drawn at its tibial contact point; "
            f"nodal pressures interpolated over the top triangles\n"
            f"FE and EF share one colour bar, 0 to {top:.3f} MPa (the largest printed p_max,"
            f" {where}); difference bar ±{diff:.3f} MPa; outlines: FE contact black, "
            f"EF contact magenta")


def pressure_map_figure(cross: CrossCheck, contact_points: Mapping[str, np.ndarray],
                        scene: str = "") -> Figure | None:
    """The figure of FE, EF and FE − EF maps for both compartments (see the module
    docstring); None when no compartment has FE top triangles to draw."""
    patches = {"FE": [], "EF": [], "FE - EF": []}
    for name, chk in cross.compartments.items():
        if len(chk.fe.faces) == 0:
            continue
        for key, p in compartment_patches(chk, cross.material, contact_points.get(name)).items():
            patches[key].append(p)
    if not patches["FE"]:
        return None
    top, where = _pressure_top(cross)
    diff = max(float(np.abs(p.values).max()) for p in patches["FE - EF"]) or 1.0
    p_scale = ColourScale("pressure\n(MPa)", (0.0, top if top > 0 else 1.0))
    d_scale = ColourScale("FE - EF\n(MPa)", (-diff, diff), cmap="RdBu_r")
    panels = [Panel("FE 3D contact pressure (MPa)", patches["FE"], p_scale, bar=False),
              Panel("EF pressure at the FE points (MPa)", patches["EF"], p_scale),
              Panel("difference FE - EF (MPa)", patches["FE - EF"], d_scale)]
    return draw_maps(panels, fe_heading(scene, cross, top, where, diff))


def _radius(check: CompartmentCheck) -> np.ndarray:
    fe = check.fe
    center = fe.points[np.argmin(fe.gap0_mm), :2]
    return np.hypot(fe.points[:, 0] - center[0], fe.points[:, 1] - center[1])


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


def write_fe_plots(cross: CrossCheck, contact_points: Mapping[str, np.ndarray],
                   directory: str | Path, scene: str = "") -> list[Path]:
    """Write `fe_pressure_map.png` (when there is an FE surface to draw) and one radial
    profile `fe_profile_<compartment>.png` per compartment into `directory`; returns the
    written paths."""
    out = Path(directory)
    paths = []
    figure = pressure_map_figure(cross, contact_points, scene)
    if figure is not None:
        paths.append(figure.save(out / MAP_FILE))
    mat = cross.material
    for name, chk in cross.compartments.items():
        paths.append(radial_profile(chk, mat["E_MPa"], mat["nu"], mat["thickness_mm"],
                                    out / f"fe_profile_{name}.png"))
    return paths
