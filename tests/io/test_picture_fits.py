"""What a picture shows, checked without reading pixels: a long preview title fits its
figure and keeps both ends; the mm scale bar of a pressure map lies outside the mesh as
drawn, at the map's own scale; the validation pressure maps' colour bar tops at the
largest p_max they print."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fecheck.model.results import CompartmentResult, RunResult

VALIDATION = Path(__file__).resolve().parents[2] / "validation"
POSE = {k: 0.0 for k in ("x_mm", "y_mm", "z_mm", "abduction_deg", "internal_deg")}
LONG_TITLE = ("subject_0042_visit_03_right_knee_" * 4 + "scene.toml: "
              + "femoral_cartilage_segmentation_final_v2_" * 3 + "femur.stl on "
              + "tibial_cartilage_segmentation_final_v2_" * 3 + "tibia.stl "
              "(right knee, rest pose)")


# ---------------------------------------------------------------------- preview title
def _preview_figure():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(13, 9.5), layout="constrained")  # the preview's
    return plt, fig


def _drawn_box(fig, text):
    fig.canvas.draw()
    return text.get_window_extent(fig.canvas.get_renderer())


def test_middle_ellipsis_keeps_the_start_and_the_end():
    from fecheck.io.knee_preview import middle_ellipsis

    assert middle_ellipsis("abcdefghij", 10) == "abcdefghij"
    assert middle_ellipsis("abcdefghij", 5) == "ab…ij"           # 2 + 1 + 2 characters
    assert middle_ellipsis("abcdefghij", 6) == "abc…ij"


def test_a_long_preview_title_fits_the_figure_and_keeps_both_ends():
    from fecheck.io.knee_preview import fit_title

    plt, fig = _preview_figure()
    try:
        text = fit_title(fig, LONG_TITLE)
        box = _drawn_box(fig, text)
        shown = text.get_text()
    finally:
        plt.close(fig)
    assert box.x0 >= 0.0 and box.x1 <= fig.bbox.width, (box, fig.bbox.width)
    assert shown.count("\n") == 1 and "…" in shown
    assert shown.startswith("subject_0042_visit_03") and shown.endswith("(right knee, rest pose)")


def test_a_title_that_fits_on_two_lines_keeps_every_character():
    from fecheck.io.knee_preview import fit_title

    title = ("subject_0042_visit_03_right_knee_long_scene_name.toml: "
             "subject_0042_visit_03_right_knee_femoral_cartilage_segmentation_final_v2.stl on "
             "subject_0042_visit_03_right_knee_tibial_cartilage_segmentation_final_v2.stl "
             "(right knee, rest pose)")
    plt, fig = _preview_figure()
    try:
        text = fit_title(fig, title)
        box = _drawn_box(fig, text)
    finally:
        plt.close(fig)
    assert box.x1 <= fig.bbox.width
    assert text.get_text().replace("\n", " ") == title and "\n" in text.get_text()
    plt, fig = _preview_figure()
    try:
        assert fit_title(fig, "knee.toml: femur.stl on tibia.stl").get_text() == \
            "knee.toml: femur.stl on tibia.stl"
    finally:
        plt.close(fig)


# ---------------------------------------------------------------------- run --plot
def _grid(x0, x1, y0, y1, n=24):
    xs, ys = np.linspace(x0, x1, n + 1), np.linspace(y0, y1, n + 1)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    points = np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)])
    idx = np.arange(X.size).reshape(n + 1, n + 1)
    a, b, c, d = (idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(),
                  idx[:-1, 1:].ravel())
    return points, np.vstack([np.column_stack([a, b, c]), np.column_stack([a, c, d])])


def _compartment(points, faces, pressure, p_max):
    return CompartmentResult(100.0, p_max, 1.0, 100.0, 0.5, 0.0, np.zeros(3),
                             int(np.count_nonzero(pressure)), pressure, points, faces)


def _knee(face_peak: float = 3.0, p_max: float = 3.2) -> RunResult:
    """Two scanned-like sheets reaching far below (posterior of) and beside their contact
    patches, as the lenhart2015 plateaus do: the strip under the contact frame is mesh."""
    out = {}
    for name, (x0, x1, cx) in {"medial": (-45.0, -8.0, -25.0),
                               "lateral": (8.0, 45.0, 25.0)}.items():
        pts, faces = _grid(x0, x1, -40.0, 12.0)
        centre = pts[faces].mean(axis=1)[:, :2]
        r = np.linalg.norm(centre - (cx, 2.0), axis=1)
        pressure = np.where(r < 7.0, face_peak * (1 - (r / 7.0) ** 2), 0.0)
        out[name] = _compartment(pts, faces, pressure, p_max)
    return RunResult("synthetic", "femur-tibia", "ef", True, 1, 0.0, POSE, out, {},
                     {"total": 0.0, "solve": 0.0})


def _display(renderer, points: np.ndarray) -> np.ndarray:
    """(n, 2) window pixel coordinates (origin bottom left) of world points, mm."""
    out = []
    for p in points:
        renderer.SetWorldPoint(*p, 1.0)
        renderer.WorldToDisplay()
        out.append(renderer.GetDisplayPoint()[:2])
    return np.array(out)


def _viewport_px(renderer, size) -> tuple[float, float, float, float]:
    x0, y0, x1, y1 = renderer.GetViewport()
    return x0 * size[0], y0 * size[1], x1 * size[0], y1 * size[1]


def test_the_scale_bar_lies_outside_the_drawn_mesh_at_the_maps_scale():
    import pyvista as pv

    from fecheck.io.plots import frame_bounds, pressure_map_figure, run_patches, scale_bar_length

    result = _knee()
    fig = pressure_map_figure(result)
    try:
        fig.plotter.render()
        size = fig.plotter.window_size
        map_r, strip = fig.maps[0], fig.scales[0]
        lines = [a for a in strip.actors.values() if isinstance(a, pv.Actor)]
        assert len(lines) == 1, "one bar in the strip under the map"
        b = lines[0].GetBounds()
        ends = np.array([[b[0], b[2], b[4]], [b[1], b[2], b[4]]])
        bar_px = _display(strip, ends)
        same_mm_on_map = _display(map_r, ends)
        # the mesh as drawn: every vertex's pixel, clipped to the map's viewport
        pts = np.vstack([c.slave_points for c in result.compartments.values()])
        mesh_px = _display(map_r, pts)
        vx0, vy0, vx1, vy1 = _viewport_px(map_r, size)
    finally:
        fig.plotter.close()
    x0, x1, _, _ = frame_bounds(run_patches(result))
    assert b[1] - b[0] == pytest.approx(scale_bar_length(x1 - x0))
    # the bar is as many pixels long as `length` mm of the map, and under the same x
    assert bar_px[:, 0] == pytest.approx(same_mm_on_map[:, 0], abs=1.0)
    # nowhere over the mesh as drawn: the bar (with its 5 px width) sits below the
    # lowest visible mesh pixel, which the map's viewport cuts
    lowest_mesh = max(float(mesh_px[:, 1].min()), vy0)
    assert bar_px[:, 1].max() + 3.0 < lowest_mesh
    assert vx0 <= bar_px[:, 0].min() and bar_px[:, 0].max() <= vx1


# ---------------------------------------------------------------------- validation maps
@pytest.fixture
def row_maps():
    from fecheck.studies.thesis import row_maps

    return row_maps


def _text_actors(plotter) -> str:
    texts = []
    for renderer in plotter.renderers:
        props = renderer.GetViewProps()
        props.InitTraversal()
        for _ in range(props.GetNumberOfItems()):
            prop = props.GetNextProp()
            if prop.IsA("vtkTextActor"):
                texts.append(prop.GetInput() or "")
            elif prop.IsA("vtkCornerAnnotation"):
                texts.extend(prop.GetText(i) or "" for i in range(8))
    return "\n".join(texts)


def test_the_validation_maps_colour_bar_tops_at_the_printed_p_max(row_maps):
    # face means peak at 5.89 MPa, the pointwise p_max is 6.1117 MPa (the scanned knee's
    # Fig. 5.18 numbers): the bar must read 6.11 at its top, as the panel prints it
    low, high = _knee(face_peak=5.89, p_max=6.1117), _knee(face_peak=4.0, p_max=4.5)
    plotter = row_maps.pressure_figure([low, high], (0.0, 8.0), "synthetic")
    try:
        bars = list(plotter.scalar_bars.values())
        texts = _text_actors(plotter)
    finally:
        plotter.close()
    assert len(bars) == 1
    lo, hi = bars[0].GetLookupTable().GetRange()
    assert (lo, hi) == pytest.approx((0.0, 6.1117), abs=1e-9)
    top_tick = bars[0].GetLabelFormat() % hi
    assert top_tick == "6.11" and "p_max 6.11 MPa" in texts and "p_max 4.50 MPa" in texts
