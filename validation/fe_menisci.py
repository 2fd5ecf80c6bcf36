"""The FE of the knee with menisci at the EF equilibrium of ``femur_tibia_menisci`` (800 N,
full extension), beside the EF and Donahue et al. 2002.

`fecheck.fe.knee_menisci`: each meniscus a deformable transversely isotropic solid (P2
tetrahedra, fibres along its arc) on horn springs to the tibia, each compartment's tibial
cartilage a bonded layer as ``fecheck fe`` builds it (series thickness), the femur rigid,
its rotation held at the EF pose and its translation along the tibial z axis solved under
the EF's load on the tibia (800 N less the tibia's weight), frictionless contact on the
three interfaces. Per compartment: the axial load into the tibia through the meniscus
(its contact and its horn springs) and through cartilage-cartilage contact, the meniscal
share, the tibial contact area and vertex p_max; then the femur's balance along its axis,
each meniscus's balance, the worst penetration over every contact vertex, dofs and time.

Beside them: the EF of the same scene (menisci rigid, smith2019's lumped 1 MPa meniscus
layer), Donahue et al. 2002's tibial contact area and p_max at 800 N (490 / 415 mm²,
2.55 / 2.36 MPa medial / lateral, thesis Tables 5.7a-5.8a: another knee), and the meniscal
share usually quoted for intact cadaver knees near full extension, about 50 % medially
and 70 % laterally (Seedhom & Hargreaves 1979, Eng. Med. 8:220-228; Walker & Erkman
1975, Clin. Orthop. 109:184-192: at least half of the load; quoted, not re-derived).

    python validation/fe_menisci.py [--quick] [--root data|donahue] [--out DIR]

--quick: tibial sheets remeshed at 2 mm (``fe.prepare = "on"``, ``fe.size_mm = 2``) and
2.5 mm meniscus tetrahedra. Writes DIR/fe_menisci.csv.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.errors import FecheckError
from fecheck.fe.knee_menisci import ROOTS, knee_menisci_fe
from fecheck.fe.meniscus_solid import DEFAULT_SIZE_MM
from fecheck.reference.closed_forms import DONAHUE_2002
from fecheck.scene import load_scene

SCENE = "femur_tibia_menisci"
QUICK = ["fe.prepare=on", "fe.size_mm=2.0"]
QUICK_MENISCUS_MM = 2.5
PUBLISHED_SHARE = {"medial": 0.5, "lateral": 0.7}
"""Meniscal share of intact knees near full extension, as usually quoted (docstring)."""


def rows(result) -> list[dict]:
    """One row per compartment and model: FE, EF, Donahue 2002 (1 mm elements)."""
    out = []
    for c, fe in result.fe.items():
        ef = result.ef[c]
        ref = DONAHUE_2002[c][1.0]
        out += [
            {"compartment": c, "model": "FE", "meniscus_N": fe.meniscus_N,
             "springs_N": fe.springs_N, "cartilage_N": fe.cartilage_N, "share": fe.share,
             "area_mm2": fe.area_mm2, "p_max_MPa": fe.p_max_MPa},
            {"compartment": c, "model": "EF", "meniscus_N": ef["meniscus_N"],
             "springs_N": float("nan"), "cartilage_N": ef["cartilage_N"],
             "share": ef["share"], "area_mm2": ef["area_mm2"], "p_max_MPa": ef["p_max_MPa"]},
            {"compartment": c, "model": "Donahue 2002", "meniscus_N": float("nan"),
             "springs_N": float("nan"), "cartilage_N": float("nan"),
             "share": float("nan"), "area_mm2": ref.area_mm2,
             "p_max_MPa": ref.max_pressure_MPa}]
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="coarse meshes (2 mm sheets, "
                   "2.5 mm meniscus tetrahedra)")
    p.add_argument("--root", choices=ROOTS, default="data", help="horn root stiffness: the "
                   "data's root bundles (k / l0) or Donahue's 2000 N/mm per horn")
    p.add_argument("--out", type=Path, default=Path("out/validation"), help="output folder")
    args = p.parse_args(argv)
    scene = load_scene(SCENE, QUICK if args.quick else [])
    size = QUICK_MENISCUS_MM if args.quick else DEFAULT_SIZE_MM
    t0 = time.perf_counter()
    try:
        r = knee_menisci_fe(scene, meniscus_size_mm=size, root=args.root,
                            log=lambda m: print(f"  {m}", file=sys.stderr))
    except FecheckError as err:
        print(f"fe_menisci: {err}", file=sys.stderr)
        return 1
    wall = time.perf_counter() - t0
    table = rows(r)
    print(f"{SCENE}: FE with menisci at the EF pose, load on the tibia {r.load_N:.2f} N "
          f"(horn roots: {args.root})")
    print(f"{'compartment':<11} {'model':<13} {'menisc. N':>9} {'springs N':>9} "
          f"{'cart. N':>8} {'share':>6} {'area mm²':>9} {'p_max MPa':>9}")
    for row in table:
        print(f"{row['compartment']:<11} {row['model']:<13} {row['meniscus_N']:9.2f} "
              f"{row['springs_N']:9.2f} {row['cartilage_N']:8.2f} {row['share']:6.3f} "
              f"{row['area_mm2']:9.1f} {row['p_max_MPa']:9.3f}")
    for c, fe in r.fe.items():
        print(f"{c}: FE area {fe.area_mm2 / DONAHUE_2002[c][1.0].area_mm2:.2f}x and p_max "
              f"{fe.p_max_MPa / DONAHUE_2002[c][1.0].max_pressure_MPa:.2f}x Donahue's; "
              f"meniscal share {fe.share:.1%} (published for intact knees near full "
              f"extension: about {PUBLISHED_SHARE[c]:.0%}); the meniscus slides "
              f"{fe.meniscus_slide_mm:.3f} mm in the tibial plane; its balance "
              f"{fe.meniscus_balance_N:.1e} N")
    print(f"balance: femur contact along its axis - load = {r.balance_N:.2e} N "
          f"({abs(r.balance_N) / r.load_N:.1e} of the load); worst penetration "
          f"{r.max_penetration_mm:.2e} mm; femur travel from the EF pose "
          f"{r.approach_mm:+.4f} mm in {r.outer_iterations} linearisations")
    print(f"dofs {r.n_dofs}; time s: " + ", ".join(f"{k} {v:.1f}" for k, v in
                                                 r.seconds.items()) + f", wall {wall:.1f}")
    print("* Donahue 2002 is another knee (its own geometry, both cartilages deformable); "
          "the femoral cartilage here is in the tibial layer's series thickness under the "
          "condyles and rigid over the menisci")
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "fe_menisci.csv"
    with path.open("w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=list(table[0]))
        writer.writeheader()
        writer.writerows(table)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
