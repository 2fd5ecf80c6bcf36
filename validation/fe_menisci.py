"""The FE of the knee with menisci at the EF equilibrium of ``femur_tibia_menisci`` (800 N,
full extension), beside the EF and Donahue et al. 2002.

`fecheck.fe.knee.knee_menisci`: each meniscus a deformable transversely isotropic solid (P2
tetrahedra, fibres along its arc) on horn springs to the tibia, each compartment's tibial
cartilage a bonded layer as ``fecheck fe`` builds it and the femoral cartilage a layer of
its own bonded to the femur (the scene's ``fe.cartilage = "two-layer"``; ``--cartilage
series``: one tibial layer of both cartilages' thickness, the femoral cartilage rigid over
the menisci), the femur rigid,
its translation along the tibial z axis and its abduction (the tibia's free DOFs) solved
under the EF's load on the tibia (800 N less the tibia's weight) and its moment about the
tibia's origin, frictionless contact on the three interfaces (``--hold-rotation``: the
femur kept at the EF's rotation, for comparison). Per compartment: the axial load into
the tibia through the meniscus (its contact and its horn springs) and through
cartilage-cartilage contact, the meniscal share, the tibial contact area and vertex
p_max; then the femur's balance along its axis, its turn from the EF pose and its moment
balance, each meniscus's balance, the worst penetration over every contact vertex, dofs
and time.

Beside them: the same FE without the menisci (``menisci.sides = []``, at that scene's own
EF pose, on the same tibial layers), the EF of the same scene (menisci rigid, smith2019's
lumped 1 MPa meniscus layer), Donahue et al. 2002's tibial contact area and p_max at
800 N (490 / 415 mm², 2.55 / 2.36 MPa medial / lateral, thesis Tables 5.7a-5.8a: another
knee), and the meniscal
share usually quoted for intact cadaver knees near full extension, about 50 % medially
and 70 % laterally (Seedhom & Hargreaves 1979, Eng. Med. 8:220-228; Walker & Erkman
1975, Clin. Orthop. 109:184-192: at least half of the load; quoted, not re-derived).

Why the share is what it is: per meniscus the area of its superior surface the femur
presses and the area within 0.1 / 0.5 / 1 mm of the femur at the loaded pose, beside the
deepest compression of the tibial cartilage under the femur (how far the femur comes
down), the radial displacement of the meniscus body (arc 0.25-0.75, + outward) and the
horn springs' load; the hoop force through sections at arc 0.1-0.9 (0 anterior tip, 1
posterior). Then one factor at a time from that run (the EF pose kept): the superior
surface raised 0.1 / 0.25 / 0.5 mm (the wedge thicker: sensitivity to placement), the
tibial cartilage modulus halved and doubled, the data's coronary ligaments added as
springs, Donahue's 2000 N/mm horn roots; the table gives the share per compartment and
its change, and names the factor that moves it most.

    python validation/fe_menisci.py [--quick] [--factors] [--root data|donahue]
        [--hold-rotation] [--cartilage two-layer|series] [--out DIR]

--quick: the sheets decimated to 1500 faces (``scanned.decimate_faces``: two deformable
layers are extruded from the sheets as read; with ``--cartilage series`` the tibial sheets
remeshed at 2 mm, ``fe.prepare = "on"``, ``fe.size_mm = 2``) and 2.5 mm meniscus
tetrahedra, without the factor table unless --factors. Writes DIR/fe_menisci.csv (the
loads), DIR/fe_menisci_regions.csv (per compartment the tibial contact under the
cartilage-cartilage contact and under each meniscus region: anterior horn, body,
posterior horn), DIR/fe_menisci_hoop.csv (hoop force per section),
DIR/fe_menisci_factors.csv and DIR/fe_menisci_pressure.png (the tibial pressure of
cartilage and meniscus contact, with each meniscus's footprint outlined).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

import numpy as np

from fecheck.errors import FecheckError
from fecheck.fe.bodies.meniscus_solid import DEFAULT_SIZE_MM
from fecheck.fe.bodies.settings import CARTILAGE
from fecheck.fe.knee.knee_menisci import NEAR_MM, knee_menisci_fe
from fecheck.fe.knee.knee_menisci_report import donahue_note, region_rows, report_lines, rows
from fecheck.fe.knee.meniscus_body import ROOTS
from fecheck.model.results import write_rows
from fecheck.scene import load_scene

SCENE = "femur_tibia_menisci"
QUICK = {"series": ["fe.prepare=on", "fe.size_mm=2.0"],
         "two-layer": ["scanned.decimate_faces=1500"]}
"""The quick run's coarse sheets per ``fe.cartilage``: remeshed at 2 mm, or (two deformable
layers are extruded from the sheets as read) decimated."""
QUICK_MENISCUS_MM = 2.5
FACTORS = (("superior surface raised 0.1 mm", {"lift_mm": 0.1}),
           ("superior surface raised 0.25 mm", {"lift_mm": 0.25}),
           ("superior surface raised 0.5 mm", {"lift_mm": 0.5}),
           ("tibial cartilage E x 0.5", {"modulus": 0.5}),
           ("tibial cartilage E x 2", {"modulus": 2.0}),
           ("coronary ligaments added", {"coronary": True}),
           ("horn roots 2000 N/mm (Donahue)", {"root": "donahue"}))
"""One factor changed at a time from the script's run (its ``--root``)."""


