"""Output paths checked before the work starts, and written safely after it.

A run that takes minutes must not lose its answer to a bad ``--json`` path: every CLI
verb calls `check_output` on each output path before it computes anything (creating
nothing: a folder is made when its first file is written), and writes through
`write_text` or `write_output` (`geometry.files`): a regular file is replaced in one step
(a reader never sees half a file), a symbolic link's target is replaced and the link
kept, a FIFO or device (``/dev/null``) is written in place; a new file's permissions
follow the umask, a replaced file keeps its own. ``-`` means standard output.

A failed run leaves the files of an earlier run where they were; `left_as_they_were`
names those the run checked and did not write, for its error line.

>>> check_output("-") is None
True
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

from fecheck.errors import FecheckError
from geometry.files import write_output, writes_in_place

__all__ = ["STDOUT", "check_output", "earlier_note", "forget_checked", "left_as_they_were",
           "write_output", "write_text", "writes_in_place"]

STDOUT = "-"
"""The path that means standard output."""

_earlier: dict[Path, tuple[Path, int, int]] = {}
"""Regular files found at `check_output` time, by resolved path: (the path as given,
inode, modification time in ns)."""


def _nearest_folder(path: Path) -> Path:
    """`path` or its nearest ancestor that exists."""
    while not path.exists() and path != path.parent:
        path = path.parent
    return path


def _check_folder(target: Path, folder: Path) -> None:
    """Raise unless files can be made in `folder` or, when it does not exist yet, in its
    nearest existing ancestor (tried with a file made and removed there, except in /dev)."""
    found = _nearest_folder(folder)
    if not found.is_dir():
        raise FecheckError(f"cannot write {target}: {found} is a file, not a folder")
    if Path(os.path.abspath(found)).parts[1:2] == ("dev",):
        if not os.access(found, os.W_OK | os.X_OK):
            raise FecheckError(f"cannot write {target}: {found} is not writable")
        return
    try:
        with tempfile.NamedTemporaryFile(dir=found, prefix=".fecheck-check-"):
            pass
    except OSError as err:
        raise FecheckError(f"cannot write to {target}: {err.strerror or err}") from None


def check_output(path: str | os.PathLike | None, *, directory: bool = False) -> Path | None:
    """Check that `path` can be written, creating nothing; None for no path or for ``-``
    (standard output). `directory`: the path is a folder to write files in (made when
    its first file is written).

    Raises `FecheckError` naming the path and the reason, before any work is done.
    """
    if path is None or str(path) == STDOUT:
        if directory and path is not None:
            raise FecheckError("'-' (standard output) takes one file, not a folder of files")
        return None
    target = Path(path).expanduser()
    if target.exists() and target.is_dir() != directory:
        kind = "a folder" if target.is_dir() else "a file"
        raise FecheckError(f"cannot write {target}: it is {kind}")
    if directory:
        _check_folder(target, target)
        return target
    if writes_in_place(target):
        if not os.access(target, os.W_OK):
            raise FecheckError(f"cannot write {target}: permission denied")
        return target
    real = Path(os.path.realpath(target))
    if real.is_file():
        if not os.access(real, os.W_OK):
            raise FecheckError(f"cannot write {target}: the file is read-only")
        st = real.stat()
        _earlier[real] = (target, st.st_ino, st.st_mtime_ns)
    _check_folder(target, real.parent)
    return target


def forget_checked() -> None:
    """Forget the files `check_output` found (at the start of a command)."""
    _earlier.clear()


def left_as_they_were() -> list[Path]:
    """The files that existed when `check_output` checked them and that nothing has
    written since (a failed run leaves them as an earlier run wrote them)."""
    out = []
    for real, (given, ino, mtime) in _earlier.items():
        try:
            st = real.stat()
        except OSError:
            continue
        if (st.st_ino, st.st_mtime_ns) == (ino, mtime):
            out.append(given)
    return out


def earlier_note() -> str:
    """`` (the older PATH was left as it was)`` for the `left_as_they_were` files, to end
    a failed run's error line; '' when there are none."""
    paths = [str(p) for p in left_as_they_were()]
    if not paths:
        return ""
    names = paths[0] if len(paths) == 1 else f"{', '.join(paths[:-1])} and {paths[-1]}"
    return f" (the older {names} {'was' if len(paths) == 1 else 'were'} left as " \
           f"{'it was' if len(paths) == 1 else 'they were'})"


def write_text(path: str | os.PathLike, text: str) -> None:
    """Write `text` (UTF-8) to `path` by `write_output`, or to standard output for
    ``-``."""
    if str(path) == STDOUT:
        sys.stdout.write(text)
        sys.stdout.flush()
        return
    write_output(path, lambda tmp: tmp.write_text(text, encoding="utf-8", newline=""))
