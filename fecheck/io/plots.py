"""Off-screen contact-pressure maps (pyvista, imported lazily inside the functions).

Every map follows the same conventions (`fecheck run --plot`, `fecheck fe --plot`):

* seen from the contact side: the camera sits above the tibial plateau and looks down
  -z with +y (anterior) up, so +x (the subject's right) is on the right of the
  picture; parallel projection, so the mm scale bar holds everywhere in the picture;
* both compartments in one picture, each labelled ("medial", "lateral") beside its
  patch, with the contact outline drawn as a line;
* unlit colours: a face's colour is exactly the colour bar's colour for its value;
* the colour bar sits in its own panel with its title above it (never over its ticks);
* a strip of its own under each map, so that they hide no mesh: orientation axes
  (x, y, z) at its left, a scale bar in mm drawn at the map's scale (mm per pixel) under
  the right end of the contact frame;
* the camera frames every contact patch with a margin (the whole mesh of a compartment
  without contact), whatever the size of the meshes.

Units: mm, MPa.
"""

from __future__ import annotations

import textwrap
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fecheck.model.results import RunResult

Bounds = tuple[float, float, float, float]
"""(x_min, x_max, y_min, y_max) of a region of the plateau plane, mm."""

MAP_FILE = "pressure_map.png"
"""The file `write_pressure_plots` writes into its folder."""

BACKGROUND = "white"
INK = "black"
MARGIN_FRACTION = 0.3      # margin around a contact patch, as a fraction of its size
MARGIN_MIN_MM = 3.0        # and at least this many mm
STRIP_ABOVE = 0.06         # strip above the contact frame for the labels, fraction of its height
SCALE_PX = 80              # strip under each map (axes, scale bar), px
AXES_WIDTH = 0.09          # width of the orientation axes in that strip, fraction
HEADING_LINE_PX = 20       # height of one heading line, px
HEADING_CHAR_PX = 10.5     # width of one heading character, px (estimate, for wrapping)
TITLE_PX = 44              # panel title row height, px
MAP_WEIGHT, BAR_WEIGHT = 5.0, 1.0    # widths of the map and colour-bar columns
LABEL_FONT = 17            # label font size, px
LABEL_CHAR_WIDTH = 0.6     # width of a label character, in font sizes (estimate)
LIFT_MM = 1.0              # lines and labels drawn this far above the meshes (toward the eye)


@dataclass(frozen=True, eq=False)
class Patch:
    """One contact surface to draw.

    name : compartment name ("medial", "lateral"), drawn beside the patch
    points : (n, 3) vertices in world coordinates, mm
    faces : (m, 3) triangles over `points`
    values : (m,) one value per face, or (n,) per vertex with `per_point`
    outlines : ((m,) bool face mask, colour) pairs: the boundary of each masked set of
        faces is drawn as a line of that colour (the first mask is the contact region
        the camera frames)
    note : text under the name (e.g. the compartment's force and p_max)
    lines : ((k, 2, 3) world segments, colour) pairs drawn flat just above the patch
        (e.g. a meniscus's footprint edge)
    """

    name: str
    points: np.ndarray
    faces: np.ndarray
    values: np.ndarray
    outlines: tuple[tuple[np.ndarray, str], ...] = ()
    note: str = ""
    per_point: bool = False
    lines: tuple[tuple[np.ndarray, str], ...] = ()

    @property
    def contact(self) -> np.ndarray:
        """(m,) bool, the faces in contact (the first outline's mask; none without)."""
        if not self.outlines:
            return np.zeros(len(self.faces), dtype=bool)
        return np.asarray(self.outlines[0][0], dtype=bool)


@dataclass(frozen=True)
class ColourScale:
    """A colour bar: map range `clim` (in the unit of `title`), colour map, tick format."""

    title: str
    clim: tuple[float, float]
    cmap: str = "viridis"
    fmt: str = "%.3f"


@dataclass(frozen=True, eq=False)
class Panel:
    """One map of a figure: its patches, colour scale and title; `bar` draws the colour
    bar in a panel of its own to the right (panels sharing a scale draw it once)."""

    title: str
    patches: Sequence[Patch]
    scale: ColourScale
    bar: bool = True


