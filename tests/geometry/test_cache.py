"""On-disk mesh cache: identical arrays, hits without a rebuild (and faster than builds: a
`bench` test), atomic, fail-safe."""

import os
import subprocess
import sys
import time
import warnings
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from geometry import cache, layer
from geometry import icosphere as icosphere_module
from geometry.cache import cache_dir, cache_key, cached_build
from geometry.icosphere import icosphere
from geometry.mesh import TetMesh, TriMesh
from geometry.plateau import plateau_box


@pytest.fixture
def fresh_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("FECHECK_CACHE_DIR", str(tmp_path / "c"))
    return tmp_path / "c"


def test_cache_dir_follows_the_environment(fresh_cache):
    assert cache_dir() == fresh_cache


def test_cached_mesh_is_identical_to_a_fresh_build(fresh_cache):
    fresh = plateau_box((1, 2, 3), 40, 30, 5, frontal_deg=7, mesh_size=5, cache=False)
    info1, info2 = {}, {}
    params = {"case": "box"}
    first = cached_build("box", params, lambda: fresh, info=info1)
    again = cached_build("box", params, lambda: pytest.fail("should not rebuild"), info=info2)
    assert (info1["source"], info2["source"]) == ("built", "cache")
    assert again is not first
    np.testing.assert_array_equal(again.points, fresh.points)
    np.testing.assert_array_equal(again.faces, fresh.faces)
    assert again.regions.keys() == fresh.regions.keys()
    for k in fresh.regions:
        np.testing.assert_array_equal(again.regions[k], fresh.regions[k])


def test_tet_meshes_round_trip_through_the_cache(fresh_cache):
    tet = TetMesh(np.eye(4, 3), np.array([[0, 1, 2, 3]]), {"top": np.array([[1, 2, 3]])})
    cached_build("tet", {}, lambda: tet)
    back = cached_build("tet", {}, lambda: pytest.fail("should not rebuild"))
    assert isinstance(back, TetMesh)
    np.testing.assert_array_equal(back.tets, tet.tets)
    np.testing.assert_array_equal(back.boundaries["top"], tet.boundaries["top"])


def test_a_cache_hit_reads_the_build_without_running_gmsh(fresh_cache, monkeypatch):
    built = icosphere(1.0, 6)
    assert cache.STATS.last == "built"
    monkeypatch.setattr(icosphere_module, "_unit_gmsh",
                        lambda *args, **kwargs: pytest.fail("a cache hit ran the builder"))
    hit = icosphere(1.0, 6)
    assert cache.STATS.last == "cache"
    np.testing.assert_array_equal(hit.points, built.points)
    np.testing.assert_array_equal(hit.faces, built.faces)


@pytest.mark.bench
def test_cache_hit_is_faster_than_the_build(fresh_cache):
    t0 = time.perf_counter()
    built = icosphere(1.0, 6)
    t_build = time.perf_counter() - t0
    t0 = time.perf_counter()
    hit = icosphere(1.0, 6)
    t_hit = time.perf_counter() - t0
    assert cache.STATS.last == "cache"
    np.testing.assert_array_equal(hit.points, built.points)
    assert t_hit < t_build  # measured ≈ 10x faster (npz read vs 6 Gmsh refinements)


def test_keys_canonicalise_parameters():
    assert cache_key("a", {"x": 0.1 + 0.2, "y": [1, 2]}) == cache_key("a", {"y": (1, 2), "x": 0.3})
    assert cache_key("a", {"x": 0.3}) != cache_key("a", {"x": 0.30001})
    assert cache_key("a", {"x": 0.3}) != cache_key("b", {"x": 0.3})


def test_gmsh_and_builder_versions_choose_the_cache_file(fresh_cache, monkeypatch):
    mesh = TriMesh(np.eye(3), np.array([[0, 1, 2]]))

    def entry(version: int = 1) -> str:
        info = {}
        cached_build("v", {"k": 1}, lambda: mesh, info=info, version=version)
        return info["path"]

    monkeypatch.setattr(cache, "gmsh_version", lambda: "4.11.0")
    first = entry()
    assert entry() == first and cache.STATS.last == "cache"
    assert entry(version=2) != first and cache.STATS.last == "built"
    assert entry(version=2) != first and cache.STATS.last == "cache"
    monkeypatch.setattr(cache, "gmsh_version", lambda: "4.13.1")
    assert entry() != first and cache.STATS.last == "built"
    monkeypatch.setattr(cache, "gmsh_version", lambda: "4.11.0")
    assert entry() == first and cache.STATS.last == "cache"
    assert len(list(fresh_cache.glob("v-*.npz"))) == 3


