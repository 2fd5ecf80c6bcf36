"""Inputs as real data brings them: a bone with a non-manifold edge, swapped files, an implant
sheet whose rim overhangs its solid, a closed solid in the FE.

The knee is `test_knee_import`'s synthetic knee (femoral caps over tibial dishes at z ≈ 0,
a right knee) with two closed bones of 1-3 mm triangles: the tibial one a flat ellipsoid
3 mm under the dishes' lowest points, the femoral one a sphere 3 mm inside each cap. Units
mm.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from test_knee_import import CENTRES, GAPS_MM, _merge, femur_cap, tibia_patch, write

from fecheck.cli import main
from fecheck.model.scanned import slave_thickness, tibial_slaves
from fecheck.scene import load_scene
from fecheck.scene.document import toml_value
from geometry.checks import non_manifold_faces
from geometry.icosphere import icosphere
from geometry.mesh import TriMesh

TIBIA_BONE_TOP_MM = -3.0


def _ellipsoid(centre, axes) -> TriMesh:
    """A closed ellipsoid of semi-axes `axes` (mm) about `centre`, outward normals."""
    unit = icosphere(1.0, 4)
    return TriMesh(unit.points * np.asarray(axes) + np.asarray(centre), unit.faces)


def tibia_bone() -> TriMesh:
    """Proximal tibia: a flat ellipsoid whose top lies 3 mm under the dishes' lowest points
    (x = ±20 mm) and whose bottom lies 60 mm lower."""
    axes = np.array([70.0, 35.0, 30.0])
    top = axes[2] * np.sqrt(1.0 - (20.0 / axes[0]) ** 2)
    return _ellipsoid((0.0, 0.5, TIBIA_BONE_TOP_MM - top), axes)


def femur_bone() -> TriMesh:
    """Distal femur: a sphere 3 mm inside each condyle cap (the caps' spheres, R 20 mm)."""
    spheres = [icosphere(17.0, 4, (*CENTRES[c], 20.0 + GAPS_MM[c])) for c in CENTRES]
    return _merge(spheres)


def with_fin(bone: TriMesh, near) -> tuple[TriMesh, np.ndarray]:
    """`bone` with one extra face standing on its edge nearest `near` (mm): that edge is
    then shared by three faces; the edge's midpoint."""
    edges = bone.edges_unique
    mid = bone.points[edges].mean(axis=1)
    a, b = edges[int(np.argmin(np.linalg.norm(mid - np.asarray(near), axis=1)))]
    tip = 0.5 * (bone.points[a] + bone.points[b]) + [0.0, 0.0, -1.0]     # into the bone
    points = np.vstack([bone.points, tip])
    out = TriMesh(points, np.vstack([bone.faces, [a, b, len(points) - 1]]))
    assert len(non_manifold_faces(out)) == 3
    return out, 0.5 * (bone.points[a] + bone.points[b])


@pytest.fixture
def knee(tmp_path) -> dict[str, str]:
    """The synthetic knee's femoral and tibial sheets (one file each), mm."""
    data = tmp_path / "data"
    return {"femur": write(data, "femur.stl", _merge([femur_cap(c) for c in CENTRES])),
            "tibia": write(data, "tibia.stl", _merge([tibia_patch(c) for c in CENTRES]))}


def _import(knee_files, out: Path, femur_bone_file: str, tibia_bone_file: str) -> int:
    return main(["knee", "import", "--femur", knee_files["femur"], "--tibia", knee_files["tibia"],
                 "--femur-bone", femur_bone_file, "--tibia-bone", tibia_bone_file,
                 "-o", str(out)])


def _one_line_error(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    errors = [e for e in err if e.startswith("fecheck: error:")]
    assert len(errors) == 1, err
    return errors[0]


# ------------------------------------------------------------------ a bone's defect
def test_a_bone_defect_far_below_the_plateau_warns_with_its_place_and_runs(knee, tmp_path,
                                                                           capsys):
    bone, at = with_fin(tibia_bone(), (0.0, 27.0, -12.0))     # 12 mm below, on its front
    data = tmp_path / "data"
    femur_file = write(data, "femur_bone.stl", femur_bone())
    out = tmp_path / "knee.toml"
    assert _import(knee, out, femur_file, write(data, "tibia_bone.stl", bone)) == 0
    captured = capsys.readouterr()
    warned = [w for w in captured.err.splitlines() if "non-manifold" in w]
    assert len(warned) == 1 and "tibia_bone.stl" in warned[0], captured.err
    x, y, z = (float(v) for v in warned[0].split("around (")[1].split(")")[0].split(", "))
    assert np.allclose((x, y, z), at, atol=1.5)
    assert "tibia-bone    thickness" in captured.out, captured.out
    # the thickness maps are the clean bone's: the fin is on the front wall, under no ray
    clean = tmp_path / "clean.toml"
    assert _import(knee, clean, femur_file, write(data, "clean.stl", tibia_bone())) == 0
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        maps = [[slave_thickness(s, m) for m in tibial_slaves(s).values()]
                for s in (load_scene(out), load_scene(clean))]
    assert any("geometry.tibia_bone (tibia_bone.stl)" in str(w.message) for w in seen)
    for a, b in zip(*maps, strict=True):
        assert np.array_equal(a, b) and 3.0 < np.median(a) < 9.0


def test_a_bone_defect_under_the_sheet_is_refused_with_its_place(knee, tmp_path, capsys):
    # the edge of the tibial bone's top right under the medial dish's middle
    bone, at = with_fin(tibia_bone(), (-20.0, 0.0, TIBIA_BONE_TOP_MM))
    data = tmp_path / "data"
    out = tmp_path / "knee.toml"
    assert _import(knee, out, write(data, "femur_bone.stl", femur_bone()),
                   write(data, "tibia_bone.stl", bone)) == 2
    err = _one_line_error(capsys)
    assert "--tibia-bone" in err and "tibia_bone.stl" in err and "non-manifold" in err
    assert "Non Manifold" in err and not out.exists()
    x, y, z = (float(v) for v in err.split("around (")[1].split(")")[0].split(", "))
    assert np.allclose((x, y, z), at, atol=1.5)
    # a run reads the bone the same way: refused, with the scene's key
    femur_file = write(data, "femur_bone.stl", femur_bone())
    assert _import(knee, out, femur_file, write(data, "clean.stl", tibia_bone())) == 0
    capsys.readouterr()
    bad = str(data / "tibia_bone.stl")
    assert main(["run", str(out), "--set", f"geometry.tibia_bone={toml_value(bad)}"]) == 2
    err = _one_line_error(capsys)
    assert err.startswith("fecheck: error: geometry.tibia_bone: the thickness rays")
    assert "non-manifold" in err


# ------------------------------------------------------------------ swapped files
def test_swapped_bone_files_are_refused_with_the_swap_to_make(knee, tmp_path, capsys):
    data = tmp_path / "data"
    femur_file = write(data, "femur_bone.stl", femur_bone())
    tibia_file = write(data, "tibia_bone.stl", tibia_bone())
    out = tmp_path / "knee.toml"
    assert _import(knee, out, tibia_file, femur_file) == 2
    err = _one_line_error(capsys)
    assert "look swapped" in err and not out.exists()
    assert f"give --femur-bone {femur_file} --tibia-bone {tibia_file}" in err
    assert _import(knee, out, femur_file, tibia_file) == 0


def test_a_bone_on_the_wrong_side_of_its_sheet_is_refused(knee, tmp_path, capsys):
    # both bones under the tibia: the femoral one is on the near side of its sheet
    data = tmp_path / "data"
    tibia_file = write(data, "tibia_bone.stl", tibia_bone())
    assert _import(knee, tmp_path / "k.toml", tibia_file, tibia_file) == 2
    err = _one_line_error(capsys)
    assert "--femur-bone" in err and "below the femoral sheet" in err
    assert "far side of its cartilage" in err and "--tibia-bone " not in err


def test_swapped_sheet_files_say_they_look_swapped(knee, tmp_path, capsys):
    out = tmp_path / "knee.toml"
    assert main(["knee", "import", "--femur", knee["tibia"], "--tibia", knee["femur"],
                 "-o", str(out)]) == 2
    err = _one_line_error(capsys)
    assert "look swapped" in err and "overlaps" not in err and not out.exists()
    assert f"give --femur {knee['femur']} --tibia {knee['tibia']}" in err


def test_the_preview_draws_each_bone_in_its_own_colour_with_a_legend():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import to_rgba

    from fecheck.io.knee_preview import _section_panel

    fig, ax = plt.subplots()
    tibia = {c: tibia_patch(c) for c in CENTRES}
    femur = _merge([femur_cap(c) for c in CENTRES])
    _section_panel(ax, "frontal", 1, 0.5, femur, tibia,
                   {"femur": femur_bone(), "tibia": tibia_bone()})
    legend = {t.get_text(): to_rgba(h.get_color()) for t, h in
              zip(ax.get_legend().get_texts(), ax.get_legend().legend_handles, strict=True)}
    plt.close(fig)
    assert legend["femoral bone"] != legend["tibial bone"]
    colours = set(legend.values())
    assert len(colours) == 4 and to_rgba("0.6") not in colours


# ------------------------------------------------------------------ what the FE meets
def test_the_import_says_what_the_fe_does_with_a_sheet_that_inverts(tmp_path, capsys):
    """A curled rim inverts the layer as read: the import says the FE meshes a prepared
    copy (fe.prepare 'auto'), and the FE does; with fe.prepare 'off' it warns that the FE
    will refuse the sheet, and the FE does."""
    from test_knee_import import _curled

    from fecheck.errors import FecheckError
    from fecheck.fe.bodies.scene_bodies import scene_bodies
    from fecheck.fe.bodies.settings import FESettings
    from fecheck.fe.solve.press import _sheet
    from fecheck.studies.knee_import import _inversion

    data = tmp_path / "data"
    femur = write(data, "femur.stl", _merge([femur_cap(c) for c in CENTRES]))
    tibia = write(data, "both_curled.stl", _merge([_curled(c) for c in CENTRES]))
    out = tmp_path / "knee.toml"
    assert main(["knee", "import", "--femur", femur, "--tibia", tibia, "-o", str(out)]) == 0
    captured = capsys.readouterr()
    assert "will refuse" not in captured.err and "will fail" not in captured.err
    assert captured.out.count("mesh a prepared copy of the sheet instead") == 2
    scene = load_scene(out)
    bodies = scene_bodies(scene)
    auto, off = FESettings.from_scene(scene), FESettings.from_scene(scene, prepare="off")
    levels = auto.levels(scene["contact.poisson"])
    for body in bodies:
        sheet, prepared, _, _ = _sheet(body, auto, levels, lambda s: None)
        assert prepared is not None and sheet.surface.n_faces < body.surface.n_faces
        warned, note = _inversion(body, levels, off, scene)
        assert note == "" and "will refuse it" in warned and "fe.prepare = 'off'" in warned
        with pytest.raises(FecheckError, match="cannot be extruded"):
            _sheet(body, off, levels, lambda s: None)


# ------------------------------------------------------------------ an implant's rim
def _implant_with_rim(folder: Path, overhang_mm: float) -> tuple[Path, np.ndarray]:
    """The generated implant (`geometry.synthetic.implant`, 2 mm triangles) whose insert
    sheet's border vertices are moved `overhang_mm` out past the solid's walls (in x and
    y, the rim is flat there); the scene and the moved vertices' (x, y, z), mm."""
    from geometry.io import load_mesh, save_mesh
    from geometry.synthetic.implant import HALF_DEPTH_MM, HALF_WIDTH_MM, write_implant

    scene = write_implant(folder, fine_mm=2.0)
    sheet = load_mesh(folder / "insert_top.stl")
    p = sheet.points.copy()
    for axis, half in ((0, HALF_WIDTH_MM), (1, HALF_DEPTH_MM)):
        edge = np.isclose(np.abs(p[:, axis]), half)
        p[edge, axis] += overhang_mm * np.sign(p[edge, axis])
    moved = ~np.isclose(p, sheet.points).all(axis=1)
    save_mesh(TriMesh(p, sheet.faces), folder / "insert_top.stl")
    return scene, p[moved]


def test_an_insert_rim_overhanging_its_solid_by_0_2_mm_is_tolerated(tmp_path):
    from fecheck.fe.bodies.scene_bodies import scene_bodies
    from fecheck.fe.bodies.volume import RIM_OVERHANG_MM

    clean = {b.name: b.thickness_mm for b in
             scene_bodies(load_scene(_implant_with_rim(tmp_path / "clean", 0.0)[0]))}
    scene, rim = _implant_with_rim(tmp_path / "rim", 0.2)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        bodies = scene_bodies(load_scene(scene))
    said = [str(w.message) for w in seen if "overhang the solid" in str(w.message)]
    assert len(said) == 2                                    # medial and lateral
    for body, text in zip(bodies, said, strict=True):
        assert f"the {body.name} sheet" in text
        on_rim = np.isin(body.surface.faces, np.flatnonzero(
            (np.abs(body.surface.points[:, None, :2] - rim[None, :, :2]) < 1e-6)
            .all(axis=2).any(axis=1))).any(axis=1)
        assert f"{int(on_rim.sum())} rim faces" in text
        # furthest at a corner, moved 0.2 mm out in x and in y: 0.2·√2 from the solid
        assert f"by up to {0.2 * np.sqrt(2):.2f} mm" in text
        assert f"{RIM_OVERHANG_MM:g} mm" in text
        h = body.thickness_mm                  # the rim's taken from the clean sheet's
        assert clean[body.name].min() <= h.min() and h.max() <= clean[body.name].max()


def test_an_insert_rim_overhanging_its_solid_by_2_mm_is_refused_with_the_place(tmp_path):
    from fecheck.errors import FecheckError
    from fecheck.fe.bodies.scene_bodies import scene_bodies

    scene, rim = _implant_with_rim(tmp_path, 2.0)
    with pytest.raises(FecheckError) as err:
        scene_bodies(load_scene(scene))
    text = str(err.value)
    assert "leaves the solid nowhere" in text and "more than 0.5 mm" in text
    place = np.array([float(v) for v in text.split(" at (")[1].split(")")[0].split(", ")])
    assert np.linalg.norm(rim - place, axis=1).min() < 0.1
    # the furthest vertex is a corner, 2 mm out in x and y
    assert float(text.split("lies ")[1].split(" mm")[0]) == pytest.approx(2 * np.sqrt(2),
                                                                          rel=0.01)


# ------------------------------------------------------------------ the solid FE
@pytest.fixture(scope="module")
def implant_scene(tmp_path_factory) -> Path:
    from geometry.synthetic.implant import write_implant

    return write_implant(tmp_path_factory.mktemp("implant"), fine_mm=2.0)


def test_the_solid_dof_count_is_the_assembled_one(implant_scene):
    from fecheck.fe.bodies.scene_bodies import scene_bodies
    from fecheck.fe.bodies.volume import mesh_solid, solid_layers

    solid = scene_bodies(load_scene(implant_scene))[0].solid
    meshed = mesh_solid(solid)
    assembled = next(iter(solid_layers(solid, 463.0, 0.45, meshed=meshed).values()))
    assert meshed.n_dofs == 3 * assembled.n_nodes                     # scikit-fem's P2
    assert meshed.kept_dofs(solid, 45.0) == assembled.n_dofs          # base fixed, ties


def test_the_dof_guard_refuses_a_large_solid_before_the_ef_run(implant_scene, monkeypatch):
    from fecheck.errors import FecheckError
    from fecheck.fe.bodies import budget
    from fecheck.fe.bodies.scene_bodies import scene_bodies
    from fecheck.fe.bodies.volume import mesh_solid
    from fecheck.fe.knee import crosscheck
    from geometry.budget import policy

    def no_ef(*args, **kwargs):
        raise AssertionError("the EF ran before the guard")

    monkeypatch.setattr(crosscheck, "_ef_run", no_ef)
    scene = load_scene(implant_scene)
    # the solid keeps about 22k dofs, about 6 times that at fe.refine 1: a limit of 100k
    # (instead of 500k, to keep the test small) passes at level 0 and not at level 1
    solid = scene_bodies(scene)[0].solid
    small = mesh_solid(solid).kept_dofs(solid, scene["fe.solid_base_deg"])
    limit = 100_000
    assert small < limit < small * budget.SOLID_GROWTH
    monkeypatch.setattr(budget, "MAX_DOFS", limit)
    with policy("fecheck fe", force=False, force_hint="--force"):
        with pytest.raises(FecheckError) as err:
            crosscheck.cross_check(scene, refine=1, log=None)
    text = str(err.value)
    assert "FE dofs" in text and "use fe.refine <= 0, or --force" in text, text
    count = float(text.split("make about ")[1].split(" FE dofs")[0].replace(",", ""))
    assert count == pytest.approx(small * budget.SOLID_GROWTH, rel=0.35)


def test_ef_faces_without_an_fe_face_take_the_nearest_fe_pressure():
    from types import SimpleNamespace

    from fecheck.fe.knee.crosscheck import on_ef_faces

    # the EF sheet: 4 faces in a row along x; the FE surface covers the first two only
    strip = TriMesh(np.array([[x, y, 0.0] for x in range(5) for y in (0, 1)], dtype=float),
                    np.array([[0, 2, 1], [1, 2, 3], [2, 4, 3], [3, 4, 5],
                              [4, 6, 5], [5, 6, 7], [6, 8, 7], [7, 8, 9]]))
    fe = TriMesh(strip.points[:6], strip.faces[:4])
    layer = SimpleNamespace(to_ef=None, surface=fe, parent=np.arange(4),
                            body=SimpleNamespace(surface=strip))
    pressure = np.array([1.0, 1.0, 2.0, 2.0, 4.0, 4.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = on_ef_faces(layer, pressure)
    face = pressure[fe.faces].mean(axis=1)
    assert np.allclose(out[:4], face)
    # faces 4-7 lie beyond x = 2: the nearest FE face is the last one (centroid x 1.67)
    assert np.allclose(out[4:], face[3])


def test_the_smallest_surface_edge_prints_its_digits():
    from fecheck.cli.fe import geometry_line

    g = {"deformable_layers": 1, "tibial_surface": "solid:insert.stl",
         "femoral_surface": "mesh:femur.stl", "thickness_source": "solid", "elements": 1,
         "dofs": 3, "smallest_size_mm": 0.00412}
    assert "smallest surface edge 0.00412 mm" in geometry_line(g)
    assert "smallest surface edge 1.44 mm" in geometry_line(g | {"smallest_size_mm": 1.4413})


def test_the_solid_fe_on_a_finer_sheet_runs_clean_and_says_why_no_estimate(tmp_path, capsys):
    """The insert's sheet split in four (each solid top face then lies under four sheet
    faces, three of them with no FE face of their own): no numpy warning, finite face
    pressures, and the report says why a closed solid has no error estimate."""
    import json

    from fecheck.cli.fe import SOLID_NO_ESTIMATE
    from geometry.io import load_mesh, save_mesh
    from geometry.subdivide import subdivide
    from geometry.synthetic.implant import write_implant

    scene = write_implant(tmp_path, fine_mm=2.0)
    fine, _ = subdivide(load_mesh(tmp_path / "insert_top.stl"), 1)
    save_mesh(fine, tmp_path / "insert_top.stl")
    out = tmp_path / "fe.json"
    assert main(["fe", str(scene), "--json", str(out)]) == 0
    captured = capsys.readouterr()
    assert "invalid value" not in captured.err and "RuntimeWarning" not in captured.err
    assert SOLID_NO_ESTIMATE in captured.out
    data = json.loads(out.read_text(encoding="utf-8"))
    assert data["error_estimate"] is None
    for c in data["compartments"].values():          # None in the JSON where not finite
        assert c["fe_peaks"]["face_MPa"] > 0
