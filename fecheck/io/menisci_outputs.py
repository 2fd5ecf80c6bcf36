"""``fecheck fe --plot`` and ``--vtk`` on a scene with menisci
(`fecheck.fe.knee.knee_menisci.KneeMenisciFE`): the tibial pressure with each meniscus's
footprint, and the femur's pressure on each meniscus's superior surface. Units: mm, MPa;
the tibia frame.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fecheck.io.outputs import write_output


def pressure_figure(result, title: str):
    """A matplotlib figure: left the tibial layers' vertex pressure seen from above with
    each meniscus's footprint outlined (white), right the femur's pressure on each
    meniscus's superior surface; one colour scale (MPa) up to the tibial p_max (a vertex
    of a meniscus's superior surface at the edge of its labelled faces has a small
    tributary area, so its nodal pressure may lie far above: such values saturate, and
    each meniscus's own peak is printed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection

    top = max(float(v.max(initial=0.0)) for v in result.pressure_MPa.values()) or 1.0
    notes = {"left": [], "right": []}
    fig, (left, right) = plt.subplots(1, 2, figsize=(14, 5.5), constrained_layout=True)
    art = None
    for c, surface in result.surfaces.items():
        pts = surface.points
        art = left.tripcolor(pts[:, 0], pts[:, 1], surface.faces, result.pressure_MPa[c],
                             shading="gouraud", cmap="viridis", vmin=0.0, vmax=top)
        if c in result.outlines:
            left.add_collection(LineCollection(result.outlines[c][:, :, :2], colors="w",
                                               linewidths=1.0))
        fe = result.fe[c]
        notes["left"].append(f"{c}: meniscal share {fe.share:.1%}, p_max "
                             f"{fe.p_max_MPa:.2f} MPa")
    for c, (surface, pressure) in result.meniscus_surfaces.items():
        pts = surface.points
        art = right.tripcolor(pts[:, 0], pts[:, 1], surface.faces, pressure,
                              shading="gouraud", cmap="viridis", vmin=0.0, vmax=top)
        notes["right"].append(f"{c}: femur on it {result.fe[c].femur_on_meniscus_N:.0f} N, "
                              f"nodal p_max {pressure.max():.2f} MPa")
    for ax, what in ((left, "tibial contact pressure, meniscus footprints (white)\n"
                      + "\n".join(notes["left"])),
                     (right, "femur's pressure on the menisci's superior surfaces\n"
                      + "\n".join(notes["right"]))):
        ax.set_aspect("equal")
        ax.autoscale_view()
        ax.set_xlabel("x mm (right)")
        ax.set_ylabel("y mm (anterior)")
        ax.set_title(what, fontsize=10)
    if art is not None:
        fig.colorbar(art, ax=[left, right], label="pressure, MPa (up to the tibial p_max)")
    fig.suptitle(f"{title}: FE with menisci ({result.cartilage} cartilage), "
                 f"{result.load_N:.0f} N", fontsize=11)
    return fig


def write_menisci_plots(result, directory: str | Path, title: str) -> list[Path]:
    """Write ``DIR/menisci_pressure.png`` (`pressure_figure`); the paths written."""
    import matplotlib.pyplot as plt

    path = Path(directory) / "menisci_pressure.png"
    fig = pressure_figure(result, title)
    write_output(path, lambda tmp: fig.savefig(tmp, dpi=110, format="png"))
    plt.close(fig)
    return [path]


def write_menisci_vtk(result, directory: str | Path) -> list[Path]:
    """Write per compartment ``tibia_<c>.vtu`` (the tibial layer's surface, point data
    ``pressure_MPa`` and ``region``: 0 cartilage contact, 1-3 under the meniscus's
    anterior horn, body, posterior horn) and per meniscus ``meniscus_<c>_superior.vtu``
    (point data ``pressure_MPa``, the femur's); the paths written (tibia frame, mm)."""
    from fecheck.io.vtk import write_vtu

    directory = Path(directory)
    out = []
    for c, surface in result.surfaces.items():
        region = result.tibial_region.get(c, np.zeros(len(surface.points), dtype=np.int64))
        out.append(write_vtu(directory / f"tibia_{c}.vtu", surface.points, surface.faces, {},
                             {"pressure_MPa": result.pressure_MPa[c], "region": region}))
    for c, (surface, pressure) in result.meniscus_surfaces.items():
        out.append(write_vtu(directory / f"meniscus_{c}_superior.vtu", surface.points,
                             surface.faces, {}, {"pressure_MPa": pressure}))
    return out
