"""Meniscal load share of the EF knee with menisci against load and meniscal modulus, and a
medial meniscectomy.

The packaged scene ``femur_tibia_menisci`` (the scanned lenhart2015 knee with the smith2019
menisci as free rigid bodies, EF contact, full extension) is solved

* at 200-2000 N with smith2019's meniscus layer (1 MPa, ν 0.45, 3 mm, lumped with one
  cartilage layer as smith2019 does);
* at 800 N with the meniscus modulus 1 MPa (smith2019's meniscus contact mesh), 5 MPa
  (smith2019's cartilage), 20 MPa (the radial and axial modulus E_r = E_z quoted for the
  meniscus of Donahue et al. 2002, J. Biomech. Eng. 124:273-280, the one an EF column
  compresses) and 120 MPa (of the order of the circumferential modulus E_θ quoted for that
  meniscus, 140 MPa in `fecheck.fe.material.anisotropy`, an upper bound: the hoop stiffness is no
  compressive modulus); the values are quoted from citing studies, not read in the paper;
* at 800 N with the two layers in series instead of lumped (the model before the lumped
  convention); with each meniscus held in the plateau's plane (menisci.free = z, flexion,
  abduction: x, y and internal rotation ride on the tibia), which shows how much of the
  low share comes from the rigid frictionless menisci sliding outward, which nothing
  but the horn roots resists (the coronary ligaments are slack); and without the medial
  meniscus (menisci.sides = ['lateral']).

Per run and compartment: the axial load through the meniscus and through cartilage, the
meniscal share, the tibial peak pressure (the larger of the cartilage-cartilage and the
meniscus-tibia peak) and the tibial contact area (cartilage-cartilage plus
meniscus-tibia). The meniscectomy's factors on the medial peak pressure and contact area
are printed beside the cadaver factors usually quoted for a total meniscectomy:
Fukubayashi & Kurosawa 1980 (Acta Orthop. Scand. 51:871-879: peak pressure about 2x,
area about half) and Baratz et al. 1986 (Am. J. Sports Med. 14:270-275: peak pressure
+235 %, area -75 %); those papers' numbers are quoted, not re-derived here.

    python validation/menisci_study.py [--quick] [--out DIR]

--quick: 500 and 800 N, 1 and 20 MPa, the meniscectomy. Every run converges (9-13 Newton
iterations, measured); one that does not would be flagged in the CSV (converged False) and
left out of the plot. Writes DIR/menisci_study.csv and
DIR/menisci_study.png.
"""

from __future__ import annotations

import csv
import math
import sys
from pathlib import Path

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.model.run import run_scene
from fecheck.scene import load_scene
from fecheck.studies.thesis.report import knee_script_args

SCENE = "femur_tibia_menisci"
LOADS_N = (200.0, 500.0, 800.0, 1200.0, 2000.0)
QUICK_LOADS_N = (500.0, 800.0)
MODULI_MPA = (1.0, 5.0, 20.0, 120.0)
QUICK_MODULI_MPA = (1.0, 20.0)
PUBLISHED = ("total meniscectomy, cadaver knees: peak pressure x2 and area x0.5 "
             "(Fukubayashi & Kurosawa 1980), peak +235 % and area -75 % (Baratz et al. "
             "1986); intact meniscal share at full extension 40-70 %")


def cases(quick: bool) -> list[tuple[str, float, list[str]]]:
    """(study, x value, scene settings) of every run."""
    loads, moduli = (QUICK_LOADS_N, QUICK_MODULI_MPA) if quick else (LOADS_N, MODULI_MPA)
    out = [("load", f, [f"load.force_N={f}"]) for f in loads]
    out += [("modulus", e, [f"menisci.youngs_MPa={e}"]) for e in moduli]
    out += [("series", 800.0, ["menisci.layers='series'"]),
            ("held", 800.0, ["menisci.free=['z', 'flexion', 'abduction']"]),
            ("meniscectomy", 800.0, ["menisci.sides=['lateral']"])]
    return out


def rows_of(study: str, x: float, result) -> list[dict]:
    """One CSV row per compartment of a run."""
    rows = []
    for side, row in result.menisci["compartments"].items():
        comp = result.compartments[side]
        p_men = row.get("meniscus_tibia_max_pressure_MPa", 0.0)
        area_men = row.get("meniscus_tibia_area_mm2", 0.0)
        rows.append({"study": study, "x": x, "compartment": side,
                     "converged": result.converged, "meniscus_N": row["meniscus_N"],
                     "cartilage_N": row["cartilage_N"], "share": row["meniscal_share"],
                     "cartilage_p_max_MPa": comp.max_pressure_MPa,
                     "meniscus_p_max_MPa": p_men,
                     "tibial_p_max_MPa": max(comp.max_pressure_MPa, p_men),
                     "cartilage_area_mm2": comp.area_mm2,
                     "meniscus_area_mm2": area_men,
                     "tibial_area_mm2": comp.area_mm2 + area_men})
    return rows


