"""Outputs: links written through, FIFOs and devices in place, modes by the umask, one-line
errors, nothing created before the work, older files named after a failed run."""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from fecheck.cli import main
from fecheck.errors import FecheckError
from fecheck.io import outputs
from fecheck.io.outputs import check_output, write_output, write_text
from geometry.icosphere import icosahedron
from geometry.io import save_mesh
from geometry.mesh import TriMesh


@pytest.fixture
def mesh_file(tmp_path) -> Path:
    return save_mesh(TriMesh(*icosahedron()), tmp_path / "ico.stl")


@pytest.fixture
def umask():
    """Set the umask for one test (restored after)."""
    old = os.umask(0o022)
    yield os.umask
    os.umask(old)


def _error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


def _fifo_reader(fifo: Path) -> int:
    """The FIFO's read end, opened without waiting and kept open, so that every writer
    gets in at once and all it writes (up to the pipe's 64 KiB) waits in the pipe."""
    return os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)


def _read(reader: int) -> bytes:
    """Everything written to the FIFO so far (its writers gone); closes the read end."""
    chunks = []
    try:
        while chunk := os.read(reader, 1 << 16):
            chunks.append(chunk)
    except BlockingIOError:
        pass
    finally:
        os.close(reader)
    return b"".join(chunks)


# ------------------------------------------------------------------ where it is written
def test_a_link_is_written_through_to_its_target_and_kept(tmp_path):
    target = tmp_path / "real" / "r.json"
    target.parent.mkdir()
    target.write_text("old\n")
    link = tmp_path / "l.json"
    link.symlink_to(Path("real") / "r.json")
    check_output(link)
    write_text(link, "new\n")
    assert link.is_symlink() and os.readlink(link) == str(Path("real") / "r.json")
    assert target.read_text() == "new\n"
    assert sorted(os.listdir(tmp_path)) == ["l.json", "real"]       # no temporary left
    assert os.listdir(target.parent) == ["r.json"]


def test_a_dangling_link_is_written_through_creating_its_target(tmp_path):
    link = tmp_path / "l.json"
    link.symlink_to(tmp_path / "out" / "r.json")
    check_output(link)
    assert not (tmp_path / "out").exists()               # nothing made by the check
    write_text(link, "new\n")
    assert link.is_symlink() and (tmp_path / "out" / "r.json").read_text() == "new\n"


def test_a_read_only_file_is_refused_not_renamed_over(tmp_path, monkeypatch):
    # root may write anything, so the permission answer is the operating system's word,
    # stood in for here: a file the user may not write is not replaced behind their back
    path = tmp_path / "r.json"
    path.write_text("keep\n")
    monkeypatch.setattr(outputs.os, "access",
                        lambda p, mode: Path(p) != path and os.path.exists(p))
    with pytest.raises(FecheckError, match=r"cannot write .*r\.json: the file is read-only"):
        check_output(path)


def test_a_fifo_is_written_in_place_not_replaced(tmp_path):
    fifo = tmp_path / "f.json"
    os.mkfifo(fifo)
    check_output(fifo)
    reader = _fifo_reader(fifo)
    write_text(fifo, '{"a": 1}\n')
    assert _read(reader) == b'{"a": 1}\n'
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)


def test_a_device_is_written_in_place_not_replaced(tmp_path):
    # a twin of /dev/null (same device numbers) where the test may make one, else /dev/null
    twin = tmp_path / "null"
    try:
        os.mknod(twin, stat.S_IFCHR | 0o666, os.makedev(1, 3))
    except OSError:
        twin = Path("/dev/null")
    before = os.stat(twin)
    check_output(twin)
    write_output(twin, lambda tmp: tmp.write_bytes(b"x" * 1000))
    after = os.stat(twin)
    assert stat.S_ISCHR(after.st_mode) and after.st_rdev == before.st_rdev
    assert after.st_ino == before.st_ino
    assert sorted(os.listdir(tmp_path)) == ([twin.name] if twin.parent == tmp_path else [])


def test_dev_null_stays_a_device_after_a_cli_output(mesh_file, capsys):
    assert main(["mesh", "info", str(mesh_file), "--json", "/dev/null"]) == 0
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)
    assert os.stat("/dev/null").st_rdev == os.makedev(1, 3)


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full here")
def test_dev_full_is_a_one_line_error(mesh_file, capsys):
    assert main(["mesh", "info", str(mesh_file), "--json", "/dev/full"]) == 2
    line = _error_line(capsys.readouterr().err)
    assert line == "fecheck: error: cannot write /dev/full: No space left on device"
    assert stat.S_ISCHR(os.stat("/dev/full").st_mode)


def test_dev_stdout_redirected_to_a_file_appends_to_it(mesh_file, tmp_path):
    # /dev/stdout leads to the very file the shell opened: it is written, not replaced
    log = tmp_path / "log.txt"
    with open(log, "w") as fh:
        subprocess.run([sys.executable, "-m", "fecheck", "mesh", "info", str(mesh_file),
                        "--json", "/dev/stdout"], stdout=fh, check=True, timeout=120,
                       env=dict(os.environ, PYTHONPATH=str(Path(__file__).parents[2])))
    text = log.read_text()
    table, _, doc = text.partition("\n[")
    assert "ico.stl" in table and "faces" in table                 # the table, first
    assert json.loads("[" + doc)[0]["faces"] == 20                  # then the JSON