@dataclass(eq=False)
class Figure:
    """A drawn figure: the pyvista plotter (close it after use), the map renderers, the
    scale-bar renderers (one under each map), the colour bars, every text drawn
    (heading, titles, labels) and the `Patch.lines` drawn (pyvista lines), for checks."""

    plotter: object
    maps: list = field(default_factory=list)
    scales: list = field(default_factory=list)
    bars: list = field(default_factory=list)
    texts: list[str] = field(default_factory=list)
    lines: list = field(default_factory=list)

    def save(self, path: str | Path) -> Path:
        """Write the PNG to `path` and close the plotter."""
        from fecheck.io.outputs import write_output

        path = write_output(path, lambda tmp: self.plotter.screenshot(str(tmp)))
        self.plotter.close()
        return path


def _pyvista():
    """pyvista, with off-screen EGL rendering unless the caller chose a window."""
    import os

    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    return pv


def _polydata(pv, points: np.ndarray, faces: np.ndarray):
    cells = np.hstack([np.full((len(faces), 1), 3), faces]).ravel()
    return pv.PolyData(np.asarray(points, dtype=float), cells)


# ---------------------------------------------------------------------- framing (numpy)
def _box(points: np.ndarray) -> Bounds:
    lo, hi = points[:, :2].min(axis=0), points[:, :2].max(axis=0)
    return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])


def _union(boxes: Sequence[Bounds]) -> Bounds:
    b = np.array(boxes)
    return float(b[:, 0].min()), float(b[:, 1].max()), float(b[:, 2].min()), float(b[:, 3].max())


def patch_frame(patch: Patch) -> Bounds:
    """The plateau region to show for one patch, mm: its contact faces' bounds with a
    margin (30 % of their size, at least 3 mm), kept inside the mesh; the whole mesh
    when nothing is in contact; widened to hold the patch's lines."""
    mesh_box = _box(patch.points)
    hot = patch.contact
    lines = [np.reshape(seg, (-1, 3)) for seg, _ in patch.lines if len(seg)]
    if not hot.any():
        return _union([mesh_box, *map(_box, lines)])
    x0, x1, y0, y1 = _box(patch.points[np.unique(patch.faces[hot])])
    m = max(MARGIN_MIN_MM, MARGIN_FRACTION * max(x1 - x0, y1 - y0))
    return _union([(max(x0 - m, mesh_box[0]), min(x1 + m, mesh_box[1]),
                    max(y0 - m, mesh_box[2]), min(y1 + m, mesh_box[3])), *map(_box, lines)])


def frame_bounds(patches: Sequence[Patch]) -> Bounds:
    """The region every map of these patches frames: the union of each patch's `patch_frame`, mm."""
    return _union([patch_frame(p) for p in patches])


def scale_bar_length(width_mm: float) -> float:
    """A round scale-bar length (1, 2 or 5 × 10^k mm) of about a sixth of `width_mm`."""
    target = max(width_mm / 6.0, 1e-3)
    k = np.floor(np.log10(target))
    steps = np.array([1.0, 2.0, 5.0, 10.0]) * 10.0 ** k
    return float(steps[steps <= target].max())


# ---------------------------------------------------------------------- drawing (pyvista)
def _boundary(mesh, lift: float):
    """The boundary edges of a surface mesh, lifted `lift` mm toward the eye (or None)."""
    edges = mesh.extract_feature_edges(boundary_edges=True, feature_edges=False,
                                       manifold_edges=False, non_manifold_edges=False)
    if edges.n_points == 0:
        return None
    return edges.translate((0.0, 0.0, lift), inplace=False)


def _outline(mesh, mask: np.ndarray):
    """The edge of the masked faces of `mesh` as lines, lifted toward the eye (or None)."""
    if not np.any(mask):
        return None
    region = mesh.extract_cells(np.flatnonzero(mask)).extract_surface(algorithm=None)
    return _boundary(region, LIFT_MM)