def meniscectomy_factors(rows: list[dict]) -> tuple[float, float]:
    """(medial tibial p_max after / before, medial tibial contact area after / before) of
    the meniscectomy against the intact knee at 800 N (the load study's 800 N run)."""
    def medial(study):
        return next(r for r in rows if r["study"] == study and r["x"] == 800.0
                    and r["compartment"] == "medial")
    before, after = medial("load"), medial("meniscectomy")
    return (after["tibial_p_max_MPa"] / before["tibial_p_max_MPa"],
            after["tibial_area_mm2"] / before["tibial_area_mm2"])


def plot(rows: list[dict], path: Path) -> None:
    """Share against load and modulus, and the medial p_max and area with and without the
    medial meniscus, in one PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 3, figsize=(15, 4.6))
    for a, study, label in ((ax[0], "load", "load N"),
                            (ax[1], "modulus", "meniscus modulus MPa (log)")):
        for side, mark in (("medial", "o-"), ("lateral", "s--")):
            pts = sorted((r["x"], 100 * r["share"]) for r in rows if r["converged"]
                         and r["study"] == study and r["compartment"] == side)
            a.plot(*zip(*pts, strict=True), mark, label=side)
        a.axhspan(40, 70, color="0.85", label="published intact, 40-70 %")
        failed = sorted({f"{r['x']:g}" for r in rows
                         if r["study"] == study and not r["converged"]})
        a.set(xlabel=label + (f"\nnot converged, left out: {', '.join(failed)}"
                              if failed else ""), ylabel="meniscal load share %",
              ylim=(0, 100))
        a.legend(fontsize=8)
    ax[1].set_xscale("log")
    ax[0].set_title("share against load (1 MPa meniscus)", fontsize=10)
    ax[1].set_title("share against meniscus modulus (800 N)", fontsize=10)
    med = {s: next(r for r in rows if r["study"] == s and r["x"] == 800.0
                   and r["compartment"] == "medial") for s in ("load", "meniscectomy")}
    p_factor, a_factor = meniscectomy_factors(rows)
    x = [0, 1]
    ax[2].bar([v - 0.2 for v in x], [med[s]["tibial_p_max_MPa"] for s in med], 0.4,
              label="medial tibial p_max MPa")
    twin = ax[2].twinx()
    twin.bar([v + 0.2 for v in x], [med[s]["tibial_area_mm2"] for s in med], 0.4,
             color="tab:orange", label="medial tibial contact area mm²")
    ax[2].set_ylim(0, 1.4 * max(med[s]["tibial_p_max_MPa"] for s in med))   # room for
    twin.set_ylim(0, 1.4 * max(med[s]["tibial_area_mm2"] for s in med))      # the legends
    ax[2].set_xticks(x, ["intact", "medial meniscectomy"])
    ax[2].set_ylabel("p_max MPa")
    twin.set_ylabel("contact area mm²")
    ax[2].set_title(f"800 N: p_max x{p_factor:.2f}, area x{a_factor:.2f}\n(cadaver: p_max "
                    "x2-3.4, area x0.25-0.5)", fontsize=10)
    ax[2].legend(loc="upper left", fontsize=8)
    twin.legend(loc="upper right", fontsize=8)
    fig.suptitle("EF knee with rigid menisci (femur_tibia_menisci, lumped smith2019 layer "
                 "unless noted)", fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    args = knee_script_args(__doc__.splitlines()[0], "500 and 800 N, 1 and 20 MPa, the "
                            "meniscectomy", argv)
    if args is None:
        return 0
    rows = []
    for study, x, sets in cases(args.quick):
        result = run_scene(load_scene(SCENE, sets))
        rows += rows_of(study, x, result)
        shares = " ".join(f"{r['compartment']} {100 * r['share']:.1f} %" for r in rows[-2:]
                          if not math.isnan(r["share"]))
        print(f"{study} {x:g}: converged {result.converged}, share {shares}", flush=True)
    p_factor, a_factor = meniscectomy_factors(rows)
    print(f"medial meniscectomy at 800 N: medial tibial p_max x{p_factor:.2f}, contact area "
          f"x{a_factor:.2f}; {PUBLISHED}")
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "menisci_study.csv"
    with path.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    plot(rows, args.out / "menisci_study.png")
    print(f"wrote {path} and {args.out / 'menisci_study.png'}")
    used = [r for r in rows if r["x"] == 800.0 and r["study"] in ("load", "meniscectomy")]
    return 0 if all(r["converged"] for r in used) else 1


if __name__ == "__main__":
    sys.exit(main())
