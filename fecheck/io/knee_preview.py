"""Preview of an imported knee at its rest pose (`fecheck knee import`): one PNG.

Four panels (matplotlib, Agg): a frontal section (plane y = y_c) and a sagittal section
through each tibial compartment's centroid, each drawing where the plane cuts the
femoral and tibial cartilage surfaces (and the bones, if given), and the tibial
compartments seen from above, coloured by their rest gap to the femoral surface (mm,
negative = overlap) with the 0 mm and `NEAR_MM` contours. Sections have equal aspect,
so a gap looks as wide as it is. Units: mm.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from fecheck.io.outputs import write_output

if TYPE_CHECKING:
    from geometry.mesh import TriMesh

NEAR_MM = 1.0
"""The gap contour drawn besides 0 mm (the import's "within 1 mm" area)."""
GAP_CAP_MM = 5.0
"""Upper end of the gap colour scale, mm (larger gaps take its end colour)."""
MARGIN_MM = 6.0
"""Margin around the cartilage in the section panels, mm."""
COLOURS = {"femur": "tab:blue", "tibia": "tab:red", "femur_bone": "tab:purple",
           "tibia_bone": "tab:orange"}
LABELS = {"femur": "femoral surface", "tibia": "tibial surface", "femur_bone": "femoral bone",
          "tibia_bone": "tibial bone"}
AXIS_NAMES = ("x", "y", "z")
TITLE_ROOM = 0.96
"""Share of the figure's width a title line may take."""


def middle_ellipsis(text: str, keep: int) -> str:
    """`text` cut to `keep` characters by an ellipsis in its middle (its start and end
    kept); unchanged if it is no longer.

    >>> middle_ellipsis("subject_0042_femoral_cartilage.stl", 15)
    'subject…age.stl'
    """
    if len(text) <= keep:
        return text
    head = keep // 2
    tail = keep - 1 - head
    return text[:head] + "…" + (text[len(text) - tail:] if tail > 0 else "")


def _halves(title: str) -> list[str]:
    """`title` split in two lines at the space nearest its middle (one line if none)."""
    spaces = [i for i, c in enumerate(title) if c == " "]
    if not spaces:
        return [title]
    cut = min(spaces, key=lambda i: abs(2 * i - len(title)))
    return [title[:cut], title[cut + 1:]]


def fit_title(fig, title: str, fontsize: float = 11):
    """Set `title` as `fig`'s suptitle within `TITLE_ROOM` of its width: on one line, or
    on two split at a space, each line too wide for the figure shortened in its middle
    (`middle_ellipsis`). Returns the title's Text."""
    text = fig.suptitle(title, fontsize=fontsize)
    renderer = fig.canvas.get_renderer()
    room = TITLE_ROOM * fig.bbox.width

    def width(line: str) -> float:
        text.set_text(line)
        return text.get_window_extent(renderer).width

    if width(title) <= room:
        return text
    lines = []
    for line in _halves(title):
        while (w := width(line)) > room and len(line) > 3:
            line = middle_ellipsis(line, min(len(line) - 1, int(len(line) * room / w)))
        lines.append(line)
    text.set_text("\n".join(lines))
    return text


def plane_section(mesh: TriMesh, axis: int, value: float) -> np.ndarray:
    """Segments (k, 2, 3) where the plane ``point[axis] = value`` cuts the faces, mm.

    A vertex on the plane counts as on its positive side, so every cut face has exactly
    two crossing edges (vectorised over the faces).
    """
    tri = mesh.triangles
    s = tri[:, :, axis] - value
    pos = s >= 0.0
    cut = pos.any(axis=1) & ~pos.all(axis=1)
    tri, s, pos = tri[cut], s[cut], pos[cut]
    nxt_tri, nxt_s = np.roll(tri, -1, axis=1), np.roll(s, -1, axis=1)
    crosses = pos != np.roll(pos, -1, axis=1)                 # edges (0,1), (1,2), (2,0)
    w = s / np.where(crosses, s - nxt_s, 1.0)
    points = tri + w[..., None] * (nxt_tri - tri)
    return points[crosses].reshape(-1, 2, 3)


def _section_panel(ax, title: str, axis: int, value: float, femur: TriMesh,
                   tibia: Mapping[str, TriMesh], bones: Mapping[str, TriMesh]) -> None:
    """Draw the cut of every surface by the plane ``point[axis] = value`` (mm)."""
    from matplotlib.collections import LineCollection

    u = 1 if axis == 0 else 0                   # horizontal coordinate: y (sagittal) or x
    cartilage = [("femur", femur)] + [("tibia", m) for m in tibia.values()]
    drawn = set()
    lo, hi = np.full(2, np.inf), np.full(2, -np.inf)
    for kind, mesh in [(f"{b}_bone", m) for b, m in bones.items()] + cartilage:
        seg = plane_section(mesh, axis, value)[..., [u, 2]]
        if not len(seg):
            continue
        bone = kind.endswith("_bone")
        ax.add_collection(LineCollection(seg, colors=COLOURS[kind],
                                         linewidths=0.9 if bone else 1.4,
                                         label=None if kind in drawn else LABELS[kind]))
        drawn.add(kind)
        if not bone:
            lo, hi = np.minimum(lo, seg.min(axis=(0, 1))), np.maximum(hi, seg.max(axis=(0, 1)))
    if np.all(np.isfinite(lo)):
        ax.set_xlim(lo[0] - MARGIN_MM, hi[0] + MARGIN_MM)
        ax.set_ylim(lo[1] - MARGIN_MM, hi[1] + MARGIN_MM)
    else:
        ax.text(0.5, 0.5, "the plane cuts no cartilage", transform=ax.transAxes,
                ha="center")
    ax.set_aspect("equal", adjustable="box")
    ax.set_title(title, fontsize=10)
    ax.set_xlabel(f"{AXIS_NAMES[u]}, mm" + (" (anterior →)" if u == 1 else " (right →)"))
    ax.set_ylabel("z, mm (superior)")
    ax.grid(True, lw=0.3, alpha=0.5)
    ax.legend(loc="best", fontsize=8, framealpha=0.8)


def _gap_panel(fig, ax, tibia: Mapping[str, TriMesh], gap_mm: Mapping[str, np.ndarray],
               centres: Mapping[str, np.ndarray], y_c: float) -> None:
    """The tibial compartments from above (+x right, +y up), coloured by the rest gap
    per face (the mean of its vertices' gaps, mm)."""
    from matplotlib import colormaps
    from matplotlib.colors import ListedColormap, Normalize, TwoSlopeNorm

    low = min(float(g.min()) for g in gap_mm.values())
    high = max(float(g.max()) for g in gap_mm.values())
    vmax = min(max(high, NEAR_MM), GAP_CAP_MM)
    cmap = colormaps["RdBu"]
    if low < -0.01:        # overlaps red, gaps blue, white at 0 mm
        norm = TwoSlopeNorm(vcenter=0.0, vmin=low, vmax=vmax)
    else:                  # no overlap: the blue half alone
        norm, cmap = Normalize(0.0, vmax), ListedColormap(cmap(np.linspace(0.5, 1.0, 128)))
    image = None
    for name, mesh in tibia.items():
        x, y, tri = mesh.points[:, 0], mesh.points[:, 1], mesh.faces
        g = gap_mm[name]
        image = ax.tripcolor(x, y, tri, facecolors=g[tri].mean(axis=1), cmap=cmap,
                             norm=norm, edgecolors="none")
        ax.tricontour(x, y, tri, g, levels=[0.0, NEAR_MM], colors=["k", "0.35"],
                      linewidths=[1.0, 0.7], linestyles=["solid", "dashed"])
        cx, cy = centres[name][:2]
        ax.axvline(cx, color="0.3", lw=0.6, ls=":")
        ax.text(cx, float(y.max()) + 1.0, name, ha="center", va="bottom", fontsize=10,
                weight="bold")
    ax.axhline(y_c, color="0.3", lw=0.6, ls=":")
    ax.set_aspect("equal", adjustable="datalim")
    ax.margins(x=0.06, y=0.12)
    ax.set_title(f"rest gap to the femur, tibia from above\n(solid: 0 mm, dashed: "
                 f"{NEAR_MM:g} mm; dotted: section planes)", fontsize=10)
    ax.set_xlabel("x, mm (right →)")
    ax.set_ylabel("y, mm (anterior ↑)")
    bar = fig.colorbar(image, ax=ax, extend="max" if high > vmax else "neither",
                       shrink=0.85, format="%g")
    ticks = np.arange(0.0, vmax + 1e-9, 1.0 if vmax > 2 else 0.25 * vmax)
    bar.set_ticks(np.r_[np.ceil(low * 100) / 100, ticks] if low < -0.01 else ticks)
    bar.set_label("rest gap, mm (< 0: overlap)")


def write_knee_preview(path: str | Path, femur: TriMesh, tibia: Mapping[str, TriMesh],
                       gap_mm: Mapping[str, np.ndarray],
                       bones: Mapping[str, TriMesh] | None = None, title: str = "") -> Path:
    """Write the preview PNG (module docstring) to `path`; returns the path.

    Parameters
    ----------
    femur : femoral articular surface, mm
    tibia : {medial, lateral} tibial compartments, mm
    gap_mm : per tibial vertex, its signed rest gap to the femoral surface, mm
        (+ gap, - overlap)
    bones : optional {femur, tibia} bone surfaces, drawn in the sections in a colour each
        (`COLOURS`), named in the legend
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    bones = dict(bones or {})
    centres = {c: np.average(m.face_centroids, axis=0, weights=m.face_areas)
               for c, m in tibia.items()}
    y_c = float(np.mean([c[1] for c in centres.values()]))
    fig, axes = plt.subplots(2, 2, figsize=(13, 9.5), layout="constrained",
                             height_ratios=(1.0, 1.3))
    _section_panel(axes[0, 0], f"frontal section y = {y_c:.1f} mm (viewed from behind)",
                   1, y_c, femur, tibia, bones)
    _gap_panel(fig, axes[0, 1], tibia, gap_mm, centres, y_c)
    for ax, (name, centre) in zip(axes[1], centres.items(), strict=True):
        _section_panel(ax, f"sagittal section x = {centre[0]:.1f} mm ({name}; viewed from +x)", 0,
                       float(centre[0]), femur, {name: tibia[name]}, bones)
    if title:
        fit_title(fig, title)
    path = Path(path)
    write_output(path, lambda tmp: fig.savefig(tmp, dpi=110))
    plt.close(fig)
    return path
