"""The Donahue knee, like for like: the FE of the packaged scene ``donahue2002`` (this knee
with each of Donahue et al. 2002's modelling choices) beside Donahue 2002 and a
subject-specific FE at 1150 N, then each difference that remains changed one at a time.

``donahue2002`` makes Donahue's choices (800 N at full extension, varus-valgus free, both
cartilage layers deformable, cartilage E 15 MPa and ν 0.475, transversely isotropic menisci,
2000 N/mm horn springs; `fecheck.reference.published_fe`). What it cannot make is Donahue's
cadaver knee: the geometry stays this one's. So the factors, geometry first, each changed
alone from the packaged scene (`fecheck.fe.knee.knee_menisci.knee_menisci_fe`, without the
no-menisci run):

* geometry: the menisci as shipped instead of fitted to the joint (``menisci.fit``); the
  cartilage 1.25 times thicker (``scanned.thickness_scale``: Donahue's layers were his knee's);
* mesh: the coarse sheets (1500 faces, 2.5 mm meniscus tetrahedra) instead of the full ones
  (the element size; Donahue's 1 mm elements are his mesh);
* material: the cartilage at fecheck's default E 20 MPa, ν 0.3 instead of Donahue's;
* attachments: the horns on the data set's root bundles (smith2019's EF placeholders,
  ``menisci.roots = "bundles"``) instead of 2000 N/mm springs;
* load: 1150 N, the subject FE's.

Per row and compartment: tibial contact area (mm²), vertex p_max (MPa), meniscal share, and
the ratio of area and p_max to Donahue's (to the subject FE's for the 1150 N row), with the
change from the packaged scene (%). Writes DIR/donahue_factors.md and DIR/donahue_factors.json.

    python validation/donahue_factors.py [--quick [--all-rows]] [--out DIR]

--quick: the packaged scene and the menisci as shipped only, with one deformable cartilage
layer of both thicknesses in series on tibial sheets remeshed at 2 mm (``fe.cartilage =
"series"``) and 2.5 mm meniscus tetrahedra: a check that the script runs, not Donahue's model;
--all-rows: every row on that model.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.errors import FecheckError
from fecheck.fe.bodies.meniscus_solid import DEFAULT_SIZE_MM
from fecheck.fe.knee.knee_menisci import knee_menisci_fe
from fecheck.reference.closed_forms import DONAHUE_2002
from fecheck.reference.published_fe import SUBJECT_FE_2020
from fecheck.scene import load_scene

SCENE = "donahue2002"
COARSE = ["scanned.decimate_faces=1500"]
"""The coarse sheets (two deformable layers are extruded from the sheets as read)."""
COARSE_MENISCUS_MM = 2.5
"""The coarse meniscus tetrahedra, mm."""
FACTORS: tuple[tuple[str, str, list[str]], ...] = (
    ("as packaged (Donahue's choices)", "-", []),
    ("menisci as shipped, not fitted", "geometry", ["menisci.fit=as-shipped"]),
    ("cartilage 1.25 x thicker", "geometry", ["scanned.thickness_scale=1.25"]),
    ("coarse mesh (1500-face sheets, 2.5 mm menisci)", "mesh", COARSE),
    ("cartilage E 20 MPa, nu 0.3 (fecheck default)", "material",
     ["contact.youngs_MPa=20", "contact.poisson=0.3"]),
    ("horns on the data's root bundles", "attachment", ["menisci.roots=bundles"]),
    ("load 1150 N (the subject FE's)", "load", ["load.force_N=1150"]),
)
"""(row, kind of difference, scene overrides), each alone from the packaged scene."""
QUICK = ["fe.cartilage=series", "fe.prepare=on", "fe.size_mm=2.0"]
"""The quick run's model: one deformable layer of both cartilages' thickness on tibial
sheets remeshed at 2 mm (not Donahue's two layers: a check that the script runs)."""
QUICK_ROWS = 2
"""The quick run: the first rows of `FACTORS`, on `QUICK`."""
SIDES = ("medial", "lateral")


def reference(row: str, c: str) -> tuple[str, float, float]:
    """(name, area mm², p_max MPa) the row is compared with: the subject FE at 1150 N for
    the 1150 N row, Donahue 2002 (800 N, 1 mm elements) for the others."""
    if "1150" in row:
        s = SUBJECT_FE_2020[c]
        return "subject FE 2020", s.area_mm2, s.p_max_MPa
    d = DONAHUE_2002[c][1.0]
    return "Donahue 2002", d.area_mm2, d.max_pressure_MPa


def run_row(name: str, kind: str, sets: list[str], quick: bool, say) -> dict:
    """The FE of the packaged scene with `sets`: per compartment area, p_max, share."""
    coarse = quick or sets == COARSE
    scene = load_scene(SCENE, [*(QUICK if quick else []), *sets])
    size = COARSE_MENISCUS_MM if coarse else DEFAULT_SIZE_MM
    say(f"{name}: {' '.join(sets) or 'no change'}")
    t0 = time.perf_counter()
    r = knee_menisci_fe(scene, meniscus_size_mm=size, log=say)
    row = {"factor": name, "kind": kind, "sets": sets, "load_N": r.load_N,
           "dofs": r.n_dofs, "wall_s": time.perf_counter() - t0}
    for c in SIDES:
        fe = r.fe[c]
        ref, area, peak = reference(name, c)
        row[c] = {"area_mm2": fe.area_mm2, "p_max_MPa": fe.p_max_MPa, "share": fe.share,
                  "springs_N": fe.springs_N, "reference": ref,
                  "area_ratio": fe.area_mm2 / area, "p_max_ratio": fe.p_max_MPa / peak}
    return row


def with_changes(rows: list[dict]) -> list[dict]:
    """`rows` with each compartment's change of area and p_max from the first row, %."""
    base = rows[0]
    for row in rows:
        for c in SIDES:
            for key in ("area_mm2", "p_max_MPa"):
                row[c][f"{key}_change_pct"] = 100 * (row[c][key] / base[c][key] - 1)
    return rows


def markdown(rows: list[dict], quick: bool) -> str:
    """The table: per row and compartment area, p_max, share, the ratios to the reference
    and the change from the packaged scene; the references below."""
    head = ("| difference | kind | medial area mm² | medial p_max MPa | medial share | "
            "lateral area mm² | lateral p_max MPa | lateral share |")
    out = [head, "|" + "---|" * 8]
    for row in rows:
        cells = []
        for c in SIDES:
            m = row[c]
            cells += [f"{m['area_mm2']:.0f} (x{m['area_ratio']:.2f}, "
                      f"{m['area_mm2_change_pct']:+.0f} %)",
                      f"{m['p_max_MPa']:.2f} (x{m['p_max_ratio']:.2f}, "
                      f"{m['p_max_MPa_change_pct']:+.0f} %)", f"{m['share']:.0%}"]
        out.append(f"| {row['factor']} | {row['kind']} | " + " | ".join(cells) + " |")
    for name, values in (("Donahue 2002 (800 N, 1 mm elements)",
                          {c: (DONAHUE_2002[c][1.0].area_mm2,
                               DONAHUE_2002[c][1.0].max_pressure_MPa) for c in SIDES}),
                         ("subject FE 2020 (1150 N, mean)",
                          {c: (SUBJECT_FE_2020[c].area_mm2, SUBJECT_FE_2020[c].p_max_MPa)
                           for c in SIDES})):
        cells = []
        for c in SIDES:
            cells += [f"{values[c][0]:.0f}", f"{values[c][1]:.2f}", "-"]
        out.append(f"| {name} | published | " + " | ".join(cells) + " |")
    mesh = ("quick: one cartilage layer in series on 2 mm sheets, 2.5 mm menisci, not "
            "Donahue's two layers" if quick
            else "full sheets, 1.25 mm menisci (the coarse row excepted)")
    out.append("")
    out.append(f"Mesh: {mesh}. In brackets: the ratio to Donahue 2002 (to the subject FE for "
               "the 1150 N row) and the change from the packaged scene. Area: tibial contact "
               "area; p_max: vertex peak of the tibial contact pressure; share: the load "
               "through the meniscus.")
    return "\n".join(out) + "\n"


def write(out: Path, rows: list[dict], failed: list[dict], quick: bool) -> None:
    """DIR/donahue_factors.md (the table, the rows that failed below it) and .json."""
    table = markdown(rows, quick) + "".join(
        f"\nNot measured: {f['factor']}: {f['error']}\n" for f in failed)
    (out / "donahue_factors.md").write_text(table)
    (out / "donahue_factors.json").write_text(json.dumps(
        {"scene": SCENE, "quick": quick, "rows": rows, "failed": failed,
         "donahue_2002": {c: {"area_mm2": DONAHUE_2002[c][1.0].area_mm2,
                              "p_max_MPa": DONAHUE_2002[c][1.0].max_pressure_MPa}
                          for c in SIDES},
         "subject_fe_2020": {c: vars(SUBJECT_FE_2020[c]) for c in SIDES}}, indent=2) + "\n")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true",
                   help="two rows, one cartilage layer on 2 mm sheets")
    p.add_argument("--all-rows", action="store_true",
                   help="with --quick: every row, on the quick model")
    p.add_argument("--out", type=Path, default=Path("out/validation"), help="output folder")
    args = p.parse_args(argv)

    def say(m):
        print(f"  {m}", file=sys.stderr)

    factors = FACTORS[:QUICK_ROWS] if args.quick and not args.all_rows else FACTORS
    args.out.mkdir(parents=True, exist_ok=True)
    rows, failed = [], []
    for n, k, s in factors:
        try:
            rows.append(run_row(n, k, s, args.quick, say))
        except FecheckError as err:
            if not rows:
                print(f"donahue_factors: {err}", file=sys.stderr)
                return 1
            failed.append({"factor": n, "kind": k, "sets": s, "error": str(err)})
            say(f"{n}: failed: {err}")
            continue
        say(f"{n}: " + ", ".join(f"{c} area {rows[-1][c]['area_mm2']:.1f} mm², p_max "
                                 f"{rows[-1][c]['p_max_MPa']:.3f} MPa, share "
                                 f"{rows[-1][c]['share']:.3f}" for c in SIDES)
            + f" ({rows[-1]['wall_s']:.0f} s)")
        write(args.out, with_changes(rows), failed, args.quick)
    print((args.out / "donahue_factors.md").read_text())
    print(f"wrote {args.out / 'donahue_factors.md'} and donahue_factors.json")
    return 0


if __name__ == "__main__":
    sys.exit(main())
