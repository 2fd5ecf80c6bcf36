"""Rebuild or check the scanned knee packaged with fecheck (fecheck/data/knee/lenhart2015,
its menisci, fecheck/data/knee/smith2019_menisci, and its patella,
fecheck/data/knee/lenhart2015_patella).

The package holds, byte for byte, the files of the lenhart2015 and smith2019_menisci data
sets that the packaged scenes, the knee presets and the validation read, with each data
set's licence, NOTICE and README. The data sets themselves live beside the repository, in
../shared/data/knee/ (docs/data.md); they are the source of the package data.

    python scripts/package_knee_data.py            # copy the files, write SHA256SUMS
    python scripts/package_knee_data.py --check    # verify, change nothing

``--check`` exits 1 (one line per problem) when a packaged file differs from SHA256SUMS,
a file is missing or unlisted, or, where the source folder is present, the source no
longer has the hashes the package was built from. The source is ``--source`` (the
lenhart2015 folder; its menisci and patella are read from ``smith2019_menisci`` and
``lenhart2015_patella`` beside it), else
``$FECHECK_SHARED_DATA/knee/lenhart2015`` (as for the tests), else the folder above.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import shutil
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("FECHECK_SHARED_DATA", REPO.parent / "shared" / "data"))
SOURCE = SHARED / "knee" / "lenhart2015"
TARGET = REPO / "fecheck" / "data" / "knee" / "lenhart2015"
MANIFEST = "SHA256SUMS"
FILES = (
    "lenhart2015_R_tibia_cartilage_medial.stl",
    "lenhart2015_R_tibia_cartilage_lateral.stl",
    "lenhart2015_R_femur_cartilage.stl",
    "lenhart2015_R_femur_bone_distal60.stl",
    "lenhart2015_R_tibia_bone_proximal40.stl",
    "ligaments.json",
    "fits.json",
    "README.md",
    "LICENSE",
    "NOTICE-opensim-core",
)
"""The packaged files: the meshes and bundles the packaged scenes read, the fits the
validation's landmarks come from, and the data set's README (its provenance and the
changes made to the originals), licence and NOTICE. Not packaged: the whole (uncropped)
bones, the unsplit tibial cartilage and preview.png, which no packaged scene reads."""
MENISCI = "smith2019_menisci"
MENISCI_FILES = (
    "smith2019_R_meniscus_medial.stl",
    "smith2019_R_meniscus_lateral.stl",
    *(f"smith2019_R_meniscus_{side}_{face}.stl"
      for side in ("medial", "lateral") for face in ("superior", "inferior")),
    *(f"regions/smith2019_R_meniscus_{side}_{face}_{part}.stl"
      for side in ("medial", "lateral") for face in ("superior", "inferior")
      for part in ("1_anterior", "2_middle", "3_posterior")),
    "meniscal_ligaments.json",
    "menisci.json",
    "README.md",
    "LICENSE",
    "NOTICE-opensim-core",
)
"""The menisci files the scene key ``menisci.dir`` reads (`fecheck.model.menisci`): the two
closed volumes (their contact surfaces), the meniscal ligaments and contact parameters,
menisci.json (the femur's smith2019 pose, the files' sha256), README, licence and NOTICE;
and the four articular surfaces and their twelve regions (``regions/``), which label the
meniscus solids of the FE (`fecheck.fe.bodies.meniscus_solid`). Not packaged: preview.png."""
PATELLA = "lenhart2015_patella"
PATELLA_FILES = (
    "lenhart2015_R_patella_cartilage.stl",
    "lenhart2015_R_patella_bone.stl",
    "patellofemoral.json",
    "README.md",
    "LICENSE",
    "NOTICE-opensim-core",
)
"""The patella files the scene key ``patella.dir`` reads (`fecheck.model.patella`): the
articular sheet and the bone (its bone-distance thickness), the 20 bundles and four
quadriceps paths, README, licence and NOTICE. Not packaged: preview.png."""


def sha256(path: Path) -> str:
    """Hex sha256 of a file's bytes."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def read_manifest(folder: Path) -> dict[str, str]:
    """{file name: sha256} of ``folder/SHA256SUMS`` (``sha256sum`` format)."""
    lines = (folder / MANIFEST).read_text(encoding="utf-8").splitlines()
    return {name.lstrip("*"): digest for digest, name in (line.split(None, 1) for line in lines
                                                          if line.strip())}


def packaged_files(folder: Path) -> set[str]:
    """The files under `folder`, as paths relative to it (``regions/x.stl``)."""
    return {p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file()}


def build(source: Path, target: Path, files: tuple[str, ...] = FILES) -> None:
    """Copy `files` from `source` to `target` and write their SHA256SUMS."""
    missing = [name for name in files if not (source / name).is_file()]
    if missing:
        sys.exit(f"package_knee_data: {source} lacks {', '.join(missing)}")
    target.mkdir(parents=True, exist_ok=True)
    for stale in packaged_files(target) - set(files) - {MANIFEST}:
        (target / stale).unlink()
    for name in files:
        (target / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(source / name, target / name)
    (target / MANIFEST).write_text("".join(f"{sha256(target / n)}  {n}\n" for n in files),
                                   encoding="utf-8")
    print(f"package_knee_data: {len(files)} files copied from {source} to {target}")


def problems(target: Path, source: Path | None, files: tuple[str, ...] = FILES) -> list[str]:
    """What is wrong with the packaged `files` (and the source, when given)."""
    manifest = read_manifest(target)
    out = [f"{name}: listed in {MANIFEST} but not a packaged file" for name in files
           if name not in manifest]
    present = packaged_files(target) - {MANIFEST}
    out += [f"{name}: in {target} but not listed in {MANIFEST}" for name in
            sorted(present - set(manifest))]
    for name, digest in manifest.items():
        for folder, what in ((target, "packaged"), (source, "source")):
            if folder is None:
                continue
            path = folder / name
            if not path.is_file():
                out.append(f"{path}: {what} file missing")
            elif sha256(path) != digest:
                out.append(f"{path}: {what} file sha256 differs from {MANIFEST}; rebuild with "
                           "scripts/package_knee_data.py")
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true",
                        help="verify the packaged files (and the source, if present)")
    parser.add_argument("--source", type=Path, default=SOURCE,
                        help=f"the lenhart2015 data set folder (default {SOURCE})")
    args = parser.parse_args(argv)
    sets = ((args.source, TARGET, FILES),
            (args.source.parent / MENISCI, TARGET.parent / MENISCI, MENISCI_FILES),
            (args.source.parent / PATELLA, TARGET.parent / PATELLA, PATELLA_FILES))
    failed = False
    for source, target, files in sets:
        if not args.check:
            build(source, target, files)
        found = problems(target, source if source.is_dir() else None, files)
        for line in found:
            print(f"package_knee_data: {line}", file=sys.stderr)
        where = "package and source" if source.is_dir() else "package (no source beside it)"
        if not found:
            print(f"package_knee_data: {target.name}: {where}: {len(read_manifest(target))} "
                  f"files match {MANIFEST}")
        failed = failed or bool(found)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