def quick_scene(quick: bool, cartilage: str | None = None, extra: tuple[str, ...] = ()):
    """The scene, with ``fe.cartilage = cartilage`` (None: the scene's) and, `quick`, its
    coarse sheets (`QUICK`), then the overrides `extra`."""
    sets = [] if cartilage is None else [f"fe.cartilage={cartilage}"]
    chosen = load_scene(SCENE, sets)["fe.cartilage"]
    return load_scene(SCENE, [*sets, *(QUICK[chosen] if quick else []), *extra])


def build(scene, modulus: float = 1.0):
    """The scene's tibial layers (`fecheck.fe.solve.press.build_layers`), the contact modulus
    times `modulus`."""
    from fecheck.fe.bodies.scene_bodies import scene_bodies
    from fecheck.fe.bodies.settings import FESettings
    from fecheck.fe.solve.press import build_layers
    from fecheck.scene import with_values

    plain = with_values(scene, menisci__dir="")
    return build_layers(scene_bodies(plain), modulus * scene["contact.youngs_MPa"],
                        scene["contact.poisson"], FESettings.from_scene(plain),
                        lambda m: None)


def factor_rows(scene, base, ef, layers, size: float, root: str, say,
                hold: bool = False) -> list[dict]:
    """One row per `FACTORS` entry (and the run itself first): per compartment the meniscal
    share, its change from the run (points), the femur-meniscus contact area (mm²), the
    horn springs' part of the meniscal load and the hoop force at mid-arc (N)."""
    out = []
    for name, change in (("as run", {}), *FACTORS):
        kw = dict(change)
        modulus = kw.pop("modulus", 1.0)
        kw.setdefault("root", root)
        if change and kw["root"] == root and change.get("root"):
            continue                                    # the run already has these roots
        say(f"factor: {name}")
        r = base if not change else knee_menisci_fe(
            scene, meniscus_size_mm=size, ef=ef,
            layers=layers if modulus == 1.0 else build(scene, modulus), hold_rotation=hold,
            **kw)
        row = {"factor": name}
        for c, fe in r.fe.items():
            m = r.menisci[c]
            row |= {f"{c}_share": fe.share, f"{c}_change_pts": 100 * (fe.share - base.fe[c].share),
                    f"{c}_femur_meniscus_mm2": m.contact_mm2,
                    f"{c}_springs_part": fe.springs_N / fe.meniscus_N,
                    f"{c}_hoop_mid_N": float(np.interp(0.5, m.hoop.section_arc, m.hoop.force_N))}
        out.append(row)
    return out


def print_factors(table: list[dict]) -> str:
    """Print the factor table; the factor that moves the share most (summed over the
    compartments, in points)."""
    print("meniscal share, one factor at a time (medial | lateral: share, change in points "
          "from the run, femur-meniscus contact mm², horn springs' part of the meniscal load, "
          "hoop force at mid-arc N)")
    print(f"{'factor':<33} " + " | ".join(
        f"{'share':>6} {'Δ pts':>6} {'mm²':>4} {'horn':>5} {'hoop N':>6}" for _ in range(2)))
    for row in table:
        print(f"{row['factor']:<33} " + " | ".join(
            f"{row[f'{c}_share']:6.1%} {row[f'{c}_change_pts']:+6.1f} "
            f"{row[f'{c}_femur_meniscus_mm2']:4.0f} {row[f'{c}_springs_part']:5.0%} "
            f"{row[f'{c}_hoop_mid_N']:6.1f}" for c in ("medial", "lateral")))
    top = max(table[1:], key=lambda r: abs(r["medial_change_pts"]) + abs(r["lateral_change_pts"]))
    print(f"the factor that moves the share most: {top['factor']} "
          f"({top['medial_change_pts']:+.1f} / {top['lateral_change_pts']:+.1f} points)")
    return top["factor"]


def print_why(r) -> None:
    """Where the femur meets each meniscus, how near the rest lies, how the body moves."""
    for c, m in r.menisci.items():
        fe = r.fe[c]
        near = ", ".join(f"{m.near_mm2[d]:.0f} within {d:g} mm" for d in NEAR_MM)
        print(f"{c} meniscus: the femur presses {m.contact_mm2:.0f} mm² of its superior "
              f"surface ({near}) while it comes down {fe.compression_mm:.3f} mm into the "
              f"tibial cartilage; body moves {m.radial_mm:+.3f} mm radially (+ out), the horn "
              f"springs hold {fe.springs_N:.1f} of its {fe.meniscus_N:.1f} N")
        print(f"{c} meniscus hoop force N at arc " + ", ".join(
            f"{a:g}: {f:.2f}" for a, f in zip(m.hoop.section_arc, m.hoop.force_N, strict=True))
            + f" (section {m.hoop.section_area_mm2.min():.0f}-"
            f"{m.hoop.section_area_mm2.max():.0f} mm²)")


