"""FE studies of the knee with menisci: meniscal share against load and against the
meniscal circumferential modulus, and a medial meniscectomy.

`fecheck.fe.knee.knee_menisci` on the packaged ``femur_tibia_menisci`` (full extension; both
cartilages deformable layers, its ``fe.cartilage = "two-layer"``), the tibial layers built
once (they do not depend on the load or the meniscus; each run builds its femoral layers
over its own contact):

* **load**: 200, 800 and 2000 N, the EF equilibrium re-solved at each load (the FE runs at
  the EF pose of its own load);
* **modulus**: 800 N with the circumferential (fibre) modulus E_t of the meniscus
  (`fecheck.fe.material.anisotropy.MENISCUS`, 140 MPa) times 0.5, 1 and 2, the rest of the
  material kept; the EF pose is that of 800 N (the EF's meniscus layer has no
  circumferential modulus);
* **meniscectomy**: 800 N without the medial meniscus (``menisci.sides = ['lateral']``). The
  EF equilibrium is re-solved without it, so the FE starts from the pose the knee takes
  without that meniscus (the FE solves the femur's travel along the tibial axis and its turn
  in the tibia's free rotations, not its other translations). The factors on the medial
  tibial peak pressure and contact area are printed beside the cadaver factors usually
  quoted for a total meniscectomy: Fukubayashi & Kurosawa 1980 (Acta Orthop. Scand.
  51:871-879: peak pressure about 2x, area about half) and Baratz et al. 1986 (Am. J. Sports
  Med. 14:270-275: peak pressure +235 %, area -75 %), quoted, not re-derived. Removing only
  the posterior horn region is not modelled (the meniscus solid is meshed whole).

Per run and compartment: the load through the meniscus and through cartilage, the
meniscal share, the tibial contact area and p_max. Units: N, mm², MPa.

    python validation/fe_menisci_study.py [--quick] [--out DIR]

--quick: sheets decimated to 1500 faces and 2.5 mm meniscus tetrahedra (as
``fe_menisci.py --quick``), loads 800 and 2000 N, moduli x0.5 and x2 (beside the 800 N
run's x1), the meniscectomy. Writes DIR/fe_menisci_study.csv.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.errors import FecheckError
from fecheck.fe.bodies.meniscus_solid import DEFAULT_SIZE_MM
from fecheck.fe.knee.knee_menisci import knee_menisci_fe
from fecheck.fe.knee.knee_menisci_report import PUBLISHED_SHARE
from fecheck.fe.material.anisotropy import MENISCUS
from fecheck.model.results import write_rows
from validation.fe_menisci import QUICK_MENISCUS_MM, SCENE, build, quick_scene

LOADS_N = (200.0, 800.0, 2000.0)
QUICK_LOADS_N = (800.0, 2000.0)
MODULUS_FACTORS = (0.5, 1.0, 2.0)
"""x1 is the 800 N load run itself (quick too)."""
PUBLISHED = ("total meniscectomy, cadaver knees: peak pressure x2 and area x0.5 "
             "(Fukubayashi & Kurosawa 1980), peak +235 % (x3.35) and area -75 % (x0.25) "
             "(Baratz et al. 1986)")


def rows_of(study: str, x: float, r) -> list[dict]:
    """One CSV row per compartment of the FE run `r`."""
    return [{"study": study, "x": x, "compartment": c, "meniscus_N": fe.meniscus_N,
             "cartilage_N": fe.cartilage_N, "share": fe.share, "area_mm2": fe.area_mm2,
             "p_max_MPa": fe.p_max_MPa, "balance_N": r.balance_N,
             "penetration_mm": r.max_penetration_mm}
            for c, fe in r.fe.items()]


def run_all(quick: bool, say) -> list[dict]:
    """Every run of the study (module docstring), its rows."""
    from fecheck.model.menisci import run_menisci

    size = QUICK_MENISCUS_MM if quick else DEFAULT_SIZE_MM
    layers = build(quick_scene(quick))
    runs: dict[tuple[str, float], object] = {}

    def fe(label: tuple[str, float], extra: list[str], material=MENISCUS):
        scene = quick_scene(quick, extra=tuple(extra))
        say(f"{label[0]} {label[1]:g}")
        runs[label] = knee_menisci_fe(scene, meniscus_size_mm=size, ef=run_menisci(scene),
                                      layers=layers, material=material)
        return runs[label]

    for f in QUICK_LOADS_N if quick else LOADS_N:
        fe(("load", f), [f"load.force_N={f}"])
    runs[("modulus", 1.0)] = runs[("load", 800.0)]
    for k in MODULUS_FACTORS:
        if k != 1.0:
            fe(("modulus", k), ["load.force_N=800.0"], replace(MENISCUS, E_t=k * MENISCUS.E_t))
    fe(("meniscectomy", 800.0), ["load.force_N=800.0", "menisci.sides=['lateral']"])
    return [row for (study, x), r in sorted(runs.items(), key=lambda kv: kv[0])
            for row in rows_of(study, x, r)]


def print_table(table: list[dict]) -> None:
    """The table, the share beside the published one, the meniscectomy's factors."""
    print(f"{'study':<13} {'x':>7} {'compartment':<11} {'menisc. N':>9} {'cart. N':>8} "
          f"{'share':>6} {'area mm²':>9} {'p_max MPa':>9}")
    for row in table:
        print(f"{row['study']:<13} {row['x']:7g} {row['compartment']:<11} "
              f"{row['meniscus_N']:9.2f} {row['cartilage_N']:8.2f} {row['share']:6.1%} "
              f"{row['area_mm2']:9.1f} {row['p_max_MPa']:9.3f}")
    print("x: load N (load), factor on the meniscus's circumferential modulus "
          f"{MENISCUS.E_t:g} MPa (modulus, 800 N), load N (meniscectomy: medial meniscus "
          "removed); published meniscal share of intact knees near full extension: "
          + ", ".join(f"{c} about {s:.0%}" for c, s in PUBLISHED_SHARE.items()))
    medial = {(r["study"], r["x"]): r for r in table if r["compartment"] == "medial"}
    intact, cut = medial[("load", 800.0)], medial[("meniscectomy", 800.0)]
    print(f"medial meniscectomy (FE, EF pose re-solved without the meniscus): peak pressure "
          f"{intact['p_max_MPa']:.2f} -> {cut['p_max_MPa']:.2f} MPa "
          f"(x{cut['p_max_MPa'] / intact['p_max_MPa']:.2f}), contact area "
          f"{intact['area_mm2']:.0f} -> {cut['area_mm2']:.0f} mm² "
          f"(x{cut['area_mm2'] / intact['area_mm2']:.2f}); {PUBLISHED}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="coarse meshes, loads 800 and "
                   "2000 N, moduli x0.5 and x2, the meniscectomy")
    p.add_argument("--out", type=Path, default=Path("out/validation"), help="output folder")
    args = p.parse_args(argv)

    def say(m):
        print(f"  {m}", file=sys.stderr)

    t0 = time.perf_counter()
    try:
        table = run_all(args.quick, say)
    except FecheckError as err:
        print(f"fe_menisci_study: {err}", file=sys.stderr)
        return 1
    print(f"{SCENE}: FE with menisci, {len(table) // 2} cases in "
          f"{time.perf_counter() - t0:.0f} s")
    print_table(table)
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "fe_menisci_study.csv"
    write_rows(path, table)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
