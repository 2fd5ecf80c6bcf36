"""The one layout helper of the validation rows: a `Row` per thesis table or figure.

A row compares quantities: the thesis's value, fecheck's value and the deviation
(100·(fecheck − thesis)/thesis, %), and, where the thesis counted whole faces (its
Fig. 3.20), fecheck's whole-face value beside the exact one. A row has a status:

* ``reproduced``: every deviation within the row's stated tolerance;
* ``deviates, explained``: numbers given, the deviation and its reason stated;
* ``cannot be reproduced``: the thesis's number cannot be recomputed (why is said);
* ``skipped: …`` / ``failed: …``: a piece is missing, or the script raised.

`guarded` runs one row's function and turns a missing piece (`Missing`) or any error
into a skipped/failed row, so one broken row never stops the report. Plots use
matplotlib's Agg backend, imported lazily. Units: mm, N, MPa, N·mm, s.
"""

from __future__ import annotations

import argparse
import csv
import math
import time
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

from fecheck.scene import lenhart
from geometry.files import write_output

REPRODUCED = "reproduced"
DEVIATES = "deviates, explained"
CANNOT = "cannot be reproduced"


class Missing(Exception):
    """A piece a row needs is absent: an optional package or the scanned-knee data set."""


@dataclass(frozen=True)
class Line:
    """One compared quantity (units in `quantity`, e.g. "medial force N").

    thesis : the thesis's number (None when it gives none)
    fecheck : fecheck's exact value (None when not computed)
    whole_face : fecheck's value with the thesis's whole-face area counting, or None
    compare : False when a deviation % would be meaningless (zeros, bounds)
    """

    quantity: str
    thesis: float | None
    fecheck: float | None
    note: str = ""
    whole_face: float | None = None
    compare: bool = True

    @property
    def deviation_pct(self) -> float | None:
        """100·(fecheck − thesis)/thesis, %, or None (also when `compare` is False:
        values that are round-off of zero, or a bound rather than a value)."""
        return _deviation(self.fecheck, self.thesis) if self.compare else None

    @property
    def whole_face_deviation_pct(self) -> float | None:
        """100·(whole_face − thesis)/thesis, %, or None."""
        return _deviation(self.whole_face, self.thesis) if self.compare else None


def _deviation(value: float | None, reference: float | None) -> float | None:
    if value is None or reference is None or reference == 0:
        return None
    if not (math.isfinite(value) and math.isfinite(reference)):
        return None
    return 100.0 * (value - reference) / reference


@dataclass(frozen=True)
class Row:
    """One thesis table or figure, compared.

    name : short id used by ``--only`` and file names, e.g. "table_5_1"
    title : what is compared; reference : "Table 5.1", "Fig. 3.3", …
    status : REPRODUCED, DEVIATES, CANNOT, or "skipped: why" / "failed: why"
    lines : the compared quantities; note : why fecheck differs (markdown)
    csv : the row's CSV files; png : its pictures; seconds : wall time of the row
    """

    name: str
    title: str
    reference: str
    status: str
    lines: tuple[Line, ...] = ()
    note: str = ""
    csv: tuple[Path, ...] = ()
    png: tuple[Path, ...] = ()
    seconds: float = 0.0
    extra: dict = field(default_factory=dict)

    def line(self, quantity: str) -> Line:
        """The line named `quantity` (KeyError if absent)."""
        for ln in self.lines:
            if ln.quantity == quantity:
                return ln
        raise KeyError(f"{self.name}: no line {quantity!r}")


def status_within(lines: Sequence[Line], tolerance_pct: float) -> str:
    """REPRODUCED when every exact deviation is within ±`tolerance_pct`, else DEVIATES."""
    devs = [abs(ln.deviation_pct) for ln in lines if ln.deviation_pct is not None]
    return REPRODUCED if devs and max(devs) <= tolerance_pct else DEVIATES


def guarded(name: str, title: str, reference: str, out: Path,
            build: Callable[[], Row]) -> Row:
    """Run `build()` (which returns the finished row), timing it; a `Missing` piece gives
    a "skipped: …" row and any other exception a "failed: …" row with the last frame."""
    t0 = time.perf_counter()
    try:
        row = build()
    except Missing as why:
        row = Row(name, title, reference, f"skipped: {why}")
    except Exception as err:  # noqa: BLE001 - a failing row must not stop the report
        where = traceback.extract_tb(err.__traceback__)[-1]
        row = Row(name, title, reference,
                  f"failed: {type(err).__name__}: {err} ({Path(where.filename).name}:"
                  f"{where.lineno})")
    return replace(row, seconds=time.perf_counter() - t0)