def _segments(pv, segments: np.ndarray, z: float):
    """(k, 2, 3) segments as one pyvista line mesh, flattened to height `z` (mm)."""
    pts = np.asarray(segments, dtype=float).reshape(-1, 3).copy()
    pts[:, 2] = z
    cells = np.column_stack([np.full(len(segments), 2), np.arange(len(pts)).reshape(-1, 2)])
    return pv.PolyData(pts, lines=cells.ravel())


def _add_patch(plotter, pv, patch: Patch, scale: ColourScale, drawn: list):
    """Draw one patch unlit, its mesh edge in grey, its outlines and its lines (appended
    to `drawn`); returns the actor."""
    mesh = _polydata(pv, patch.points, patch.faces)
    data = mesh.point_data if patch.per_point else mesh.cell_data
    data["values"] = np.asarray(patch.values, dtype=float)
    actor = plotter.add_mesh(mesh, scalars="values", clim=scale.clim, cmap=scale.cmap,
                             lighting=False, show_scalar_bar=False, show_edges=False)
    edge = _boundary(mesh, 0.5 * LIFT_MM)
    if edge is not None:
        plotter.add_mesh(edge, color="grey", line_width=1, lighting=False)
    for mask, colour in patch.outlines:
        line = _outline(mesh, np.asarray(mask, dtype=bool))
        if line is not None:
            plotter.add_mesh(line, color=colour, line_width=2.5, lighting=False)
    top = float(np.asarray(patch.points)[:, 2].max()) + LIFT_MM
    for segments, colour in patch.lines:
        if len(segments):
            drawn.append(_segments(pv, segments, top))
            plotter.add_mesh(drawn[-1], color=colour, line_width=3, lighting=False)
    return actor


def _mm_per_pixel(plotter) -> float:
    """World size of one pixel of the active renderer (parallel projection), mm."""
    _, y0, _, y1 = plotter.renderer.GetViewport()
    return 2.0 * plotter.camera.parallel_scale / ((y1 - y0) * plotter.window_size[1])


def _label_point(patch: Patch, text: str, frame: Bounds, mm_per_px: float,
                 top_z: float) -> np.ndarray:
    """Where a patch's label starts (its lower left corner), mm: just anterior of its
    contact region (or mesh), from its left edge, moved left to stay inside `frame`."""
    hot = patch.contact
    pts = patch.points[np.unique(patch.faces[hot])] if hot.any() else patch.points
    x0, _, _, y1 = _box(pts)
    width = LABEL_CHAR_WIDTH * LABEL_FONT * max(len(line) for line in text.splitlines())
    x = max(frame[0], min(x0, frame[1] - width * mm_per_px))
    return np.array([x, y1 + 1.0, top_z])


def _add_labels(plotter, patches: Sequence[Patch], frame: Bounds, top_z: float,
                texts: list[str]) -> None:
    """The name (and note) of every patch in a white box beside its contact region."""
    labels = [p.name + (f"\n{p.note}" if p.note else "") for p in patches]
    scale = _mm_per_pixel(plotter)
    points = [_label_point(p, t, frame, scale, top_z) for p, t in zip(patches, labels,
                                                                      strict=True)]
    plotter.add_point_labels(np.array(points), labels, font_size=LABEL_FONT, text_color=INK,
                             shape="rounded_rect", shape_color="white", shape_opacity=0.8,
                             show_points=False, always_visible=True)
    texts.extend(labels)