def test_a_sweep_writes_its_csv_to_a_fifo_once(tmp_path, capsys):
    # the CSV kept up to date while a sweep runs is a file's business: a FIFO reader gets
    # the whole CSV once, at the end, not one copy per checkpoint
    fifo = tmp_path / "s.csv"
    os.mkfifo(fifo)
    reader = _fifo_reader(fifo)
    scene = Path(__file__).resolve().parents[2] / "validation" / "scenes" / "rigid.toml"
    assert main(["sweep", str(scene), "--param", "contact.youngs_MPa", "--values", "9,15,30",
                 "--csv", str(fifo)]) == 0
    lines = _read(reader).decode().splitlines()
    assert len(lines) == 4 and lines[0].startswith("contact.youngs_MPa,")
    assert [float(line.split(",")[0]) for line in lines[1:]] == [9.0, 15.0, 30.0]


def test_check_output_probes_no_file_beside_a_special_target(tmp_path, monkeypatch):
    fifo = tmp_path / "f.json"
    os.mkfifo(fifo)

    def no_probe(*args, **kwargs):
        raise AssertionError("made a probe file beside a FIFO")

    monkeypatch.setattr(outputs.tempfile, "NamedTemporaryFile", no_probe)
    assert check_output(fifo) == fifo
    assert check_output("/dev/null") == Path("/dev/null")


# ------------------------------------------------------------------ permissions
@pytest.mark.parametrize(("mask", "mode"), [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_a_new_file_gets_its_mode_from_the_umask(tmp_path, umask, mask, mode):
    umask(mask)
    path = tmp_path / "new.json"
    write_text(path, "{}\n")
    assert stat.S_IMODE(os.stat(path).st_mode) == mode      # 0o666 & ~umask, as '>' gives


def test_a_replaced_file_keeps_its_own_mode(tmp_path, umask):
    umask(0o077)
    path = tmp_path / "old.json"
    path.write_text("old\n")
    os.chmod(path, 0o640)
    write_text(path, "new\n")
    assert path.read_text() == "new\n"
    assert stat.S_IMODE(os.stat(path).st_mode) == 0o640


def test_a_failing_writer_leaves_the_old_file_and_no_temporary(tmp_path):
    path = tmp_path / "out.vtu"
    path.write_text("old\n")

    def fails(tmp):
        tmp.write_text("half")
        raise OSError(28, "No space left on device")

    with pytest.raises(FecheckError, match=r"^cannot write .*out\.vtu: No space left"):
        write_output(path, fails)
    assert path.read_text() == "old\n" and os.listdir(tmp_path) == ["out.vtu"]


# ------------------------------------------------------------------ folders and failed runs
@pytest.fixture
def failing_solve(monkeypatch):
    """A run that fails after its outputs were checked (as a solve error would)."""
    def boom(scene):
        raise FecheckError("the solve failed")

    monkeypatch.setattr("fecheck.model.run.run_scene", boom)


def test_output_folders_are_not_made_before_the_work(tmp_path, failing_solve, capsys):
    plots, vtk = tmp_path / "new" / "plots", tmp_path / "vtk"
    json_path = tmp_path / "deep" / "er" / "r.json"
    assert main(["run", "--plot", str(plots), "--vtk", str(vtk), "--json",
                 str(json_path)]) == 2
    assert "the solve failed" in _error_line(capsys.readouterr().err)
    assert os.listdir(tmp_path) == []                  # no folder made for nothing
    assert check_output(plots, directory=True) == plots and not plots.parent.exists()


def test_the_first_file_makes_its_folders(tmp_path):
    path = tmp_path / "a" / "b" / "x.json"
    write_text(path, "{}\n")
    assert path.read_text() == "{}\n"


def test_a_folder_under_a_file_is_refused_without_making_anything(tmp_path):
    (tmp_path / "file").write_text("")
    with pytest.raises(FecheckError, match=r"file.* is a file, not a folder"):
        check_output(tmp_path / "file" / "sub" / "plots", directory=True)


def test_a_failed_run_names_the_older_output_it_left(tmp_path, failing_solve, capsys):
    old = tmp_path / "r.json"
    old.write_text('{"from": "an earlier run"}\n')
    assert main(["run", "--json", str(old), "--csv", str(tmp_path / "new.csv")]) == 2
    line = _error_line(capsys.readouterr().err)
    assert line == f"fecheck: error: the solve failed (the older {old} was left as it was)"
    assert old.read_text() == '{"from": "an earlier run"}\n'


def test_no_note_when_there_was_no_older_output(tmp_path, failing_solve, capsys):
    assert main(["run", "--json", str(tmp_path / "r.json")]) == 2
    assert _error_line(capsys.readouterr().err) == "fecheck: error: the solve failed"


def test_an_output_written_before_the_failure_is_not_called_older(tmp_path, monkeypatch,
                                                                   capsys):
    old = tmp_path / "r.json"
    old.write_text("old\n")

    def write_then_fail(*args, **kwargs):
        write_text(old, "new\n")
        raise KeyboardInterrupt

    monkeypatch.setattr("fecheck.model.run.run_scene", write_then_fail)
    assert main(["run", "--json", str(old)]) == 130
    assert _error_line(capsys.readouterr().err) == "fecheck: interrupted"
    old.write_text("old again\n")

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr("fecheck.model.run.run_scene", interrupted)
    assert main(["run", "--json", str(old)]) == 130
    assert _error_line(capsys.readouterr().err) == \
        f"fecheck: interrupted (the older {old} was left as it was)"