def require(module: str, owner: str):
    """Import an optional third-party package (python-fcl, pyamg, sfepy), or raise
    `Missing` naming it and how to install it.

    fecheck's own modules are imported directly: a missing one is a broken row, not a
    skipped one (ValueError here)."""
    import importlib

    if module.split(".")[0] == "fecheck":
        raise ValueError(f"import {module} directly: require() is for optional packages")
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as err:
        if err.name not in (module, module.split(".")[0]):  # it is there, but broken
            raise
        raise Missing(f"{module} is not installed ({owner})") from None


def require_knee_data():
    """The scanned-knee folder (`lenhart.knee_dir`), or raise `Missing` saying where it
    was looked for (the packaged one, or $FECHECK_KNEE_DIR)."""

    try:
        return lenhart.knee_dir()
    except Exception as err:  # noqa: BLE001 - FecheckError naming the folder
        raise Missing(str(err)) from None


def knee_scene(name: str) -> str:
    """`name`, a scene of ``validation/scenes`` on the scanned knee, once the knee data set
    is there (else `Missing`); a missing scene file fails where the scene is loaded."""
    require_knee_data()
    return name


def knee_script_args(description: str, quick_help: str, argv: Sequence[str] | None
                     ) -> argparse.Namespace | None:
    """``--quick`` and ``--out`` of a scanned-knee validation script, or None after
    printing why it is skipped when the knee data set (outside the repository) is absent."""
    p = argparse.ArgumentParser(description=description)
    p.add_argument("--quick", action="store_true", help=quick_help)
    p.add_argument("--out", type=Path, default=Path("out/validation"), help="output folder")
    args = p.parse_args(argv)
    try:
        require_knee_data()
    except Missing as err:
        print(f"skipped: {err}")
        return None
    return args


def _fmt(x: float | None) -> str:
    if x is None:
        return "–"
    if isinstance(x, str):
        return x
    if not math.isfinite(x):
        return "nan"
    if x != 0 and (abs(x) >= 1e5 or abs(x) < 1e-3):
        return f"{x:.3g}"
    return f"{x:.4g}" if abs(x) < 100 else f"{x:.2f}"


def _pct(x: float | None) -> str:
    return "–" if x is None else f"{x:+.2f}"


def has_whole_face(lines: Sequence[Line]) -> bool:
    """True if any line carries a whole-face value."""
    return any(ln.whole_face is not None for ln in lines)


def table_markdown(lines: Sequence[Line]) -> str:
    """The lines as a markdown table (whole-face columns only when present)."""
    wf = has_whole_face(lines)
    head = ["quantity", "thesis", "fecheck", "dev %"]
    if wf:
        head += ["fecheck whole-face", "dev %"]
    head.append("note")
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for ln in lines:
        cells = [ln.quantity.replace("|", "\\|"), _fmt(ln.thesis), _fmt(ln.fecheck),
                 _pct(ln.deviation_pct)]
        if wf:
            cells += [_fmt(ln.whole_face), _pct(ln.whole_face_deviation_pct)]
        cells.append(ln.note.replace("|", "/"))
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


def write_lines_csv(lines: Sequence[Line], path: Path) -> Path:
    """Write the compared lines to `path` (CSV; empty cells where a value is absent)."""
    def write(tmp: Path) -> None:
        with open(tmp, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["quantity", "thesis", "fecheck", "deviation_pct", "fecheck_whole_face",
                        "whole_face_deviation_pct", "note"])
            for ln in lines:
                w.writerow([ln.quantity, _csv(ln.thesis), _csv(ln.fecheck),
                            _csv(ln.deviation_pct), _csv(ln.whole_face),
                            _csv(ln.whole_face_deviation_pct), ln.note])

    return write_output(path, write)


