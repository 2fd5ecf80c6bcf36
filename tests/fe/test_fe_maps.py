"""Pressure maps, VTK surfaces and the table of `fecheck fe`, on a synthetic cross-check.

Two flat square tibial surfaces (medial at x < 0, lateral at x > 0, tibia frame) carry
made-up FE and EF face pressures: a narrow high FE cap and a wide low EF cap, so FE − EF
has both signs. The maps are rendered off-screen and their pixels read back.
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from test_maps import lut_index

from fecheck.cli import main
from fecheck.fe.bodies.indenter import SphereIndenter
from fecheck.fe.bodies.scene_bodies import FEBody
from fecheck.fe.bodies.settings import FESettings
from fecheck.fe.knee.crosscheck import CompartmentCheck, CrossCheck
from fecheck.fe.pressure.results import SideMetrics
from fecheck.fe.solve.press import FELayer
from fecheck.model.results import Pose
from geometry.mesh import TriMesh

CENTRES = {"medial": (-20.0, 2.0, -8.0), "lateral": (20.0, 2.0, -6.0)}
"""Centre of each compartment's FE pressure cap (and of its square surface), mm."""
EF_SHIFT = np.array([0.3, 0.2, 0.0])        # the EF cap's centre from the FE one, mm
POSE = Pose.of(np.zeros(5))


# ---------------------------------------------------------------------- synthetic data
def square(centre, half: float = 12.0, n: int = 24) -> TriMesh:
    """A flat triangulated square of side 2·half around `centre` (mm), normals +z."""
    s = np.linspace(-half, half, n + 1)
    X, Y = np.meshgrid(centre[0] + s, centre[1] + s, indexing="ij")
    points = np.column_stack([X.ravel(), Y.ravel(), np.full(X.size, centre[2])])
    idx = np.arange(X.size).reshape(n + 1, n + 1)
    a, b, c, d = (idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(),
                  idx[:-1, 1:].ravel())
    return TriMesh(points, np.vstack([np.column_stack([a, b, c]), np.column_stack([a, c, d])]))


def cap(points: np.ndarray, centre, p0: float, radius: float) -> np.ndarray:
    """p0·sqrt(1 − r²/R²) (0 outside), r the in-plane distance from `centre`, MPa."""
    r2 = np.sum((points[:, :2] - np.asarray(centre)[:2]) ** 2, axis=1)
    return p0 * np.sqrt(np.clip(1.0 - r2 / radius**2, 0.0, None))


def metrics(p_max: float, centre, resolved: bool = True) -> SideMetrics:
    """300 N along +z over 50 mm²; no mean pressure nor centre without `resolved`."""
    cop = np.asarray(centre, dtype=float) if resolved else None
    return SideMetrics(np.array([0.0, 0.0, 300.0]), 300.0, p_max,
                       6.0 if resolved else math.nan, 50.0, 0.2, cop)


def compartment(name: str, ef: bool = True, resolved: bool = True) -> CompartmentCheck:
    """One synthetic compartment: FE cap 5 MPa over R 4 mm, EF cap 3.5 MPa over R 6 mm
    (shifted by `EF_SHIFT`); no EF face pressure without `ef`."""
    centre = np.array(CENTRES[name])
    surface = square(centre)
    centroids = surface.points[surface.faces].mean(axis=1)
    fe_points = cap(surface.points, centre, 5.0, 4.0)
    body = FEBody(name, surface, np.full(surface.n_points, 2.0),
                  SphereIndenter(centre + (0.0, 0.0, 30.0), 30.0), "plane",
                  "sphere R 30.00 mm", "uniform")
    layer = FELayer(body, surface, np.arange(surface.n_faces), None, 0)
    return CompartmentCheck(
        name, metrics(5.0, centre, resolved), metrics(3.5, centre + EF_SHIFT), layer,
        fe_points, fe_points.copy(), fe_points > 0, cap(centroids, centre, 5.0, 4.0),
        cap(centroids, centre + EF_SHIFT, 3.5, 6.0) if ef else None, 0.0)


