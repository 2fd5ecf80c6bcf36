"""Writing an output file without clobbering what its path names: `write_output`.

* A regular file, or no file yet: the new content goes to a temporary file in the same
  folder, renamed over the old one in one step, so a reader never sees half a file. A
  symbolic link is followed: its target is replaced and the link kept. A new file gets
  the permissions ``0o666 & ~umask`` (as the shell's ``>`` would give it); a replaced
  file keeps its own. Missing folders on the way are created then, not before.
* Anything else is written in place, never replaced: a FIFO, a device (``/dev/null``,
  ``/dev/full``), a terminal, and a descriptor path (``/dev/stdout``, ``/dev/fd/N``,
  ``/proc/...``) even when it leads to a regular file (appended to, as the descriptor's
  own writes would be).

>>> writes_in_place("/dev/null"), writes_in_place("/no/such/file.json")
(True, False)
"""

from __future__ import annotations

import os
import secrets
import shutil
import stat
import tempfile
from collections.abc import Callable
from pathlib import Path

from geometry.errors import FecheckError

_DESCRIPTORS = ("/dev/stdout", "/dev/stderr", "/dev/stdin", "/dev/fd/", "/proc/")


def _names_a_descriptor(path: Path) -> bool:
    """Whether `path` reaches a file through a process's descriptor (``/dev/stdout``)."""
    text = os.path.abspath(path)
    return any(text == d.rstrip("/") or text.startswith(d) for d in _DESCRIPTORS)


def writes_in_place(path: str | os.PathLike) -> bool:
    """Whether `write_output` writes `path` in place (an existing FIFO, device or
    descriptor path) rather than by renaming a new file over it."""
    target = Path(path).expanduser()
    try:
        mode = os.stat(target).st_mode
    except OSError:
        return False
    if stat.S_ISDIR(mode):
        return False
    return not stat.S_ISREG(mode) or _names_a_descriptor(target)


def write_output(path: str | os.PathLike, write: Callable[[Path], object]) -> Path:
    """Write `path` by calling ``write(tmp)``, which writes the whole content to the
    file `tmp` (a new, empty file with `path`'s suffix), then putting it in place by the
    rules of this module. Returns `path`.

    Raises `FecheckError` ("cannot write PATH: reason") on an `OSError` on the way; the
    temporary file is removed whatever happens.
    """
    target = Path(path).expanduser()
    try:
        if writes_in_place(target):
            _write_in_place(target, write)
        else:
            _write_by_rename(Path(os.path.realpath(target)), write)
    except OSError as err:
        raise FecheckError(f"cannot write {target}: {err.strerror or err}") from None
    return Path(path)


def _write_in_place(target: Path, write: Callable[[Path], object]) -> None:
    with tempfile.TemporaryDirectory(prefix="fecheck-") as scratch:
        tmp = Path(scratch) / f"output{target.suffix}"
        tmp.touch()
        write(tmp)
        fd = os.open(target, os.O_WRONLY | os.O_APPEND)
        with open(tmp, "rb") as src, os.fdopen(fd, "wb") as dst:
            shutil.copyfileobj(src, dst)


def _new_file(folder: Path, name: str, suffix: str) -> Path:
    """A new empty file in `folder` made with mode 0o666 (the umask applies)."""
    while True:
        tmp = folder / f".{name[:80]}.{secrets.token_hex(4)}{suffix}"
        try:
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
        except FileExistsError:
            continue
        return tmp


def _write_by_rename(real: Path, write: Callable[[Path], object]) -> None:
    real.parent.mkdir(parents=True, exist_ok=True)
    try:
        keep = stat.S_IMODE(os.stat(real).st_mode)
    except FileNotFoundError:
        keep = None
    tmp = _new_file(real.parent, real.stem, real.suffix)
    try:
        write(tmp)
        if keep is not None:
            os.chmod(tmp, keep)
        os.replace(tmp, real)
    finally:
        tmp.unlink(missing_ok=True)
