"""Built model parts reused across a sweep's runs (`fecheck.model.reuse`): only while every
scene key the build read is unchanged, only within the context and its thread; a sweep
of a key the build reads gives the fresh runs' numbers, one of a key it does not read
builds once."""

from __future__ import annotations

import threading

import pytest

from fecheck.contact.pair import ContactPair
from fecheck.fe.knee.crosscheck import cross_check
from fecheck.model import reuse
from fecheck.model.reuse import reusable, reusing_builds
from fecheck.model.run import run_scene
from fecheck.scene import apply_overrides, load_scene, surfaces
from fecheck.studies.sweep import override_for, run_sweep

BUILDS: list[str] = []


@reusable
def _inner(scene):
    BUILDS.append("inner")
    return ("inner", scene["contact.youngs_MPa"])


@reusable
def _outer(scene):
    BUILDS.append("outer")
    return ("outer", scene["contact.poisson"], _inner(scene))


def _scene(**values):
    return load_scene(overrides=[f"{k.replace('__', '.')}={v}" for k, v in values.items()])


def test_parts_are_reused_while_the_keys_read_are_unchanged():
    BUILDS.clear()
    with reusing_builds():
        first = _outer(_scene())
        assert _outer(_scene(load__force_N=900.0)) is first      # a key not read
        assert BUILDS == ["outer", "inner"]
        again = _outer(_scene(contact__poisson=0.42))              # read by the outer only
        assert again is not first and again[2] is first[2]
        assert BUILDS == ["outer", "inner", "outer"]
        # read by the inner build only: the outer one, which called it, rebuilds too
        changed = _outer(_scene(contact__poisson=0.42, contact__youngs_MPa=7.0))
        assert changed[2] == ("inner", 7.0)
        assert BUILDS == ["outer", "inner", "outer", "outer", "inner"]


def test_nothing_is_kept_outside_the_context_or_across_threads():
    BUILDS.clear()
    _outer(_scene())
    _outer(_scene())
    assert BUILDS == ["outer", "inner"] * 2
    with reusing_builds():
        mine = _outer(_scene())
        theirs = []
        thread = threading.Thread(target=lambda: theirs.append(_outer(_scene())))
        thread.start()
        thread.join()
        assert theirs[0] is not mine and theirs[0] == mine
        assert _outer(_scene()) is mine
    assert getattr(reuse._active, "memo", None) is None


@pytest.mark.parametrize("param, values", [("contact.youngs_MPa", [4.0, 8.0, 16.0]),
                                           ("mesh.plateau_refine_mm", [1.5, 1.0])])
def test_a_sweep_of_a_key_the_build_reads_equals_fresh_runs(param, values):
    scene = load_scene()
    swept = run_sweep(scene, param, values, progress=False)
    for value, point in zip(values, swept, strict=True):
        fresh = run_scene(apply_overrides(scene, [override_for(scene, param, value)]))
        assert point.result.converged and fresh.converged
        for c, comp in fresh.compartments.items():
            assert point.result.compartments[c].force_N == pytest.approx(comp.force_N,
                                                                         rel=1e-9)
            assert point.result.compartments[c].area_mm2 == pytest.approx(comp.area_mm2,
                                                                          rel=1e-9)


def _count_pairs(monkeypatch) -> list:
    """Every contact pair built from now on (a list that grows)."""
    made = []
    init = ContactPair.__init__

    def counted(self, *args, **kwargs):
        made.append(self)
        init(self, *args, **kwargs)

    monkeypatch.setattr(ContactPair, "__init__", counted)
    return made


def test_a_load_point_sweep_builds_the_model_once(monkeypatch):
    made = _count_pairs(monkeypatch)
    points = run_sweep(load_scene(), "load.point_mm[0]", [4.0, 5.0, 6.0], progress=False)
    assert all(p.result.converged for p in points)
    assert len(made) == 2                # one pair per compartment, at the first point


def test_a_mesh_master_sweep_reusing_its_walk_equals_fresh_runs(tmp_path, monkeypatch):
    """The femur-tibia model (a mesh master, whose closest-point walk and candidate sets
    carry over from one point to the next) on the synthetic knee of `test_own_knee`."""
    from test_own_knee import write_scene

    from fecheck.model import scanned

    scene = load_scene(write_scene(tmp_path, "stl", "mm", "sagittal"))
    values = [600.0, 700.0, 900.0]
    made, slaves = _count_pairs(monkeypatch), []
    read = scanned.tibial_slaves
    monkeypatch.setattr(scanned, "tibial_slaves", lambda s: slaves.append(1) or read(s))
    swept = run_sweep(scene, "load.force_N", values, progress=False)
    assert (len(made), len(slaves)) == (2, 1)        # built once, at the first point
    for value, point in zip(values, swept, strict=True):
        fresh = run_scene(apply_overrides(scene, [f"load.force_N={value}"]))
        assert point.result.converged and fresh.converged
        for c, comp in fresh.compartments.items():
            assert comp.force_N > 0
            assert point.result.compartments[c].force_N == pytest.approx(comp.force_N,
                                                                         rel=1e-9)


def test_a_failed_point_drops_the_parts_built_so_far():
    from fecheck.studies.sweep import _solve_reusing

    scene = load_scene()
    memo: dict = {}
    ok = _solve_reusing(memo, scene, "contact.youngs_MPa=20.0", 20.0)
    assert not ok.failed and memo
    crushed = _solve_reusing(memo, scene, "contact.youngs_MPa=0.1", 0.1)   # layer crushed
    assert crushed.failed and memo == {}


def _count_calls(monkeypatch, module, name: str) -> list:
    """Every call of `module.name` from now on (a list that grows)."""
    calls = []
    original = getattr(module, name)

    def counted(*args, **kwargs):
        calls.append(args)
        return original(*args, **kwargs)

    monkeypatch.setattr(module, name, counted)
    return calls


def test_a_run_builds_the_scanned_knee_once(monkeypatch):
    # the EF run reads its pairs three times (the compartments, each compartment's
    # thickness map) and the surfaces from the runner, the mesh checks and the fingerprint:
    # each is built once
    made = _count_pairs(monkeypatch)
    sheets = _count_calls(monkeypatch, surfaces, "tibial_compartments")
    femur = _count_calls(monkeypatch, surfaces, "femoral_surface")
    result = run_scene(load_scene("femur_tibia", ["scanned.decimate_faces=1500"]))
    assert result.converged
    assert len(made) == 2                # one pair per compartment
    assert len(sheets) == 2 and len(femur) == 1   # the tibial slaves', the femur's share


def test_a_cross_check_builds_the_knee_once_for_the_ef_and_the_fe(monkeypatch):
    # the FE's tibial sheets are the very objects the EF's pairs hold, and the femoral
    # surface is read once for both
    made = _count_pairs(monkeypatch)
    sheets = _count_calls(monkeypatch, surfaces, "tibial_compartments")
    femur = _count_calls(monkeypatch, surfaces, "femoral_surface")
    scene = load_scene("femur_tibia", ["scanned.decimate_faces=1500", "fe.layers=1"])
    check = cross_check(scene, log=None)
    assert len(made) == 2 and len(sheets) == 2 and len(femur) == 1
    slaves = {id(p.slave) for p in made}
    assert {id(chk.layer.body.surface) for chk in check.compartments.values()} == slaves