def _add_scale_bar(plotter, pv, frame: Bounds, mm_per_px: float, texts: list[str]) -> float:
    """The orientation axes and a round-length bar (mm) in the active (strip) renderer,
    the bar under the right end of the map's contact frame: the strip's camera has the
    map's centre x, view and scale (`mm_per_px`), so the bar is as long as that many mm
    of the map. Its length is written above it; returns the length, mm."""
    x0, x1, _, _ = frame
    length = scale_bar_length(x1 - x0)
    _, v0, _, v1 = plotter.renderer.GetViewport()
    half = 0.5 * (v1 - v0) * plotter.window_size[1] * mm_per_px   # half the row, mm
    right, y = x1 - 0.15 * length, -0.45 * half
    plotter.add_mesh(pv.Line((right - length, y, 0.0), (right, y, 0.0)), color=INK,
                     line_width=5, lighting=False)
    label = f"{length:g} mm"
    plotter.add_point_labels(np.array([[right - 0.65 * length, y + 0.12 * half, 0.0]]),
                             [label], font_size=LABEL_FONT, text_color=INK, shape=None,
                             show_points=False, always_visible=True)
    texts.append(label)
    plotter.add_axes(xlabel="x", ylabel="y", zlabel="z", color=INK, line_width=3,
                     viewport=(0.0, 0.0, AXES_WIDTH, 1.0))
    cam = plotter.camera
    cam.focal_point = (0.5 * (x0 + x1), 0.0, 0.0)
    cam.position = (0.5 * (x0 + x1), 0.0, 1000.0)
    cam.up = (0.0, 1.0, 0.0)
    plotter.enable_parallel_projection()
    cam.parallel_scale = half
    plotter.renderer.ResetCameraClippingRange()
    return length


def camera_frame(frame: Bounds) -> Bounds:
    """The contact frame with a strip above for the labels, mm."""
    x0, x1, y0, y1 = frame
    return x0, x1, y0, y1 + STRIP_ABOVE * (y1 - y0)


def _aspect(plotter) -> float:
    """Width / height of the active renderer in pixels."""
    x0, y0, x1, y1 = plotter.renderer.GetViewport()
    w, h = plotter.window_size
    return (x1 - x0) * w / ((y1 - y0) * h)


def frame_camera(plotter, frame: Bounds, top_z: float) -> None:
    """Parallel projection from +z (above the plateau), view-up +y, showing `frame`
    with a 6 % border in the active renderer."""
    x0, x1, y0, y1 = frame
    centre = (0.5 * (x0 + x1), 0.5 * (y0 + y1), top_z)
    cam = plotter.camera
    cam.focal_point = centre
    cam.position = (centre[0], centre[1], top_z + 1000.0)
    cam.up = (0.0, 1.0, 0.0)
    plotter.enable_parallel_projection()
    half = max(0.5 * (y1 - y0), 0.5 * (x1 - x0) / _aspect(plotter))
    cam.parallel_scale = 1.06 * half
    plotter.renderer.ResetCameraClippingRange()


def _draw_map(plotter, pv, panel: Panel, frame: Bounds, fig: Figure):
    """Patches, camera and labels in the active renderer; returns the
    first patch's mapper (its lookup table is the panel's colour bar)."""
    texts = fig.texts
    actors = [_add_patch(plotter, pv, p, panel.scale, fig.lines) for p in panel.patches]
    top_z = max(float(p.points[:, 2].max()) for p in panel.patches) + LIFT_MM
    frame_camera(plotter, camera_frame(frame), top_z)
    _add_labels(plotter, panel.patches, frame, top_z + LIFT_MM, texts)
    return actors[0].mapper


def _add_bar(plotter, mapper, scale: ColourScale, texts: list[str]):
    """A vertical colour bar in the active (bar) renderer, its title above it."""
    bar = plotter.add_scalar_bar(title="", mapper=mapper, unique_bar=True, vertical=True,
                                 position_x=0.12, position_y=0.04, width=0.3, height=0.78,
                                 n_labels=5, fmt=scale.fmt, color=INK, label_font_size=20)
    plotter.add_text(scale.title, position=(0.05, 0.86), viewport=True, font_size=11,
                     color=INK)
    texts.append(scale.title)
    return bar


def _bar_groups(panels: Sequence[Panel]) -> list[tuple[int, int]]:
    """(first panel, last panel) of each colour bar: a bar spans the panels without a
    bar just before its own."""
    groups, first = [], 0
    for i, panel in enumerate(panels):
        if panel.bar:
            groups.append((first, i))
            first = i + 1
    return groups


def _wrap(heading: str, width: int) -> str:
    """The heading with each line wrapped to the window width (px)."""
    chars = int(width / HEADING_CHAR_PX)
    return "\n".join(textwrap.fill(line, chars) for line in heading.splitlines())


