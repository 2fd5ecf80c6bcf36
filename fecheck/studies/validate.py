"""Run the validation rows (``validation/row_*.py``) in-process and write the report.

Each row script exposes ``rows(quick: bool, out: Path) -> list[Row]`` (see
``validation/report.py``). `run_validation` imports the scripts from the validation
folder (next to the package's repository root, or given) as modules of the package
``validation`` (they import one another so), runs the selected ones, times
them, prints progress on stderr, and writes ``OUT/report.md`` with the conventions, a
summary and one section per row. A script that fails to import or raises becomes a
"failed" row; the report is always written.
"""

from __future__ import annotations

import contextlib
import importlib
import importlib.machinery
import importlib.util
import re
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from fecheck.errors import FecheckError
from fecheck.io.outputs import write_output

SCRIPT_PREFIX = "row_"

CONVENTIONS = """\
## Conventions

- Units: mm, N, MPa (N/mm²), N·mm, s. Deviation = 100·(fecheck − thesis)/thesis, %.
- Frame (thesis App. A/B): origin at the tibial plateau centre, x to the subject's right,
  y anterior, z superior; in the baseline right knee the medial compartment is at x < 0.
- Load: 800 N along +z on the tibia at **x = +7.9 mm**, y = 12.8, z = −380 mm, with a
  2.0 kg tibia (19.62 N) at x = 0. The thesis prints x = −7.9 mm, but its own Table 5.1
  (323.71 / 456.67 N) is reproduced only with x = +7.9 mm (F_m + F_l = 780.38 N,
  −20.4·F_m + 28.3·F_l = 800·7.9); sweeps move the load point along x from there
  ("shift", mm).
- Elastic foundation: k = (1−ν)E/((1+ν)(1−2ν)h), E = 20 MPa, ν = 0.3, h = 6 mm
  (k = 4.487 N/mm³). fecheck clips each contact face at its zero-depth line (exact
  area and ∫depth dA); the thesis counted the whole area of every face touching the
  plane (its Fig. 3.20), which overestimates area and underestimates depth by 12-16 % at
  5,000 faces. Where the thesis's number comes from that counting, the tables show
  fecheck's exact value and fecheck's whole-face value side by side.
- Scanned rows use the lenhart2015 MRI knee packaged with fecheck (another subject than
  the thesis's unpublished scan): they compare trends and orders of magnitude, and are
  skipped with a message when $FECHECK_KNEE_DIR names an absent folder.
- Times are compared as ratios and exponents measured in one run, never as absolute
  values.
- Status: *reproduced* (every deviation within the row's stated tolerance), *deviates,
  explained* (numbers and the reason given), *cannot be reproduced* (why given),
  *skipped* (a piece or data set is missing) or *failed* (the script raised).
"""


def default_validation_dir() -> Path:
    """``validation/`` at the repository root next to the installed `fecheck` package."""
    import fecheck

    return Path(fecheck.__file__).resolve().parents[1] / "validation"


def find_validation_dir(explicit: str | Path | None = None) -> Path:
    """The validation folder: `explicit` if given, else `default_validation_dir()`."""
    path = Path(explicit) if explicit is not None else default_validation_dir()
    if not path.is_dir():
        raise FecheckError(f"validation folder not found at {path}; run from a source "
                           "checkout of fecheck or pass --dir PATH/validation")
    if not discover(path):
        raise FecheckError(f"{path} holds no validation row scripts ({SCRIPT_PREFIX}*.py): "
                           "--dir takes the validation/ folder of a fecheck source checkout "
                           "(row_rigid.py, report.py, scenes/ ...)")
    return path


def discover(vdir: Path) -> dict[str, Path]:
    """Row scripts in `vdir`: name (file stem without ``row_``) → path, sorted by name."""
    return {p.stem[len(SCRIPT_PREFIX):]: p for p in sorted(vdir.glob(f"{SCRIPT_PREFIX}*.py"))}


def select(scripts: dict[str, Path], only: Sequence[str] | None) -> dict[str, Path]:
    """The scripts named in `only` (all when empty); unknown names raise FecheckError."""
    if not only:
        return scripts
    unknown = [n for n in only if n not in scripts]
    if unknown:
        raise FecheckError(f"unknown validation row(s) {', '.join(unknown)}; "
                           f"choose from: {', '.join(scripts)}")
    return {n: scripts[n] for n in scripts if n in only}


PACKAGE = "validation"
"""The row scripts import one another as modules of this package (``from validation import
report``)."""


