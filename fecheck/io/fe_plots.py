"""The pressure-map figure of the FE cross-check (`fecheck fe --plot`; pyvista, imported
lazily through `fecheck.io.plots`).

Both compartments in one picture, drawn where they are in the tibia frame (mm) with the
conventions of `fecheck.io.plots` (seen from the contact side, +x right, +y anterior up,
unlit colours, labels, mm scale bar), framing the whole tibial surfaces (their edges are
the knee outline). On the EF run's tibial faces:

1. the EF face pressure,
2. the FE pressure averaged onto the same faces (one colour scale for 1 and 2),
3. FE − EF on a symmetric diverging scale;

with the centres of pressure marked (FE "+", EF "×"). When the EF pressure lives on
another mesh (e.g. ``contact.master = 'plateau'``) only the FE map is drawn.
Units: mm, MPa.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from fecheck.io.plots import INK, LIFT_MM, ColourScale, Figure, Panel, Patch, draw_maps

if TYPE_CHECKING:
    from fecheck.fe.knee.crosscheck import CompartmentCheck, CrossCheck

MAP_FILE = "fe_pressure_map.png"
"""The pressure-map file `write_fe_plots` writes into its folder."""

FE_COLOUR = "darkorange"   # FE contact outline
EF_COLOUR = "magenta"      # EF contact outline and centre-of-pressure mark
FE_MARK = INK              # FE centre-of-pressure mark
MARK_MM = 1.5              # half-length of a centre-of-pressure mark's arms, mm
NO_EF = "no EF map: the EF face pressure lives on another mesh (e.g. contact.master = 'plateau')"


def has_ef_map(check: CrossCheck) -> bool:
    """Whether every compartment has the EF face pressure on its EF faces."""
    return all(c.ef_face_pressure_MPa is not None for c in check.compartments.values())


def difference(comp: CompartmentCheck) -> np.ndarray:
    """(n_ef_faces,) FE − EF face pressure, MPa (requires the EF face pressure)."""
    return comp.fe_face_pressure_MPa - comp.ef_face_pressure_MPa


def _patch(comp: CompartmentCheck, values: np.ndarray, outlines, note: str) -> Patch:
    """A patch on the EF faces (tibia frame); the first outline (all faces, so the map
    frames the whole surface) draws the surface's edge."""
    surface = comp.layer.body.surface
    every = np.ones(surface.n_faces, dtype=bool)
    return Patch(comp.name, surface.points, surface.faces, np.asarray(values, dtype=float),
                 ((every, INK), *outlines), note)


def _side_note(label: str, m) -> str:
    """"<label> <force> N, p_max <p> MPa" of one side's metrics (`SideMetrics`)."""
    return f"{label} {m.force_N:.1f} N, p_max {m.max_pressure_MPa:.3f} MPa"


def compartment_patches(comp: CompartmentCheck) -> dict[str, Patch]:
    """The "FE" patch of one compartment and, with the EF face pressure, its "EF" and
    "FE - EF" patches (face values, MPa); contact outlines FE orange, EF magenta."""
    fe = comp.fe_face_pressure_MPa
    fe_line = (fe > 0, FE_COLOUR)
    note = _side_note("FE", comp.fe)
    if comp.peaks is not None and comp.peaks.spike:
        note += f" (a lone-vertex spike; smoothed {comp.peaks.smoothed_MPa:.3f} MPa)"
    out = {"FE": _patch(comp, fe, (fe_line,), note)}
    if comp.ef_face_pressure_MPa is not None:
        ef_line = (comp.ef_face_pressure_MPa > 0, EF_COLOUR)
        out["EF"] = _patch(comp, comp.ef_face_pressure_MPa, (ef_line,),
                           _side_note("EF", comp.ef_model))
        cop = comp.cop_distance_mm
        note = f"CoP FE to EF {cop:.2f} mm" if np.isfinite(cop) else "CoP n/a"
        out["FE - EF"] = _patch(comp, difference(comp), (fe_line, ef_line), note)
    return out


def spike_cap(check: CrossCheck) -> float | None:
    """With a lone-vertex FE spike in any compartment, the largest smoothed FE peak (MPa)
    the pressure bar stops at (so the spike does not swamp the map); None otherwise."""
    peaks = [c.peaks for c in check.compartments.values() if c.peaks is not None]
    if not any(p.spike for p in peaks):
        return None
    return max(p.smoothed_MPa for p in peaks)


def _pressure_scale(check: CrossCheck, top: float) -> ColourScale:
    """0 to `top` MPa, or to the EF peak and smoothed FE peak with a lone spike (the bar's
    title says so)."""
    cap = spike_cap(check)
    if cap is None:
        return ColourScale("pressure\n(MPa)", (0.0, top))
    ef = [float(np.max(c.ef_face_pressure_MPa)) for c in check.compartments.values()
          if c.ef_face_pressure_MPa is not None]
    return ColourScale("pressure (MPa)\ncapped at the\nsmoothed FE peak",
                       (0.0, min(top, max([cap, *ef])) or 1.0))