def _window(panels: Sequence[Panel], frame: Bounds, width: int, heading_px: float
            ) -> tuple[int, int]:
    """Window size (px) fitting one map row per panel to the frame's aspect."""
    x0, x1, y0, y1 = camera_frame(frame)
    map_w = width * MAP_WEIGHT / (MAP_WEIGHT + BAR_WEIGHT)
    map_h = float(np.clip(map_w * (y1 - y0) / max(x1 - x0, 1e-9) * 1.08, 320, 1000))
    return width, int(heading_px + len(panels) * (TITLE_PX + map_h + SCALE_PX))


def _layout(pv, panels: Sequence[Panel], window: tuple[int, int], heading_px: float):
    """Plotter with a heading row, then a title row, a map row and a scale-bar row per
    panel; the maps in the wide left column, the colour bars in the narrow right one."""
    map_h = (window[1] - heading_px) / len(panels) - TITLE_PX - SCALE_PX
    rows = [heading_px] + [TITLE_PX, map_h, SCALE_PX] * len(panels)
    groups = [(0, np.s_[:])] + [(np.s_[2 + 3 * a:3 + 3 * b], 1)
                                for a, b in _bar_groups(panels) if b > a]
    plotter = pv.Plotter(shape=(len(rows), 2), row_weights=rows,
                         col_weights=[MAP_WEIGHT, BAR_WEIGHT], groups=groups,
                         off_screen=True, window_size=window, border=False)
    plotter.set_background(BACKGROUND)
    return plotter


def draw_maps(panels: Sequence[Panel], heading: str, width: int = 1400) -> Figure:
    """A figure of map panels one above the other, all framing the same plateau region
    (the union of every panel's `frame_bounds`), with one heading across the top and
    each colour bar to the right of the panels it serves."""
    pv = _pyvista()
    frame = _union([frame_bounds(p.patches) for p in panels])
    heading = _wrap(heading, width)
    heading_px = HEADING_LINE_PX * (heading.count("\n") + 1.6)
    plotter = _layout(pv, panels, _window(panels, frame, width, heading_px), heading_px)
    fig = Figure(plotter)
    bar_rows = {b: 2 + 3 * a for a, b in _bar_groups(panels)}
    for i, panel in enumerate(panels):
        plotter.subplot(1 + 3 * i, 0)
        plotter.add_text(panel.title, position=(0.005, 0.2), viewport=True, font_size=12,
                         color=INK)
        fig.texts.append(panel.title)
        plotter.subplot(2 + 3 * i, 0)
        mapper = _draw_map(plotter, pv, panel, frame, fig)
        fig.maps.append(plotter.renderer)
        mm_per_px = _mm_per_pixel(plotter)
        plotter.subplot(3 + 3 * i, 0)
        _add_scale_bar(plotter, pv, frame, mm_per_px, fig.texts)
        fig.scales.append(plotter.renderer)
        if i in bar_rows:
            plotter.subplot(bar_rows[i], 1)
            fig.bars.append(_add_bar(plotter, mapper, panel.scale, fig.texts))
    plotter.subplot(0, 0)
    plotter.add_text(heading, position=(0.004, 0.1), viewport=True, font_size=10, color=INK)
    fig.texts.append(heading)
    return fig


# ---------------------------------------------------------------------- fecheck run
def has_pressure_map(result: RunResult) -> bool:
    """Whether the run has face pressures to draw (the rigid model has none)."""
    return any(c.face_pressure_MPa is not None and c.slave_points is not None
               for c in result.compartments.values())


def printed_max_pressure(result: RunResult) -> tuple[float, str]:
    """The largest p_max over the compartments (MPa, as `fecheck run` prints it) and
    the compartment it belongs to."""
    name = max(result.compartments, key=lambda c: result.compartments[c].max_pressure_MPa)
    return float(result.compartments[name].max_pressure_MPa), name


