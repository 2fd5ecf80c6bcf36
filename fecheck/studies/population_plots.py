"""Pictures of a population study: histograms of the outputs, a tornado chart of the
Sobol indices and scatter plots of each output against each key (PNG, matplotlib)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from fecheck.io.outputs import write_output
from fecheck.studies.population import Plan, Sample, output_matrix
from fecheck.studies.sobol import Indices


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> Path:
    write_output(path, lambda tmp: fig.savefig(tmp, dpi=110))
    _pyplot().close(fig)
    return path


def _grid(n: int) -> tuple[int, int]:
    cols = min(n, 3)
    return math.ceil(n / cols), cols


def histograms(plan: Plan, samples: dict[int, Sample], outputs: Sequence[str],
               out: Path) -> Path:
    """One histogram per output (converged samples), its 5/50/95 % quantiles marked."""
    plt = _pyplot()
    rows, cols = _grid(len(outputs))
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.3 * rows), squeeze=False)
    for ax, name in zip(axes.flat, outputs, strict=False):
        y = output_matrix(plan, samples, name)
        y = y[np.isfinite(y)]
        ax.hist(y, bins=max(10, min(60, int(np.sqrt(y.size)))), color="tab:blue", alpha=0.8)
        for q in np.percentile(y, [5, 50, 95]) if y.size else ():
            ax.axvline(q, color="k", lw=0.8, ls="--")
        ax.set_xlabel(name)
        ax.set_ylabel("samples")
        ax.set_title(f"{name} (n = {y.size})", fontsize=9)
    for ax in list(axes.flat)[len(outputs):]:
        ax.set_visible(False)
    fig.suptitle("population: outputs (dashed: 5, 50, 95 %)", fontsize=10)
    fig.tight_layout()
    return _save(fig, out / "population_histograms.png")


def tornado(indices: dict[str, Indices], out: Path) -> Path:
    """Per output, the total (ST) and first-order (S1) Sobol index of each key, sorted by
    ST, with their bootstrap intervals."""
    plt = _pyplot()
    names = list(indices)
    rows, cols = _grid(len(names))
    d = len(next(iter(indices.values())).names)
    fig, axes = plt.subplots(rows, cols, figsize=(4.8 * cols, 0.5 * d * rows + 1.6 * rows),
                             squeeze=False)
    for ax, name in zip(axes.flat, names, strict=False):
        idx = indices[name]
        order = np.argsort(idx.st)
        y = np.arange(len(order))
        ax.barh(y + 0.18, idx.st[order], 0.36, xerr=idx.st_conf[order], color="tab:red",
                label="total ST")
        ax.barh(y - 0.18, idx.s1[order], 0.36, xerr=idx.s1_conf[order], color="tab:blue",
                label="first-order S1")
        ax.set_yticks(y, [idx.names[i] for i in order], fontsize=8)
        ax.set_xlim(min(-0.05, float(np.min(idx.s1 - idx.s1_conf))),
                    max(1.05, float(np.max(idx.st + idx.st_conf))))
        ax.axvline(0.0, color="k", lw=0.6)
        ax.set_title(f"{name} ({idx.groups} base rows)", fontsize=9)
        ax.legend(fontsize=7, loc="lower right")
    for ax in list(axes.flat)[len(names):]:
        ax.set_visible(False)
    fig.suptitle("Sobol indices (bars: 95 % bootstrap intervals)", fontsize=10)
    fig.tight_layout()
    return _save(fig, out / "population_tornado.png")


def scatter(plan: Plan, samples: dict[int, Sample], outputs: Sequence[str],
            out: Path) -> Path:
    """Each output (rows) against each key's drawn value (columns)."""
    plt = _pyplot()
    drawn = plan.drawn()
    d, m = len(plan.varied), len(outputs)
    fig, axes = plt.subplots(m, d, figsize=(2.8 * d + 0.6, 2.3 * m + 0.6), squeeze=False)
    size = 4 if plan.runs > 2000 else 9
    for r, name in enumerate(outputs):
        y = output_matrix(plan, samples, name)
        ok = np.isfinite(y)
        for c, v in enumerate(plan.varied):
            ax = axes[r, c]
            ax.scatter(drawn[ok, c], y[ok], s=size, alpha=0.35, lw=0, color="tab:blue")
            if r == m - 1:
                ax.set_xlabel(f"{v.column()}" + (f" ({v.unit})" if v.unit else ""), fontsize=8)
            if c == 0:
                ax.set_ylabel(name, fontsize=8)
            ax.tick_params(labelsize=7)
    fig.suptitle("population: outputs against the varied keys", fontsize=10)
    fig.tight_layout()
    return _save(fig, out / "population_scatter.png")