def hoop_rows(r) -> list[dict]:
    """One row per meniscus and section: arc coordinate, hoop force (N), section (mm²)."""
    return [{"meniscus": c, "arc": float(a), "hoop_force_N": float(f),
             "section_mm2": float(area)}
            for c, m in r.menisci.items()
            for a, f, area in zip(m.hoop.section_arc, m.hoop.force_N,
                                  m.hoop.section_area_mm2, strict=True)]


def plot_pressure(r, layers, path: Path) -> None:
    """The tibial pressure (cartilage and meniscus contact) seen from above, each
    meniscus's footprint outlined."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection

    top = max(float(p.max()) for p in r.pressure_MPa.values())
    fig, ax = plt.subplots(figsize=(8, 5.5))
    label_y = max(float(lay.surface.points[:, 1].max()) for lay in layers) + 3.0
    for lay in layers:
        c = lay.body.name
        pts = lay.surface.points
        art = ax.tripcolor(pts[:, 0], pts[:, 1], lay.surface.faces, r.pressure_MPa[c],
                           shading="gouraud", cmap="viridis", vmin=0.0, vmax=top)
        if c in r.outlines:
            ax.add_collection(LineCollection(r.outlines[c][:, :, :2], colors="w",
                                             linewidths=1.0))
        ax.text(pts[:, 0].mean(), label_y, f"{c}: share {r.fe[c].share:.1%}, "
                f"p_max {r.fe[c].p_max_MPa:.2f} MPa", ha="center", fontsize=9)
    fig.colorbar(art, ax=ax, label="tibial contact pressure, MPa")
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.set_ylim(top=label_y + 4.0)                          # room for the labels
    ax.set_xlabel("x mm (right)")
    ax.set_ylabel("y mm (anterior)")
    ax.set_title(f"FE with menisci ({r.cartilage} cartilage), {r.load_N:.0f} N: tibial "
                 "pressure, meniscus footprints (white)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def write_csv(path: Path, table: list[dict]) -> None:
    write_rows(path, table)
    print(f"wrote {path}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="coarse meshes (2 mm sheets, "
                   "2.5 mm meniscus tetrahedra), no factor table unless --factors")
    p.add_argument("--factors", action="store_true", help="the factor table also with "
                   "--quick")
    p.add_argument("--root", choices=ROOTS, default="data", help="horn root stiffness: the "
                   "data's root bundles (k / l0) or Donahue's 2000 N/mm per horn")
    p.add_argument("--hold-rotation", action="store_true", help="keep the femur at the EF's "
                   "rotation (for comparison; by default it turns free where the tibia does)")
    p.add_argument("--cartilage", choices=CARTILAGE, help="the femoral cartilage a "
                   "deformable layer of its own on the femur (two-layer: the scene's), or in "
                   "the tibial layer's series thickness (fe.cartilage)")
    p.add_argument("--out", type=Path, default=Path("out/validation"), help="output folder")
    args = p.parse_args(argv)
    scene = quick_scene(args.quick, args.cartilage)
    size = QUICK_MENISCUS_MM if args.quick else DEFAULT_SIZE_MM

    def say(m):
        print(f"  {m}", file=sys.stderr)

    t0 = time.perf_counter()
    try:
        from fecheck.model.menisci import run_menisci

        ef = run_menisci(scene)
        layers = build(scene)
        r = knee_menisci_fe(scene, meniscus_size_mm=size, root=args.root, ef=ef,
                            layers=layers, log=say, hold_rotation=args.hold_rotation,
                            without=True)
        wall = time.perf_counter() - t0
        factors = (factor_rows(scene, r, ef, layers, size, args.root, say, args.hold_rotation)
                   if args.factors or not args.quick else None)
    except FecheckError as err:
        print(f"fe_menisci: {err}", file=sys.stderr)
        return 1
    table = rows(r)
    print(f"{SCENE}: FE with menisci at the EF pose, load on the tibia {r.load_N:.2f} N "
          f"(horn roots: {args.root})")
    print("\n".join(report_lines(r, wall)[:-1]))
    print_why(r)
    if factors:
        print_factors(factors)
    print(donahue_note(r.cartilage))
    args.out.mkdir(parents=True, exist_ok=True)
    write_csv(args.out / "fe_menisci.csv", table)
    write_csv(args.out / "fe_menisci_regions.csv", region_rows(r))
    write_csv(args.out / "fe_menisci_hoop.csv", hoop_rows(r))
    if factors:
        write_csv(args.out / "fe_menisci_factors.csv", factors)
    plot_pressure(r, layers, args.out / "fe_menisci_pressure.png")
    print(f"wrote {args.out / 'fe_menisci_pressure.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
