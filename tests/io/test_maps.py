"""Pressure maps, VTK surfaces, per-face CSV and output paths of `fecheck run` (and the
output paths of `fecheck fe`; its maps and VTK surfaces: test_fe_maps.py).

Maps are checked on their pixels: synthetic results (pressure only where we put it) are
rendered off-screen and the picture is read back.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from fecheck.cli import main
from fecheck.model.results import POSE_KEYS, CompartmentResult, RunResult
from fecheck.reference.closed_forms import column_stiffness

SCENES = Path(__file__).resolve().parents[2] / "validation" / "scenes"
AXES_CORNER = (0.14, 0.2)          # the orientation-axes viewport of a map, fractions
POSE = {k: 0.0 for k in POSE_KEYS}


# ---------------------------------------------------------------------- synthetic data
def grid(x0: float, x1: float, y0: float, y1: float, n: int = 20, z: float = 0.0):
    """A flat triangulated rectangle: points (mm) and faces (two triangles per cell)."""
    xs, ys = np.linspace(x0, x1, n + 1), np.linspace(y0, y1, n + 1)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    points = np.column_stack([X.ravel(), Y.ravel(), np.full(X.size, z)])
    idx = np.arange(X.size).reshape(n + 1, n + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), \
        idx[:-1, 1:].ravel()
    return points, np.vstack([np.column_stack([a, b, c]), np.column_stack([a, c, d])])


def compartment(points, faces, pressure, p_max=None) -> CompartmentResult:
    p_max = float(pressure.max()) if p_max is None else p_max
    return CompartmentResult(100.0, p_max, 1.0, 100.0, 0.5, 0.0, np.zeros(3),
                             int(np.count_nonzero(pressure)), pressure, points, faces)


def run_result(compartments) -> RunResult:
    return RunResult("synthetic", "sphere-plane", "ef", True, 1, 0.0, POSE, compartments,
                     {}, {"total": 0.0, "solve": 0.0})


def right_anterior_patch(value: float = 3.0, p_max: float | None = None) -> RunResult:
    """Medial plate at x < 0 without contact; lateral plate at x > 0 pressed only on its
    anterior half (y > 0), every pressed face at `value` MPa."""
    mp, mf = grid(-30, -10, -10, 10)
    lp, lf = grid(10, 30, -10, 10)
    hot = lp[lf].mean(axis=1)[:, 1] > 0
    return run_result({"medial": compartment(mp, mf, np.zeros(len(mf)), p_max),
                       "lateral": compartment(lp, lf, np.where(hot, value, 0.0), p_max)})


def map_pixels(fig) -> np.ndarray:
    """The map panel's pixels (rows top to bottom) with the orientation-axes corner
    blanked (its arrows are drawn in colours of their own), closing the figure."""
    img = np.asarray(fig.plotter.screenshot(return_img=True))[..., :3].astype(int)
    x0, y0, x1, y1 = fig.maps[0].GetViewport()
    h, w = img.shape[:2]
    crop = img[int(round((1 - y1) * h)):int(round((1 - y0) * h)),
               int(round(x0 * w)):int(round(x1 * w))].copy()
    fig.plotter.close()
    ch, cw = crop.shape[:2]
    crop[int(ch * (1 - AXES_CORNER[1])):, :int(cw * AXES_CORNER[0])] = 255
    return crop


def lut_index(pixels: np.ndarray, lut) -> tuple[np.ndarray, np.ndarray]:
    """Nearest colour-table entry of each pixel and its distance (0-255 units)."""
    n = lut.GetNumberOfTableValues()
    table = np.array([lut.GetTableValue(i)[:3] for i in range(n)]) * 255.0
    colours, inverse = np.unique(pixels.reshape(-1, 3), axis=0, return_inverse=True)
    d = np.linalg.norm(colours[:, None, :] - table[None], axis=-1)
    shape = pixels.shape[:2]
    return d.argmin(axis=1)[inverse].reshape(shape), d.min(axis=1)[inverse].reshape(shape)


def drawn_texts(plotter) -> str:
    """Every text actor's text in the figure's renderers (heading, titles), joined."""
    texts = []
    for renderer in plotter.renderers:
        props = renderer.GetViewProps()
        props.InitTraversal()
        for _ in range(props.GetNumberOfItems()):
            prop = props.GetNextProp()
            if prop.IsA("vtkTextActor") and prop.GetInput():
                texts.append(prop.GetInput())
    return "\n".join(texts)


# ---------------------------------------------------------------------- maps
def test_a_patch_at_plus_x_and_plus_y_is_drawn_right_and_up():
    from fecheck.io.plots import pressure_map_figure

    fig = pressure_map_figure(right_anterior_patch())
    lut = fig.bars[0].GetLookupTable()
    px = map_pixels(fig)
    index, dist = lut_index(px, lut)
    coloured = (dist < 4) & (index > 20)          # pressed faces (3 of 3 MPa: the top)
    zero = (dist < 4) & (index == 0)               # faces without pressure
    rows, cols = np.nonzero(coloured)
    h, w = coloured.shape
    assert len(cols) > 2000
    assert cols.min() > w / 2, "the +x patch must be on the right (seen from above)"
    lateral_zero_rows = np.nonzero(zero[:, w // 2:])[0]
    assert np.median(rows) < np.median(lateral_zero_rows) and rows.min() < h / 4, \
        "the +y (anterior) half must be above the posterior half, near the top"
    assert np.count_nonzero(zero[:, : w // 2]) > 2000, "the medial plate sits on the left"


def test_faces_are_unlit_and_take_the_colour_bar_colour():
    from fecheck.io.plots import pressure_map_figure

    fig = pressure_map_figure(right_anterior_patch(value=2.0, p_max=4.0))
    lut = fig.bars[0].GetLookupTable()
    rgb = [0.0, 0.0, 0.0]
    lut.GetColor(2.0, rgb)
    expected = np.array(rgb) * 255.0
    px = map_pixels(fig)
    match = np.all(np.abs(px - expected) <= 1.5, axis=-1)
    assert np.count_nonzero(match) > 2000, "pressed faces must show exactly the bar's colour"


def test_the_colour_bar_runs_to_the_printed_p_max():
    import pyvista as pv

    from fecheck.io.plots import pressure_map_figure

    result = right_anterior_patch(value=5.89, p_max=6.1117)     # face means peak below
    printed = max((tok for line in result.table().splitlines()
                   if line.startswith("max pressure MPa") for tok in line.split()[3:]),
                  key=float)
    fig = pressure_map_figure(result)
    bar = fig.bars[0]
    assert bar.GetLookupTable().GetRange() == pytest.approx((0.0, float(printed)), abs=1e-3)
    coloured = [a.mapper for r in fig.maps for a in r.actors.values()
                if isinstance(a, pv.Actor) and a.mapper.GetScalarVisibility()]
    assert len(coloured) == 2                                      # medial and lateral
    assert all(m.scalar_range == pytest.approx((0.0, 6.1117)) for m in coloured)
    assert bar.GetLabelFormat() % 6.1117 == printed                 # the top tick
    texts = drawn_texts(fig.plotter)
    fig.plotter.close()
    assert f"p_max = {printed} MPa" in texts and "mean pressure" in texts
    labels = "\n".join(fig.texts)                           # point labels included
    for word in ("medial", "lateral", "10 mm"):
        assert word in labels


def test_frame_holds_every_contact_patch_with_a_margin():
    from fecheck.io.plots import Patch, frame_bounds, scale_bar_length

    pts, faces = grid(-50, 50, -40, 40, n=40)            # a big (scanned-like) sheet
    hot = np.linalg.norm(pts[faces].mean(axis=1)[:, :2] - (20, 5), axis=1) < 8
    x0, x1, y0, y1 = frame_bounds([Patch("lateral", pts, faces, hot * 1.0, ((hot, "k"),))])
    assert x0 < 12 - 3 and x1 > 28 + 3 and y0 < -3 - 3 and y1 > 13 + 3
    assert x1 - x0 < 40 and y1 - y0 < 40                      # zoomed to the contact
    assert scale_bar_length(x1 - x0) in (2.0, 5.0)


# ---------------------------------------------------------------------- VTK and faces CSV
def test_vtu_pressure_times_area_is_the_compartment_force(tmp_path, capsys):
    import meshio

    out = tmp_path / "new" / "r.json"
    assert main(["run", "--vtk", str(tmp_path / "vtk"), "--json", str(out),
                 "--faces-csv", str(tmp_path / "faces.csv"),
                 "--plot", str(tmp_path / "plot")]) == 0
    assert "note:" not in capsys.readouterr().out
    data = json.loads(out.read_text())
    k = column_stiffness(20.0, 0.3, 6.0)
    for name, force in (("medial", 324.2), ("lateral", 456.2)):
        mesh = meshio.read(tmp_path / "vtk" / f"{name}.vtu")
        cells = {key: v[0] for key, v in mesh.cell_data.items()}
        total = float(np.sum(cells["pressure_MPa"] * cells["contact_area_mm2"]))
        f = data["compartments"][name]["force_N"]
        assert f == pytest.approx(force, abs=0.1)
        assert total == pytest.approx(f, rel=1e-3)
        assert cells["pressure_MPa"] == pytest.approx(k * cells["depth_mm"], abs=1e-9)
    with open(tmp_path / "faces.csv") as fh:
        rows = list(csv.DictReader(fh))
    medial = [r for r in rows if r["compartment"] == "medial"]
    assert sum(float(r["pressure_MPa"]) * float(r["contact_area_mm2"]) for r in medial) \
        == pytest.approx(data["compartments"]["medial"]["force_N"], rel=1e-3)
    assert (tmp_path / "plot" / "pressure_map.png").read_bytes()[:4] == b"\x89PNG"


def test_without_per_face_areas_the_estimate_is_flagged():
    # a point contact (the closed-form Hertz pair) has face pressures but no clipped areas
    from dataclasses import replace

    from fecheck.io.vtk import face_fields, field_notes, triangle_areas

    result = right_anterior_patch()
    comp = replace(result.compartments["lateral"], face_area_mm2=None, face_depth_mm=None)
    result = replace(result, compartments={**result.compartments, "lateral": comp})
    fields = face_fields(comp)
    whole = triangle_areas(comp.slave_points, comp.slave_faces)
    assert fields["contact_area_mm2"] == pytest.approx(np.where(comp.face_pressure_MPa > 0,
                                                                whole, 0.0))
    assert "depth_mm" not in fields and field_notes(result)


# ---------------------------------------------------------------------- output paths
@pytest.fixture
def no_solve(monkeypatch):
    """Fail the test if a solve starts."""
    def boom(*args, **kwargs):
        raise AssertionError("the solve started before the output paths were checked")

    monkeypatch.setattr("fecheck.model.run.run_scene", boom)
    monkeypatch.setattr("fecheck.fe.knee.crosscheck.cross_check", boom)


@pytest.mark.parametrize("verb", ["run", "fe"])
@pytest.mark.parametrize("option", ["--json", "--plot", "--vtk"])
def test_an_unwritable_output_stops_before_the_solve(verb, option, no_solve, capsys):
    assert main([verb, option, "/proc/x.json"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("fecheck: error:") and "\n" not in err and "/proc/x.json" in err


@pytest.fixture
def synthetic_run(monkeypatch):
    result = right_anterior_patch()
    monkeypatch.setattr("fecheck.model.run.run_scene", lambda scene: result)
    return result


@pytest.mark.parametrize("option", ["--json", "--csv", "--faces-csv"])
def test_dash_writes_to_stdout_and_the_table_to_stderr(option, synthetic_run, tmp_path,
                                                        monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["run", option, "-"]) == 0
    captured = capsys.readouterr()
    assert not (tmp_path / "-").exists()
    assert "max pressure MPa" in captured.err and "max pressure MPa" not in captured.out
    if option == "--json":
        assert json.loads(captured.out)["compartments"]["lateral"]["max_pressure_MPa"] == 3.0
    else:
        rows = list(csv.DictReader(captured.out.splitlines()))
        assert rows and ("compartment" in rows[0]) == (option == "--faces-csv")


def test_a_missing_parent_folder_is_created(synthetic_run, tmp_path):
    out = tmp_path / "a" / "b" / "r.json"
    assert main(["run", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["scene"] == "synthetic"


def test_two_outputs_cannot_share_stdout(no_solve, capsys):
    assert main(["run", "--json", "-", "--csv", "-"]) == 2
    assert "standard output" in capsys.readouterr().err


def test_the_rigid_model_writes_no_pressure_map(tmp_path, capsys):
    assert main(["run", str(SCENES / "rigid.toml"), "--plot", str(tmp_path / "p"),
                 "--vtk", str(tmp_path / "v")]) == 0
    out = capsys.readouterr().out
    assert "rigid model has no pressure map" in out and "--plot, --vtk" in out
    assert not (tmp_path / "p").exists() and not (tmp_path / "v").exists()
