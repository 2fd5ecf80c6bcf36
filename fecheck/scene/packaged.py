"""What ships inside the fecheck package: scenes by name, and data sets by name.

Scenes: every ``fecheck/scenes/NAME.toml`` is a packaged scene. A verb that takes a
scene takes its path or a packaged scene's name (``femur_tibia``; ``-`` and ``_`` are
the same, so the scene's own ``name`` works too); a path wins when that file exists.
`ALIASES` are friendly names. Each scene's description is the headline of its leading
comment.

Data sets: ``geometry.dir = "fecheck:knee/lenhart2015"`` names the folder
``fecheck/data/knee/lenhart2015`` of the installed package (the lenhart2015 scanned knee,
Apache-2.0; docs/data.md), so the packaged scenes find their meshes wherever fecheck is
installed; ``menisci.dir = "fecheck:knee/smith2019_menisci"`` names the menisci of the
same knee (smith2019, Apache-2.0).

>>> scene_path("scanned-knee").name
'femur_tibia.toml'
>>> data_dir("fecheck:knee/lenhart2015").name
'lenhart2015'
"""

from __future__ import annotations

import re
from importlib import resources
from pathlib import Path

from fecheck.errors import FecheckError

PACKAGE_PREFIX = "fecheck:"
"""A ``geometry.dir`` value starting so names a data set packaged with fecheck."""
DATA_SETS = ("knee/lenhart2015", "knee/smith2019_menisci", "knee/lenhart2015_patella")
"""The data sets packaged in ``fecheck/data`` (``geometry.dir = "fecheck:NAME"``)."""
ALIASES = {"scanned-knee": "femur_tibia"}
"""Friendly scene names → packaged scene: the scanned femur on the scanned tibia."""
DESCRIPTION_CHARS = 100
"""A scene's description is cut to about this many characters."""
HEADLINE_MIN = 30
"""A headline ends at a colon only after this many characters ("fecheck baseline scene:"
goes on)."""


def _package() -> Path:
    return Path(str(resources.files("fecheck")))


def scenes_dir() -> Path:
    """The folder of the packaged scenes."""
    return _package() / "scenes"


def scene_names() -> list[str]:
    """The packaged scenes' names (file stems), sorted."""
    return sorted(p.stem for p in scenes_dir().glob("*.toml"))


def scene_path(name: str) -> Path:
    """The packaged scene `name` (an alias, or a file stem with ``-`` for ``_``);
    `FecheckError` listing the names when there is none."""
    stem = ALIASES.get(name, name.replace("-", "_"))
    path = scenes_dir() / f"{stem}.toml"
    if not stem or "/" in stem or not path.is_file():
        aliases = ", ".join(f"{a} = {s}" for a, s in ALIASES.items())
        raise FecheckError(f"no scene file or packaged scene named {name!r}; packaged scenes: "
                           f"{', '.join(scene_names())} (aliases: {aliases}); or give the "
                           "path of a scene TOML file")
    return path


def resolve_scene(given: str | Path) -> Path:
    """The scene file a verb's SCENE argument names: the path when that file exists or the
    argument looks like a path (a folder part or a ``.toml`` suffix), else the packaged
    scene of that name (`scene_path`)."""
    path = Path(given)
    if path.exists() or len(path.parts) != 1 or path.suffix.lower() == ".toml":
        return path
    return scene_path(str(given))


def description(path: Path) -> str:
    """A scene file's headline: the first sentence of its leading comment up to its first
    ``": "`` outside parentheses after `HEADLINE_MIN` characters, cut near
    `DESCRIPTION_CHARS` characters at a word ("" when it has no leading comment)."""
    lines = []
    for line in path.read_text(encoding="utf-8").splitlines():
        if not line.startswith("#"):
            break
        lines.append(line.lstrip("#").strip())
    text = re.split(r"\.\s+(?=[A-Z])", " ".join(lines), maxsplit=1)[0].rstrip(".")
    depth = 0
    for i, char in enumerate(text):
        depth += {"(": 1, ")": -1}.get(char, 0)
        if text.startswith(": ", i) and depth == 0 and i >= HEADLINE_MIN:
            text = text[:i]
            break
    if len(text) <= DESCRIPTION_CHARS:
        return text
    return text[:DESCRIPTION_CHARS].rsplit(" ", 1)[0].rstrip(",;:") + " …"


def data_dir(value: str, key: str = "geometry.dir") -> Path:
    """The folder a ``geometry.dir`` (or another folder `key`) of the form ``fecheck:NAME``
    names; `FecheckError` listing the packaged data sets when NAME is not one."""
    name = value[len(PACKAGE_PREFIX):].strip("/")
    if name not in DATA_SETS:
        known = ", ".join(PACKAGE_PREFIX + n for n in DATA_SETS)
        raise FecheckError(f"{key} = {value!r} names no data set packaged with fecheck "
                           f"(packaged: {known}); give one of those or a folder path")
    return _package() / "data" / name