def synthetic_check(ef: bool = True, resolved: bool = True) -> CrossCheck:
    """Both compartments; the lateral one without a centre of pressure or mean pressure
    unless `resolved`."""
    comps = {"medial": compartment("medial", ef),
             "lateral": compartment("lateral", ef, resolved)}
    geometry = {"tibial_surface": "plane", "femoral_surface": "sphere R 30.00 mm",
                "thickness_source": "uniform", "deformable_layers": 1, "elements": 10,
                "nodes": 20, "dofs": 60, "smallest_size_mm": 1.0, "element": "tet P2"}
    timing = {"ef_equilibrium": 0.1, "fe_build": 1.0, "fe_condense": 0.5, "fe_contact": 0.1,
              "references": 0.0, "total": 1.7, "fe": 1.6, "ef_over_fe": 0.1 / 1.6}
    material = {"E_MPa": 20.0, "nu": 0.3, "thickness_mm": 2.0, "ef_k_N_per_mm3": 1.0}
    return CrossCheck(comps, FESettings(), material, {"fe": POSE, "ef": POSE}, geometry,
                      timing)


# ---------------------------------------------------------------------- pixels
def crop(img: np.ndarray, renderer) -> np.ndarray:
    """The pixels of one renderer's viewport."""
    x0, y0, x1, y1 = renderer.GetViewport()
    h, w = img.shape[:2]
    return img[int(round((1 - y1) * h)):int(round((1 - y0) * h)),
               int(round(x0 * w)):int(round(x1 * w))]


def world_pixel(renderer, point, height: int) -> tuple[int, int]:
    """(row, column) of the window pixel where `point` (world, mm) is drawn."""
    import vtk

    coord = vtk.vtkCoordinate()
    coord.SetCoordinateSystemToWorld()
    coord.SetValue(*map(float, point))
    x, y = coord.GetComputedDisplayValue(renderer)
    return height - 1 - y, x


def scalar_ranges(renderer) -> list[tuple[float, float]]:
    """The scalar range of every actor coloured by its values in `renderer`."""
    import pyvista as pv

    return [tuple(a.mapper.scalar_range) for a in renderer.actors.values()
            if isinstance(a, pv.Actor) and a.mapper.GetScalarVisibility()]


# ---------------------------------------------------------------------- the map
def mark_pixels(fig, check, height: int) -> list[tuple[tuple[int, int], tuple[int, int]]]:
    """Per map and compartment, the pixels of a point on the FE + (along +y) and on the
    EF × (along its +x+y arm), 0.7 of an arm from the centre."""
    from fecheck.io.fe_plots import MARK_MM

    out = []
    for renderer in fig.maps:
        for comp in check.compartments.values():
            fe, ef = comp.fe.center_of_pressure_mm, comp.ef_model.center_of_pressure_mm
            out.append((world_pixel(renderer, fe + (0.0, 0.7 * MARK_MM, 0.0), height),
                        world_pixel(renderer, ef + 0.7 * MARK_MM * np.array([0.7071, 0.7071,
                                                                               0.0]), height)))
    return out


@pytest.fixture(scope="module")
def drawn():
    """The synthetic check, its figure, the scalar ranges of each map, the colour bars'
    lookup tables, the pixels and the `mark_pixels`."""
    from fecheck.io.fe_plots import pressure_map_figure

    check = synthetic_check()
    fig = pressure_map_figure(check, "synthetic")
    ranges = [scalar_ranges(r) for r in fig.maps]
    luts = [bar.GetLookupTable() for bar in fig.bars]
    img = np.asarray(fig.plotter.screenshot(return_img=True))[..., :3].astype(int)
    marks = mark_pixels(fig, check, img.shape[0])
    fig.plotter.close()
    return check, fig, ranges, luts, img, marks


def test_ef_and_fe_share_one_scale_and_the_difference_is_symmetric(drawn):
    check, fig, ranges, luts, *_ = drawn
    comps = check.compartments.values()
    top = max(max(c.fe_face_pressure_MPa.max(), c.ef_face_pressure_MPa.max()) for c in comps)
    span = max(np.abs(c.fe_face_pressure_MPa - c.ef_face_pressure_MPa).max() for c in comps)
    assert len(fig.maps) == 3 and len(fig.bars) == 2
    assert ranges[0] == ranges[1] == [pytest.approx((0.0, top))] * 2   # EF, FE: both knees
    assert ranges[2] == [pytest.approx((-span, span))] * 2
    assert luts[0].GetRange() == pytest.approx((0.0, top))
    assert luts[1].GetRange() == pytest.approx((-span, span))
    texts = "\n".join(fig.texts)
    for word in ("synthetic", "fe.mode = joint", "pressure\n(MPa)", "FE - EF\n(MPa)",
                 "medial", "lateral", "CoP FE to EF 0.36 mm", "EF pressure", "FE pressure"):
        assert word in texts