@contextlib.contextmanager
def _package(vdir: Path):
    """`PACKAGE` names the folder `vdir` while the block runs; the modules it named before
    (another checkout's validation/, or none) are put back afterwards."""
    def ours(name: str) -> bool:
        return name == PACKAGE or name.startswith(PACKAGE + ".")

    saved = {n: m for n, m in sys.modules.items() if ours(n)}
    for name in saved:
        del sys.modules[name]
    init = vdir / "__init__.py"
    if init.is_file():
        spec = importlib.util.spec_from_file_location(PACKAGE, init,
                                                      submodule_search_locations=[str(vdir)])
    else:                                   # a folder of scripts without the package file
        spec = importlib.machinery.ModuleSpec(PACKAGE, None, is_package=True)
        spec.submodule_search_locations = [str(vdir)]
    package = importlib.util.module_from_spec(spec)
    sys.modules[PACKAGE] = package
    try:
        if init.is_file():
            spec.loader.exec_module(package)
        yield package
    finally:
        for name in [n for n in sys.modules if ours(n)]:
            del sys.modules[name]
        sys.modules.update(saved)


def run_validation(out: Path, quick: bool = False, only: Sequence[str] | None = None,
                   vdir: str | Path | None = None, log=None) -> tuple[Path, list]:
    """Run the selected row scripts; write ``out/report.md``; return (report path, rows).

    Progress goes to `log` (default: standard error)."""
    log = sys.stderr if log is None else log
    vdir = find_validation_dir(vdir)
    scripts = select(discover(vdir), only)
    out = Path(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise FecheckError(f"cannot create the output folder {out}: {err.strerror}") from None
    with _package(vdir):
        report_module = importlib.import_module(f"{PACKAGE}.report")  # validation/report.py
        rows, total = _run_rows(scripts, quick, out, report_module.Row, log)
        text = render(rows, quick, total, report_module.row_markdown, out)
    report = out / "report.md"
    write_output(report, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    print(f"wrote {report} ({len(rows)} rows, {total:.0f} s)", file=log, flush=True)
    return report, rows


def _run_rows(scripts: dict[str, Path], quick: bool, out: Path, row_type, log
              ) -> tuple[list, float]:
    """Each script's rows (a failing one becomes a "failed" row) and the total time, s."""
    rows = []
    t_all = time.perf_counter()
    for i, (name, path) in enumerate(scripts.items(), 1):
        print(f"[{i}/{len(scripts)}] {name} ...", file=log, flush=True)
        t0 = time.perf_counter()
        try:
            got = list(importlib.import_module(f"{PACKAGE}.{path.stem}").rows(quick, out))
        except Exception as err:  # noqa: BLE001 - one failing script must not stop the report
            got = [row_type(name, f"script {path.name}", path.name,
                            f"failed: {type(err).__name__}: {err}")]
        dt = time.perf_counter() - t0
        for r in got:
            print(f"    {r.reference:24s} {r.status[:70]}  ({r.seconds:.1f} s)", file=log,
                  flush=True)
        print(f"    {name} done in {dt:.1f} s", file=log, flush=True)
        rows.extend(got)
    return rows, time.perf_counter() - t_all


def thesis_order(reference: str) -> tuple[int, int, int]:
    """Sort key of "Table 5.3" / "Fig. 4.4" / "Figs. 3.21/3.25": chapter, tables before
    figures, number."""
    m = re.search(r"(\d+)\.(\d+)", reference)
    chapter, number = (int(m[1]), int(m[2])) if m else (99, 99)
    return chapter, 0 if reference.startswith("Table") else 1, number


def render(rows: list, quick: bool, total_s: float, row_markdown, out: Path) -> str:
    """The whole report.md text (rows in the thesis's order)."""
    rows = sorted(rows, key=lambda r: thesis_order(r.reference))
    counts: dict[str, int] = {}
    for r in rows:
        key = r.status.split(":")[0]
        counts[key] = counts.get(key, 0) + 1
    mode = ("quick (coarser meshes, fewer sweep points; CI)" if quick
            else "full (the numbers the README points to)")
    tally = ", ".join(f"{v} {k}" for k, v in sorted(counts.items()))
    parts = ["# fecheck validation report", "",
             ("Each result of the thesis (B. Istace, UCLouvain 2024) beside fecheck's number, "
              "the deviation and why they differ."), "",
             f"Mode: {mode}. Rows: {len(rows)} ({tally}). Total time {total_s:.0f} s.", "",
             CONVENTIONS,
             "## Summary", "", "| reference | row | status | time s |", "|---|---|---|---|"]
    for r in rows:
        parts.append(f"| {r.reference} | `{r.name}` | {r.status.replace('|', '/')} "
                     f"| {r.seconds:.1f} |")
    parts += ["", "## Rows", ""]
    parts += [row_markdown(r, out) for r in rows]
    return "\n".join(parts) + "\n"