def run_patches(result: RunResult) -> list[Patch]:
    """One patch per compartment with face pressures: the face-mean pressure (MPa), the
    in-contact faces (p > 0) outlined, force and p_max under the name."""
    patches = []
    for name, c in result.compartments.items():
        if c.face_pressure_MPa is None or c.slave_points is None:
            continue
        p = np.asarray(c.face_pressure_MPa, dtype=float)
        note = f"{c.force_N:.1f} N, p_max {c.max_pressure_MPa:.3f} MPa"
        patches.append(Patch(name, c.slave_points, c.slave_faces, p, ((p > 0, INK),), note))
    return patches


def run_heading(result: RunResult, p_max: float, where: str, face_max: float) -> str:
    """The heading of a run's pressure map (says what the colours and the bar mean)."""
    return (f"{result.scene}: contact pressure seen from above (the contact side), +x "
            f"(subject's right) to the right, +y (anterior) up, parallel view\n"
            f"each face shows its mean pressure (largest face mean {face_max:.3f} MPa); "
            f"black line: edge of the faces in contact\n"
            f"colour bar: 0 to p_max = {p_max:.3f} MPa ({where}, the pointwise maximum "
            f"printed by fecheck run)")


MENISCUS_INK = "red"
"""Colour of a meniscus's footprint edge on the pressure maps."""


def meniscus_panels(result: RunResult, patches: Sequence[Patch]) -> tuple[list[Patch],
                                                                           list[Patch]]:
    """With menisci: (the cartilage patches with each meniscus's footprint edge, the
    meniscus-on-tibia patches: the meniscus's face-mean pressure on the same tibial
    faces, its contact outlined, its footprint edge, its load and share)."""
    maps, rows = result.meniscus_maps, result.menisci.get("compartments", {})
    lined, under = [], []
    for patch in patches:
        m = maps.get(patch.name)
        lines = () if m is None else ((m["outline"], MENISCUS_INK),)
        lined.append(Patch(patch.name, patch.points, patch.faces, patch.values,
                           patch.outlines, patch.note, patch.per_point, lines))
        if m is None:
            continue
        p, row = np.asarray(m["pressure_MPa"], dtype=float), rows[patch.name]
        note = (f"meniscus {row['meniscus_N']:.1f} N ({100 * row['meniscal_share']:.1f} %), "
                f"p_max {row['meniscus_tibia_max_pressure_MPa']:.3f} MPa")
        under.append(Patch(patch.name, patch.points, patch.faces, p, ((p > 0, INK),), note,
                           lines=lines))
    return lined, under


def pressure_map_figure(result: RunResult) -> Figure:
    """The figure of `write_pressure_plots` (not saved): both compartments in one map,
    colour bar 0 … the printed p_max; with menisci a second map, in the same colours, of
    the menisci's pressure on the tibia, and each meniscus's footprint edge on both.
    Raises ValueError without face pressures."""
    patches = run_patches(result)
    if not patches:
        raise ValueError(f"{result.scene}: the {result.model} model has no pressure map")
    p_max, where = printed_max_pressure(result)
    face_max = max(float(p.values.max()) for p in patches)
    top = p_max if p_max > 0 else max(face_max, 1.0)
    scale = ColourScale("pressure\n(MPa)\nface means", (0.0, top))
    heading = run_heading(result, p_max, where, face_max)
    if not result.meniscus_maps:
        panel = Panel("contact pressure, MPa (face means)", patches, scale)
        return draw_maps([panel], heading)
    lined, under = meniscus_panels(result, patches)
    panels = [Panel("cartilage-cartilage contact pressure on the tibial cartilage, MPa "
                    "(face means)", lined, scale, bar=False),
              Panel("meniscus-tibia contact pressure on the tibial cartilage, MPa (face "
                    "means, same colours)", under, scale)]
    return draw_maps(panels, heading + f"\n{MENISCUS_INK} line: edge of each meniscus's "
                     "footprint (its volume projected on x-y at the solved pose)")


def write_pressure_plots(result: RunResult, directory: str | Path) -> list[Path]:
    """Write `pressure_map.png` (both compartments, see `pressure_map_figure`) into
    `directory`; returns the written paths, none for a model without pressure maps."""
    if not has_pressure_map(result):
        return []
    return [pressure_map_figure(result).save(Path(directory) / MAP_FILE)]