def test_gmsh_version_is_the_installed_one_and_gmsh_stays_unimported():
    code = ("import sys; from geometry.cache import cache_key, gmsh_version; cache_key('a', {}); "
            "print(gmsh_version(), 'gmsh' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    import gmsh

    assert out.stdout.split() == [gmsh.__version__, "False"]


def test_layer_builder_passes_its_version_not_a_parameter(monkeypatch):
    seen = {}

    def spy(name, params, build, use_cache=True, info=None, *, version=1):
        seen.update(name=name, params=params, version=version)
        return "built"

    monkeypatch.setattr(layer, "cached_build", spy)
    monkeypatch.setattr(layer, "_BUILDER_VERSION", 7)
    assert layer.cartilage_layer() == "built"
    assert seen["name"] == "cartilage_layer" and seen["version"] == 7
    assert "builder_version" not in seen["params"]


def test_unwritable_cache_warns_once_and_still_builds(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("FECHECK_CACHE_DIR", str(blocker / "sub"))
    mesh = TriMesh(np.eye(3), np.array([[0, 1, 2]]))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        a = cached_build("x", {}, lambda: mesh)
        b = cached_build("x", {}, lambda: mesh)
    assert a is mesh and b is mesh
    assert sum("mesh cache disabled" in str(w.message) for w in caught) == 1


def _rebuilt_with_a_note(name, params, build, info) -> list[str]:
    """Run `cached_build` on a damaged entry: it must rebuild, warning once on one line."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        again = cached_build(name, params, build, info=info)
    notes = [str(w.message) for w in caught if "mesh cache entry" in str(w.message)]
    assert info["source"] == "built" and again is build()
    assert len(notes) == 1 and "\n" not in notes[0], notes
    assert notes[0].startswith(f"mesh cache entry {info['path']} was damaged (")
    assert notes[0].endswith("); rebuilt")
    return notes


def test_corrupt_entry_is_rebuilt(fresh_cache):
    mesh = TriMesh(np.eye(3), np.array([[0, 1, 2]]))
    info = {}
    cached_build("x", {"k": 1}, lambda: mesh, info=info)
    with open(info["path"], "wb") as fh:
        fh.write(b"garbage")
    _rebuilt_with_a_note("x", {"k": 1}, lambda: mesh, info)


@pytest.mark.parametrize("keep", [0.5, 0.9, 0.0], ids=["half", "tail-cut", "empty"])
def test_a_truncated_entry_is_rebuilt_with_a_note_and_stored_again(fresh_cache, keep):
    mesh = icosphere(2.0, 2, cache=False)
    info = {}
    cached_build("ico", {}, lambda: mesh, info=info)
    entry = Path(info["path"])
    data = entry.read_bytes()
    entry.write_bytes(data[:int(keep * len(data))])
    _rebuilt_with_a_note("ico", {}, lambda: mesh, info)
    back = cached_build("ico", {}, lambda: pytest.fail("the rebuilt entry was not stored"),
                        info=info)
    assert info["source"] == "cache"
    np.testing.assert_array_equal(back.faces, mesh.faces)


TRI = {"kind": np.array("tri"), "points": np.eye(3), "cells": np.array([[0, 1, 2]])}
TET = {"kind": np.array("tet"), "points": np.eye(4, 3), "cells": np.array([[0, 1, 2, 3]]),
       "group__top": np.array([[1, 2, 3]])}


@pytest.mark.parametrize(("kind", "change", "reason"), [
    ("tri", {"points": np.eye(3)[:, :2]}, "points of shape (3, 2)"),
    ("tri", {"cells": np.array([[0, 1, 7]])}, "cells index 7 out of range 0..2"),
    ("tri", {"cells": np.array([[0.0, 1.0, 2.0]])}, "not (m, 3) integers"),
    ("tri", {"group__top": np.array([0, 4])}, "group__top index 4 out of range 0..0"),
    ("tri", {"points": np.full((3, 3), np.nan)}, "points not finite"),
    ("tet", {"cells": np.array([[0, 1, 2, 3, 0]])}, "not (m, 4|10) integers"),
    ("tet", {"cells": np.array([[0, 1, 2, 9]])}, "cells index 9 out of range 0..3"),
    ("tet", {"group__top": np.array([[1, 2, 5]])}, "group__top index 5 out of range 0..3"),
    ("tet", {"kind": np.array("hex")}, "unknown mesh kind 'hex'"),
], ids=["tri-points", "tri-index", "tri-float", "tri-region", "tri-nan", "tet-width",
        "tet-index", "tet-boundary", "kind"])
def test_an_entry_of_the_wrong_shape_is_rebuilt_with_a_note(fresh_cache, kind, change,
                                                             reason):
    good = TRI if kind == "tri" else TET
    mesh = (TriMesh(good["points"], good["cells"]) if kind == "tri"
            else TetMesh(good["points"], good["cells"], {"top": good["group__top"]}))
    info = {}
    cached_build(kind, {}, lambda: mesh, info=info)
    np.savez(Path(info["path"]), **(good | change))
    notes = _rebuilt_with_a_note(kind, {}, lambda: mesh, info)
    assert reason in notes[0]


def test_a_damaged_array_entry_is_rebuilt_with_a_note(fresh_cache):
    mesh = TriMesh(np.eye(3), np.array([[0, 1, 2]]))
    value = (np.arange(6.0),)
    assert cache.cached_arrays("arr", [mesh], lambda: value)[0].tolist() == list(range(6))
    entry = next(Path(fresh_cache).glob("arr-*.npz"))
    entry.write_bytes(entry.read_bytes()[:40])
    builds = cache.STATS.builds
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        again = cache.cached_arrays("arr", [mesh], lambda: value)
    assert again[0].tolist() == list(range(6)) and cache.STATS.builds == builds + 1
    assert [str(w.message) for w in caught] == [
        f"mesh cache entry {entry} was damaged (BadZipFile: File is not a zip file); rebuilt"]


def test_parallel_writers_leave_one_valid_entry_and_no_temp_files(fresh_cache):
    mesh = icosphere(2.0, 3, cache=False)

    def build():
        time.sleep(0.01)
        return mesh

    with ThreadPoolExecutor(4) as pool:
        list(pool.map(lambda _: cached_build("par", {}, build), range(8)))
    files = os.listdir(fresh_cache)
    assert len([f for f in files if f.startswith("par-")]) == 1
    assert not [f for f in files if f.startswith(".")]           # no temporary left
    back = cached_build("par", {}, lambda: pytest.fail("should not rebuild"))
    np.testing.assert_array_equal(back.faces, mesh.faces)


# ------------------------------------------------------------------ per mesh object
def _triangle() -> TriMesh:
    return TriMesh(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))


def test_per_mesh_computes_once_per_mesh_object_and_arguments():
    calls = []

    @cache.per_mesh
    def scaled_area(mesh: TriMesh, factor: float) -> float:
        calls.append((id(mesh), factor))
        return factor * float(mesh.area)

    mesh = _triangle()
    assert scaled_area(mesh, 2.0) == scaled_area(mesh, 2.0) == 1.0     # ½ · 2, computed once
    assert scaled_area(mesh, 3.0) == 1.5 and len(calls) == 2            # other arguments
    twin = TriMesh(mesh.points, mesh.faces)                             # same arrays, new mesh
    assert scaled_area(twin, 2.0) == 1.0 and len(calls) == 3


@pytest.mark.parametrize("returns_the_mesh", [False, True])
def test_per_mesh_lets_a_dropped_mesh_go(returns_the_mesh):
    import gc
    import weakref

    @cache.per_mesh
    def derived(mesh: TriMesh):
        return mesh if returns_the_mesh else np.zeros(3)

    mesh = _triangle()
    derived(mesh)
    alive = weakref.ref(mesh)
    del mesh
    gc.collect()
    assert alive() is None
