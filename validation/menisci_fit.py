"""The menisci fitted to the joint (``menisci.fit``), before and after: vertical gap maps
and volumes.

For each meniscus of the scene, at the touching pose (`fecheck.model.menisci_shape`):
the vertical gap from its inferior articular surface down to the tibial cartilage and
from its superior surface up to the femoral cartilage (mm, + open, − overlap), on an
x-y grid of 0.25 mm, as shipped and fitted; the volume of each; the area within 0.1 mm.
Draws the eight maps (``--png``). Units: mm, mm², mm³.

    python validation/menisci_fit.py [--quick] [--set KEY=VALUE ...] [--png PATH]

--quick: the knee's sheets decimated to 1,500 faces (scanned.decimate_faces), in seconds.
"""

from __future__ import annotations

import argparse

import numpy as np

from fecheck.model import menisci
from fecheck.model.menisci_shape import vertical_height
from fecheck.model.scanned import tibial_slaves
from fecheck.scene import load_scene, with_values
from fecheck.scene.surfaces import read_surface
from geometry.mesh import TriMesh

STEP_MM = 0.25


def gap_maps(scene, side: str, shape, femur: TriMesh) -> dict:
    """{"x", "y", "inferior", "superior"}: the grid (mm) and the vertical gaps (mm, NaN
    off the surface) of `shape`'s articular surfaces to the tibial and femoral cartilage."""
    folder = menisci.menisci_dir(scene)
    sheets = {face: shape.sheet(read_surface(
        folder / menisci.VOLUME.format(side=f"{side}_{face}"))) for face in
        ("inferior", "superior")}
    lo = shape.shipped.points[:, :2].min(axis=0) - 1.0
    hi = shape.shipped.points[:, :2].max(axis=0) + 1.0
    gx, gy = np.meshgrid(np.arange(lo[0], hi[0], STEP_MM), np.arange(lo[1], hi[1], STEP_MM))
    xy = np.column_stack([gx.ravel(), gy.ravel()])
    tibia = tibial_slaves(scene)[side]
    inf = vertical_height(sheets["inferior"], xy, False) - vertical_height(tibia, xy, True)
    sup = vertical_height(femur, xy, False) - vertical_height(sheets["superior"], xy, True)
    return {"x": gx, "y": gy, "inferior": inf.reshape(gx.shape),
            "superior": sup.reshape(gx.shape)}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", action="append", default=[], dest="sets")
    parser.add_argument("--png", default="")
    parser.add_argument("--quick", action="store_true",
                        help="the knee's sheets decimated to 1,500 faces")
    args = parser.parse_args(argv)
    quick = ["scanned.decimate_faces=1500"] if args.quick else []
    scene = load_scene("femur_tibia_menisci", [*quick, *args.sets])
    femur = menisci._touching(scene, menisci.menisci_dir(scene))
    cells = STEP_MM ** 2
    maps = {}
    for fit in ("as-shipped", "fitted"):
        shapes = menisci.shapes(with_values(scene, menisci__fit=fit))
        for side, shape in shapes.items():
            m = gap_maps(scene, side, shape, femur)
            maps[(side, fit)] = m
            line = [f"{side:7} {fit:10} volume {shape.volume.signed_volume:7.1f} mm³"]
            for face in ("inferior", "superior"):
                g = m[face][np.isfinite(m[face])]
                near = cells * (np.abs(g) <= 0.1).sum()
                line.append(f"{face}: gap median {np.median(g):+.2f}, min {g.min():+.2f}, "
                            f"max {g.max():+.2f} mm, within 0.1 mm {near:.0f} of "
                            f"{cells * len(g):.0f} mm²")
            print("; ".join(line))
    if args.png:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(2, 4, figsize=(16, 8), constrained_layout=True)
        for row, side in enumerate(("medial", "lateral")):
            for col, (fit, face) in enumerate([(f, s) for s in ("inferior", "superior")
                                               for f in ("as-shipped", "fitted")]):
                ax = axes[row, col]
                m = maps.get((side, fit))
                if m is None:
                    ax.set_axis_off()
                    continue
                im = ax.pcolormesh(m["x"], m["y"], m[face], cmap="RdBu", vmin=-2.0, vmax=2.0,
                                   shading="auto")
                ax.set_aspect("equal")
                ax.set_title(f"{side} {face} gap, {fit}")
                ax.set_xlabel("x mm")
                ax.set_ylabel("y mm")
        fig.colorbar(im, ax=axes, label="vertical gap to the cartilage, mm (+ open, − overlap)")
        fig.savefig(args.png, dpi=80)
        print(f"wrote {args.png}")


if __name__ == "__main__":
    main()