def write_data_csv(path: Path, columns: dict[str, Sequence[float]]) -> Path:
    """Write equal-length columns (name with unit → values) to `path` as CSV."""
    names = list(columns)
    n = len(columns[names[0]])

    def write(tmp: Path) -> None:
        with open(tmp, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(names)
            for i in range(n):
                w.writerow([_csv(columns[k][i]) for k in names])

    return write_output(path, write)


def _csv(x) -> str:
    if x is None:
        return ""
    if isinstance(x, str):
        return x
    x = float(x)
    return "nan" if not math.isfinite(x) else repr(round(x, 10))


def figure(ncols: int = 1, width: float = 6.4, height: float = 4.4):
    """A new matplotlib figure (Agg) with `ncols` axes side by side: (fig, axes list)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, ncols, figsize=(width * ncols, height), squeeze=False)
    return fig, list(axes[0])


def save_figure(fig, path: Path) -> Path:
    """Save `fig` as a PNG at `path` and close it."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    write_output(path, lambda tmp: fig.savefig(tmp, dpi=110, bbox_inches="tight"))
    plt.close(fig)
    return path


def deviation_png(row_name: str, reference: str, lines: Sequence[Line], path: Path) -> Path:
    """Bar chart of each quantity's deviation from the thesis, %, exact and whole-face."""
    import numpy as np

    shown = [ln for ln in lines if ln.deviation_pct is not None
             or ln.whole_face_deviation_pct is not None]
    fig, (ax,) = figure(height=max(2.6, 0.32 * len(shown) + 1.4))
    y = np.arange(len(shown))
    exact = [ln.deviation_pct if ln.deviation_pct is not None else np.nan for ln in shown]
    wf = has_whole_face(shown)
    h = 0.4 if wf else 0.7
    ax.barh(y - (h / 2 if wf else 0), exact, height=h, color="tab:blue",
            label="fecheck (exact, clipped faces)" if wf else "fecheck")
    if wf:
        whole = [ln.whole_face_deviation_pct if ln.whole_face_deviation_pct is not None
                 else np.nan for ln in shown]
        ax.barh(y + h / 2, whole, height=h, color="tab:orange",
                label="fecheck, whole-face counting (thesis Fig. 3.20)")
    ax.axvline(0.0, color="k", lw=0.8)
    biggest = np.nanmax(np.abs(np.r_[exact, whole if wf else []]))
    span = 1.1 * max(1.0, biggest if np.isfinite(biggest) else 1.0)
    ax.set_xlim(-span, span)
    ax.set_yticks(y, [ln.quantity for ln in shown], fontsize=8)
    ax.invert_yaxis()
    ax.set_xlabel("deviation from the thesis, %")
    ax.grid(axis="x", alpha=0.3)
    ax.legend(fontsize=8, loc="lower center", bbox_to_anchor=(0.5, 1.0), frameon=False)
    ax.set_title(f"{reference}: fecheck against the thesis", pad=14 + (26 if wf else 14))
    return save_figure(fig, path)


def table_row(name: str, title: str, reference: str, lines: Sequence[Line], out: Path,
              status: str, note: str, extra_png: Sequence[Path] = (),
              extra_csv: Sequence[Path] = ()) -> Row:
    """A finished row: writes ``out/name.csv`` and, unless the row brings its own figure
    (`extra_png`), ``out/name.png`` charting the deviations."""
    lines = tuple(lines)
    csv_path = write_lines_csv(lines, out / f"{name}.csv")
    png = (deviation_png(name, reference, lines, out / f"{name}.png"),) if not extra_png and any(
        ln.deviation_pct is not None or ln.whole_face_deviation_pct is not None
        for ln in lines) else ()
    return Row(name, title, reference, status, lines, note, (csv_path, *extra_csv),
               (*png, *extra_png))


def row_markdown(row: Row, out: Path) -> str:
    """The markdown section of one row (files linked relative to `out`)."""
    parts = [f"### {row.reference}: {row.title}", "",
             f"**Status:** {row.status}  ", f"`{row.name}` — {row.seconds:.1f} s", ""]
    if row.lines:
        parts += [table_markdown(row.lines), ""]
    if row.note:
        parts += [row.note, ""]
    for p in row.png:
        parts.append(f"![{row.reference}]({_rel(p, out)})")
    if row.png:
        parts.append("")
    if row.csv:
        parts.append("Data: " + ", ".join(f"[{Path(p).name}]({_rel(p, out)})" for p in row.csv))
        parts.append("")
    return "\n".join(parts)


def _rel(p: Path, out: Path) -> str:
    try:
        return str(Path(p).resolve().relative_to(out.resolve()))
    except ValueError:
        return str(p)


def main_for(rows_fn: Callable[[bool, Path], list[Row]], argv: Sequence[str] | None = None
             ) -> int:
    """The command line every row script shares (``validation/row_*.py`` pass their
    module's ``rows``): ``[--quick] [--out DIR]``; prints each row. Exit status 1 when a
    row failed (a skipped row is not a failure)."""
    p = argparse.ArgumentParser(description="Reproduce thesis rows; writes CSV/PNG to --out.")
    p.add_argument("--quick", action="store_true", help="reduced meshes and sweeps")
    p.add_argument("--out", type=Path, default=Path("out/validation"), help="output folder")
    args = p.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    rows = rows_fn(args.quick, args.out)
    for row in rows:
        print(row_markdown(row, args.out))
    return 1 if any(row.status.startswith("failed") for row in rows) else 0