def fe_panels(check: CrossCheck) -> list[Panel]:
    """EF and FE maps on one scale (MPa, 0 to the largest face value, or capped at the
    smoothed FE peak with a lone-vertex spike) and FE − EF on a symmetric diverging one;
    the FE map alone without EF face pressures."""
    patches = [compartment_patches(c) for c in check.compartments.values()]
    fe = [p["FE"] for p in patches]
    if not has_ef_map(check):
        top = max(float(p.values.max()) for p in fe) or 1.0
        scale = _pressure_scale(check, top)
        return [Panel("FE pressure on the EF faces (MPa); no EF map (see above)", fe, scale)]
    ef, diff = [p["EF"] for p in patches], [p["FE - EF"] for p in patches]
    top = max(float(p.values.max()) for p in fe + ef) or 1.0
    span = max(float(np.abs(p.values).max()) for p in diff) or 1.0
    scale = _pressure_scale(check, top)
    if spike_cap(check) is not None:
        span = min(span, scale.clim[1])
    d_scale = ColourScale("FE - EF\n(MPa)", (-span, span), cmap="RdBu_r")
    return [Panel("EF pressure on the EF faces (MPa)", ef, scale, bar=False),
            Panel("FE pressure averaged onto the same faces (MPa)", fe, scale),
            Panel("difference FE - EF (MPa)", diff, d_scale)]


def fe_heading(check: CrossCheck, title: str, panels: Sequence[Panel]) -> str:
    """The figure's heading: scene, mode, view and what the colours, lines and marks mean
    (three panels: EF, FE, FE − EF; one: FE only)."""
    with_ef = len(panels) == 3
    top = panels[0].scale.clim[1]
    bars = (f"pressure bar 0 to {top:.3f} MPa (the largest face mean)"
            if spike_cap(check) is None else
            f"pressure bar 0 to {top:.3f} MPa, capped at the smoothed FE peak: a lone-vertex "
            "FE spike (see the report) would swamp it")
    bars += f"; difference bar ±{panels[2].scale.clim[1]:.3f} MPa" if with_ef else ""
    lines = f"surface edge black, FE contact {FE_COLOUR}"
    lines += f", EF contact {EF_COLOUR}" if with_ef else ""
    return "\n".join([
        f"{title}: FE vs elastic foundation (EF), fe.mode = {check.settings.mode}, "
        f"fe.refine = {check.settings.refine}" + ("" if with_ef else f"; {NO_EF}"),
        "tibial surfaces seen from above (the contact side), tibia frame: +x (subject's "
        "right) to the right, +y (anterior) up, parallel view",
        f"each face of the EF mesh shows its mean pressure; {bars}",
        f"lines: {lines}; centre of pressure: FE + {FE_MARK}, EF \u00d7 {EF_COLOUR}"])


def mark_points(centre: np.ndarray, cross: bool) -> np.ndarray:
    """(4, 3) end points of the two arms of a "+" (or "×" with `cross`) at `centre`, mm."""
    arms = np.array([[1.0, 0.0], [0.0, 1.0]])
    if cross:
        arms = arms @ np.array([[1.0, 1.0], [-1.0, 1.0]]) / np.sqrt(2.0)
    ends = np.repeat(np.asarray(centre, dtype=float)[None], 4, axis=0)
    ends[:, :2] += MARK_MM * np.vstack([arms, -arms])[[0, 2, 1, 3]]
    return ends


def _add_marks(fig: Figure, check: CrossCheck) -> None:
    """The FE and EF centres of pressure on every map of `fig`, above everything else."""
    import pyvista as pv

    comps = list(check.compartments.values())
    z = max(float(c.layer.body.surface.points[:, 2].max()) for c in comps) + 3 * LIFT_MM
    plotter = fig.plotter
    for renderer in fig.maps:
        plotter.subplot(*plotter.renderers.index_to_loc(list(plotter.renderers).index(renderer)))
        for comp in comps:
            for m, colour, cross in ((comp.fe, FE_MARK, False),
                                     (comp.ef_model, EF_COLOUR, True)):
                if m.center_of_pressure_mm is None:
                    continue
                ends = mark_points([*m.center_of_pressure_mm[:2], z], cross)
                plotter.add_mesh(pv.line_segments_from_points(ends), color=colour,
                                 line_width=3, lighting=False, reset_camera=False)
        renderer.ResetCameraClippingRange()


def pressure_map_figure(check: CrossCheck, title: str) -> Figure:
    """The figure of `write_fe_plots` (not saved; see the module docstring)."""
    panels = fe_panels(check)
    fig = draw_maps(panels, fe_heading(check, title, panels))
    _add_marks(fig, check)
    return fig


def write_fe_plots(check: CrossCheck, directory: str | Path, title: str) -> list[Path]:
    """Write `fe_pressure_map.png` (see `pressure_map_figure`) into `directory`; returns
    the written paths."""
    return [pressure_map_figure(check, title).save(Path(directory) / MAP_FILE)]