def test_both_compartments_are_drawn_where_they_are(drawn):
    _, fig, _, luts, img, _ = drawn
    for renderer in fig.maps[:2]:                           # EF and FE maps
        index, dist = lut_index(crop(img, renderer), luts[0])
        hot = (dist < 4) & (index > 128)                    # upper half of the scale
        w = hot.shape[1]
        assert np.count_nonzero(hot[:, : w // 2]) > 300, "medial (x < 0) on the left"
        assert np.count_nonzero(hot[:, w // 2:]) > 300, "lateral (x > 0) on the right"


def test_the_difference_map_shows_both_signs(drawn):
    _, fig, _, luts, img, _ = drawn
    index, dist = lut_index(crop(img, fig.maps[2]), luts[1])
    assert np.count_nonzero((dist < 4) & (index > 170)) > 300      # FE above EF (centre)
    assert np.count_nonzero((dist < 4) & (index < 85)) > 300       # EF above FE (rim)


def test_centres_of_pressure_are_marked_at_their_place(drawn):
    *_, img, marks = drawn
    assert len(marks) == 3 * 2
    for arm, diagonal in marks:
        assert np.all(img[arm] < 40), "the FE + is black"
        assert np.abs(img[diagonal] - (255, 0, 255)).max() < 40, "the EF x is magenta"


def test_the_png_has_the_figure_size_and_the_map_colours(tmp_path):
    from PIL import Image

    from fecheck.io.fe_plots import MAP_FILE, pressure_map_figure, write_fe_plots

    check = synthetic_check()
    fig = pressure_map_figure(check, "synthetic")
    size = tuple(fig.plotter.window_size)
    top_colour = np.array(fig.bars[0].GetLookupTable().GetTableValue(255)[:3]) * 255
    fig.plotter.close()
    assert write_fe_plots(check, tmp_path / "p", "synthetic") == [tmp_path / "p" / MAP_FILE]
    png = np.asarray(Image.open(tmp_path / "p" / MAP_FILE).convert("RGB")).astype(int)
    assert (png.shape[1], png.shape[0]) == size and size[0] == 1400
    near_top = np.linalg.norm(png - top_colour, axis=-1) < 30      # yellow of the cap tops
    assert np.count_nonzero(near_top) > 50
    assert np.count_nonzero(np.ptp(png, axis=-1) > 60) > 20000      # plenty of colour


def test_without_ef_face_pressures_only_the_fe_map_is_drawn(tmp_path):
    from PIL import Image

    from fecheck.io.fe_plots import MAP_FILE, pressure_map_figure, write_fe_plots

    check = synthetic_check(ef=False)
    fig = pressure_map_figure(check, "synthetic")
    texts, ranges = fig.texts, scalar_ranges(fig.maps[0])
    assert len(fig.maps) == 1 and len(fig.bars) == 1
    fig.plotter.close()
    assert any(t.startswith("FE pressure") and "no EF map" in t for t in texts)
    top = max(c.fe_face_pressure_MPa.max() for c in check.compartments.values())
    assert ranges == [pytest.approx((0.0, top))] * 2
    write_fe_plots(check, tmp_path, "synthetic")
    one = Image.open(tmp_path / MAP_FILE).size
    write_fe_plots(synthetic_check(), tmp_path / "three", "synthetic")
    three = Image.open(tmp_path / "three" / MAP_FILE).size
    assert one[0] == three[0] and 2.5 * one[1] < three[1]


def test_mark_arms_cross_at_the_centre():
    from fecheck.io.fe_plots import MARK_MM, mark_points

    centre = np.array([1.0, 2.0, 3.0])
    for cross in (False, True):
        ends = mark_points(centre, cross)
        arms = ends[[1, 3]] - ends[[0, 2]]
        assert (ends[[0, 2]] + ends[[1, 3]]) / 2 == pytest.approx(np.array([centre] * 2))
        assert np.linalg.norm(arms, axis=1) == pytest.approx([2 * MARK_MM] * 2)
        assert np.dot(*arms) == pytest.approx(0.0)
        assert np.abs(arms[:, 0]).min() == pytest.approx(0.0 if not cross else 2 ** 0.5 * MARK_MM)


# ---------------------------------------------------------------------- VTK
@pytest.mark.parametrize("ef", [True, False])
def test_vtu_holds_the_fe_and_ef_face_pressures(tmp_path, ef):
    import meshio

    from fecheck.io.vtk import write_fe_vtk

    check = synthetic_check(ef=ef)
    paths = write_fe_vtk(check, tmp_path)
    assert paths == [tmp_path / "medial.vtu", tmp_path / "lateral.vtu"]
    for name, comp in check.compartments.items():
        mesh = meshio.read(tmp_path / f"{name}.vtu")
        cells = {k: v[0] for k, v in mesh.cell_data.items()}
        surface = comp.layer.body.surface
        assert mesh.cells[0].data.shape == (surface.n_faces, 3)
        assert mesh.points == pytest.approx(surface.points)          # tibia frame, in place
        assert cells["fe_pressure_MPa"] == pytest.approx(comp.fe_face_pressure_MPa)
        if not ef:
            assert set(cells) == {"fe_pressure_MPa"}
            continue
        assert cells["ef_pressure_MPa"] == pytest.approx(comp.ef_face_pressure_MPa)
        assert cells["difference_MPa"] == pytest.approx(comp.fe_face_pressure_MPa
                                                        - comp.ef_face_pressure_MPa)
        assert cells["difference_MPa"].min() < -1 and cells["difference_MPa"].max() > 1


# ---------------------------------------------------------------------- fecheck fe
@pytest.fixture
def synthetic_fe(monkeypatch):
    """`fecheck fe` answers with the synthetic check (lateral: no centre of pressure,
    mean pressure undefined) without solving."""
    check = synthetic_check(resolved=False)
    monkeypatch.setattr("fecheck.fe.knee.crosscheck.cross_check", lambda scene, **kw: check)
    return check


def test_fe_json_dash_vtk_plot_and_a_table_without_bare_nan(synthetic_fe, tmp_path, capsys):
    import meshio

    assert main(["fe", "--json", "-", "--vtk", str(tmp_path / "v"),
                 "--plot", str(tmp_path / "p")]) == 0
    captured = capsys.readouterr()
    data = json.loads(captured.out)
    assert data["compartments"]["medial"]["fe"]["max_pressure_MPa"] == 5.0
    report = captured.err
    assert "nan" not in report.lower().replace("n/a", "")
    assert "n/a(" in report and "FE gives no p_mean" in report
    assert "no FE axisymmetric (FE load) row: the axisymmetric FE runs only" in report
    assert "lateral n/a (point contact)" in report
    for name, comp in synthetic_fe.compartments.items():
        mesh = meshio.read(tmp_path / "v" / f"{name}.vtu")
        assert mesh.cell_data["fe_pressure_MPa"][0] == pytest.approx(comp.fe_face_pressure_MPa)
        assert f"wrote {tmp_path / 'v' / f'{name}.vtu'}" in report
    assert (tmp_path / "p" / "fe_pressure_map.png").read_bytes()[:4] == b"\x89PNG"


def test_fe_table_columns_fit_any_value(synthetic_fe):
    from fecheck.cli.fe import comparison_table

    big = SideMetrics(np.array([0.0, 0.0, 324.0]), 324.0, 27921.835, 25224.272, 0.0128,
                      0.00015, None)
    medial = synthetic_fe.compartments["medial"]
    synthetic_fe.compartments["medial"] = dataclasses.replace(medial, ef_model=big)
    lines = comparison_table(synthetic_fe).splitlines()
    row = next(line for line in lines if line.startswith("EF model"))
    assert row.split()[2:8] == ["324.0", "324.0", "27921.835", "25224.272", "0.0128",
                                "0.00015"]
    units = next(i for i, line in enumerate(lines) if line.startswith("units:"))
    table = lines[1:units]                            # column heads and the rows
    assert len({len(line) for line in table}) == 1, "every column right-aligned"
    ends = [i for i, ch in enumerate(table[0]) if ch != " " and
            (i + 1 == len(table[0]) or table[0][i + 1] == " ")]
    for line in table[1:]:
        assert all(line[i] != " " and (i + 1 == len(line) or line[i + 1] == " ")
                   for i in ends), line
