"""Output paths checked before the work starts, and written atomically after it.

A run that takes minutes must not lose its answer to a bad ``--json`` path: every CLI
verb calls `check_output` on each output path before it computes anything, and writes
through `write_text`, which replaces the file in one step (a reader never sees half a
file, and an older file is never left behind a newer run's failure). ``-`` means
standard output.

>>> check_output("-") is None
True
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

from fecheck.errors import FecheckError

STDOUT = "-"
"""The path that means standard output."""


def check_output(path: str | os.PathLike | None, *, directory: bool = False) -> Path | None:
    """Check that `path` can be written (its parent folder is created); None for no path
    or for ``-`` (standard output). `directory`: the path is a folder to write files in.

    Raises `FecheckError` naming the path and the reason, before any work is done.
    """
    if path is None or str(path) == STDOUT:
        if directory and path is not None:
            raise FecheckError("'-' (standard output) takes one file, not a folder of files")
        return None
    target = Path(path).expanduser()
    folder = target if directory else target.parent
    if target.exists() and target.is_dir() != directory:
        kind = "a folder" if target.is_dir() else "a file"
        raise FecheckError(f"cannot write {target}: it is {kind}")
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".fecheck-check-"):
            pass
    except OSError as err:
        raise FecheckError(f"cannot write to {target}: {err.strerror or err}") from None
    return target


def write_text(path: str | os.PathLike, text: str) -> None:
    """Write `text` to `path` atomically (a temporary file renamed into place), or to
    standard output for ``-``."""
    if str(path) == STDOUT:
        sys.stdout.write(text)
        sys.stdout.flush()
        return
    target = Path(path).expanduser()
    tmp = None
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.")
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as fh:
            fh.write(text)
        os.replace(tmp, target)
        tmp = None
    except OSError as err:
        raise FecheckError(f"cannot write {target}: {err.strerror or err}") from None
    finally:
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)
