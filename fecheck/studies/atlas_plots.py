"""Pictures of an EF error atlas: the predicted error over pairs of keys (the other keys
at their medians) with the tolerance's contour and the FE design points, and the partial
dependence of each error on each key."""

from __future__ import annotations

from collections.abc import Sequence
from itertools import combinations
from pathlib import Path

import numpy as np

from fecheck.io.outputs import write_output
from fecheck.studies.atlas import OUTPUTS, ErrorModel, partial_dependence
from fecheck.studies.population import Plan
from fecheck.studies.population_inputs import Varied

GRID = 41
MAX_PAIRS = 15


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> Path:
    write_output(path, lambda tmp: fig.savefig(tmp, dpi=110))
    _pyplot().close(fig)
    return path


def _values(v: Varied, u: np.ndarray) -> np.ndarray:
    return v.drawn(u)


def error_maps(out: Path, varied: Sequence[Varied], model: ErrorModel, u_fe: np.ndarray,
               tolerance: float, output: str = "p_max") -> Path:
    """The predicted `output` error over each pair of keys (others at u = 0.5)."""
    plt = _pyplot()
    pairs = list(combinations(range(len(varied)), 2))[:MAX_PAIRS]
    cols = min(3, len(pairs))
    rows = -(-len(pairs) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.4 * cols, 3.6 * rows), squeeze=False)
    g = np.linspace(0.0, 1.0, GRID)
    limit = 2.0 * tolerance
    for ax, (a, b) in zip(axes.flat, pairs, strict=False):
        ua, ub = np.meshgrid(g, g)
        u = np.full((GRID * GRID, len(varied)), 0.5)
        u[:, a], u[:, b] = ua.ravel(), ub.ravel()
        mean = model.models[output].predict(u).reshape(GRID, GRID)
        xa, xb = _values(varied[a], g), _values(varied[b], g)
        im = ax.pcolormesh(xa, xb, mean, cmap="RdBu_r", vmin=-limit, vmax=limit,
                           shading="auto")
        ax.contour(xa, xb, np.abs(mean), levels=[tolerance], colors="k", linewidths=1.2)
        ax.plot(_values(varied[a], u_fe[:, a]), _values(varied[b], u_fe[:, b]), "k.", ms=4)
        ax.set_xlabel(varied[a].column(), fontsize=8)
        ax.set_ylabel(varied[b].column(), fontsize=8)
        ax.tick_params(labelsize=7)
        fig.colorbar(im, ax=ax, shrink=0.85).ax.tick_params(labelsize=7)
    for ax in list(axes.flat)[len(pairs):]:
        ax.set_visible(False)
    fig.suptitle(f"EF error in {output} (EF/FE − 1) predicted by the error model\n"
                 f"black line: ±{tolerance:g}; dots: FE design points; other keys at their "
                 "medians", fontsize=9)
    fig.tight_layout()
    return _save(fig, out / f"atlas_map_{output}.png")


def dependence(out: Path, varied: Sequence[Varied], model: ErrorModel, u: np.ndarray,
               tolerance: float) -> Path:
    """Partial dependence of every error (rows) on every key (columns)."""
    plt = _pyplot()
    d = len(varied)
    outputs = [o for o in OUTPUTS if o in model.models]
    fig, axes = plt.subplots(len(outputs), d, figsize=(2.7 * d + 0.6, 2.0 * len(outputs) + 0.6),
                             squeeze=False)
    g = np.linspace(0.0, 1.0, 15)
    sub = u[:: max(1, len(u) // 200)]
    for j, v in enumerate(varied):
        pd = partial_dependence(model, sub, j, g)
        for r, name in enumerate(outputs):
            ax = axes[r, j]
            ax.plot(_values(v, g), pd[name], "-", color="tab:blue")
            if name != "cop_mm":
                ax.axhspan(-tolerance, tolerance, color="tab:green", alpha=0.15)
            if r == len(outputs) - 1:
                ax.set_xlabel(v.column(), fontsize=8)
            if j == 0:
                ax.set_ylabel(name + (" (mm)" if name == "cop_mm" else ""), fontsize=8)
            ax.tick_params(labelsize=7)
    fig.suptitle(f"partial dependence of the EF's errors (green: ±{tolerance:g})", fontsize=9)
    fig.tight_layout()
    return _save(fig, out / "atlas_dependence.png")


def write(out: Path, varied: Sequence[Varied], model: ErrorModel, plan: Plan,
          u_fe: np.ndarray, tolerance: float) -> list[Path]:
    """Every atlas picture (error maps need two keys)."""
    out = Path(out)
    paths = [dependence(out, varied, model, plan.u, tolerance)]
    if len(varied) >= 2:
        paths.insert(0, error_maps(out, varied, model, u_fe, tolerance))
    return paths
