"""Run the validation rows (`fecheck.studies.thesis`, ``row_*``) in-process and write the
report.

Each row module exposes ``rows(quick: bool, out: Path) -> list[Row]`` (see
`fecheck.studies.thesis.report`). `run_validation` runs the selected ones, times them,
prints progress on stderr, and writes ``OUT/report.md`` with the conventions, a summary
and one section per row. A module that fails to import or raises becomes a "failed" row;
the report is always written. The rows ship with the package: an installed wheel runs
them as a checkout does.
"""

from __future__ import annotations

import importlib
import pkgutil
import re
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from fecheck.errors import FecheckError
from fecheck.io.outputs import write_output
from fecheck.studies import thesis
from fecheck.studies.thesis.report import Row, row_markdown

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


def discover() -> dict[str, str]:
    """Row modules of `fecheck.studies.thesis`: name (module name without ``row_``) →
    module, sorted by name."""
    names = sorted(m.name for m in pkgutil.iter_modules(thesis.__path__)
                   if m.name.startswith(SCRIPT_PREFIX))
    return {n[len(SCRIPT_PREFIX):]: f"{thesis.__name__}.{n}" for n in names}


def select(scripts: dict[str, str], only: Sequence[str] | None) -> dict[str, str]:
    """The rows named in `only` (all when empty); unknown names raise FecheckError."""
    if not only:
        return scripts
    unknown = [n for n in only if n not in scripts]
    if unknown:
        raise FecheckError(f"unknown validation row(s) {', '.join(unknown)}; "
                           f"choose from: {', '.join(scripts)}")
    return {n: scripts[n] for n in scripts if n in only}


def run_validation(out: Path, quick: bool = False, only: Sequence[str] | None = None,
                   log=None, scripts: dict[str, str] | None = None) -> tuple[Path, list]:
    """Run the selected rows; write ``out/report.md``; return (report path, rows).

    `scripts` (name → module) defaults to `discover()`; progress goes to `log` (default:
    standard error)."""
    log = sys.stderr if log is None else log
    scripts = select(discover() if scripts is None else scripts, only)
    out = Path(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise FecheckError(f"cannot create the output folder {out}: {err.strerror}") from None
    rows, total = _run_rows(scripts, quick, out, log)
    text = render(rows, quick, total, out)
    report = out / "report.md"
    write_output(report, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    print(f"wrote {report} ({len(rows)} rows, {total:.0f} s)", file=log, flush=True)
    return report, rows


def _run_rows(scripts: dict[str, str], quick: bool, out: Path, log) -> tuple[list, float]:
    """Each module's rows (a failing one becomes a "failed" row) and the total time, s."""
    rows = []
    t_all = time.perf_counter()
    for i, (name, module) in enumerate(scripts.items(), 1):
        print(f"[{i}/{len(scripts)}] {name} ...", file=log, flush=True)
        t0 = time.perf_counter()
        try:
            got = list(importlib.import_module(module).rows(quick, out))
        except Exception as err:  # noqa: BLE001 - one failing module must not stop the report
            got = [Row(name, f"module {module}", module,
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


def render(rows: list, quick: bool, total_s: float, out: Path) -> str:
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
