"""Reports of the FE of the knee with menisci (`fecheck.fe.knee.knee_menisci.KneeMenisciFE`):
the per-compartment table beside the EF and Donahue et al. 2002, the per-region table of
the tibial contact, the summary lines and the JSON dictionary. Shared by ``fecheck fe`` on
a menisci scene and ``validation/fe_menisci.py``. Units: mm, N, MPa.

The published meniscal share is the one usually quoted for intact cadaver knees near full
extension, about 50 % medially and 70 % laterally (Seedhom & Hargreaves 1979, Eng. Med.
8:220-228; Walker & Erkman 1975, Clin. Orthop. 109:184-192: at least half of the load).
"""

from __future__ import annotations

import math
from dataclasses import asdict

from fecheck.fe.material.anisotropy import MENISCUS
from fecheck.reference.closed_forms import DONAHUE_2002
from fecheck.reference.published_fe import DONAHUE_2002_CHOICES, SUBJECT_FE_2020

PUBLISHED_SHARE = {"medial": 0.5, "lateral": 0.7}
"""Meniscal share of intact knees near full extension, as usually quoted (docstring)."""
CARTILAGE_NOTES = {
    "series": "the femoral cartilage here is in the tibial layer's series thickness under "
              "the condyles and rigid over the menisci",
    "two-layer": "both cartilages here are deformable layers too (fe.cartilage = "
                 "'two-layer')"}
"""How the run's cartilage model (``fe.cartilage``) differs from Donahue's, or not."""


def donahue_note(cartilage: str) -> str:
    """The note under the table: Donahue 2002 is another knee; the run's cartilage model
    (``fe.cartilage``) beside its two deformable layers."""
    return ("* Donahue 2002 is another knee (its own geometry, both cartilages deformable); "
            + CARTILAGE_NOTES[cartilage])


def rows(result) -> list[dict]:
    """One row per compartment and model: FE, the FE without menisci (where the run has
    it), EF, Donahue 2002 (1 mm elements); loads N, share, area mm², p_max MPa (NaN where
    the model gives none)."""
    out = []
    for c, fe in result.fe.items():
        ef = result.ef[c]
        ref = DONAHUE_2002[c][1.0]
        out.append({"compartment": c, "model": "FE", "meniscus_N": fe.meniscus_N,
                    "springs_N": fe.springs_N, "cartilage_N": fe.cartilage_N,
                    "share": fe.share, "area_mm2": fe.area_mm2, "p_max_MPa": fe.p_max_MPa})
        bare = result.without_menisci.get(c)
        if bare is not None:
            out.append({"compartment": c, "model": "FE no menisci", "meniscus_N": 0.0,
                        "springs_N": 0.0, "cartilage_N": bare.cartilage_N, "share": 0.0,
                        "area_mm2": bare.area_mm2, "p_max_MPa": bare.p_max_MPa})
        out += [
            {"compartment": c, "model": "EF", "meniscus_N": ef["meniscus_N"],
             "springs_N": float("nan"), "cartilage_N": ef["cartilage_N"],
             "share": ef["share"], "area_mm2": ef["area_mm2"], "p_max_MPa": ef["p_max_MPa"]},
            {"compartment": c, "model": "Donahue 2002", "meniscus_N": float("nan"),
             "springs_N": float("nan"), "cartilage_N": float("nan"),
             "share": float("nan"), "area_mm2": ref.area_mm2,
             "p_max_MPa": ref.max_pressure_MPa}]
    return out


def region_rows(result) -> list[dict]:
    """One row per compartment and tibial contact region (`REGION_NAMES`), then the horn
    springs and the total: axial load N, its part of the compartment's load, area mm² and
    p_max MPa (NaN for the springs, which touch no area)."""
    out = []
    for c, fe in result.fe.items():
        total = fe.meniscus_N + fe.cartilage_N
        for name, r in fe.regions.items():
            out.append({"compartment": c, "region": name, "load_N": r.load_N,
                        "part": r.load_N / total, "area_mm2": r.area_mm2,
                        "p_max_MPa": r.p_max_MPa})
        out.append({"compartment": c, "region": "horn springs", "load_N": fe.springs_N,
                    "part": fe.springs_N / total, "area_mm2": float("nan"),
                    "p_max_MPa": float("nan")})
        out.append({"compartment": c, "region": "total", "load_N": total, "part": 1.0,
                    "area_mm2": fe.area_mm2, "p_max_MPa": fe.p_max_MPa})
    return out


def _cell(value: float, spec: str, width: int) -> str:
    return f"{value:{width}{spec}}" if math.isfinite(value) else f"{'-':>{width}}"


def report_lines(result, wall_s: float | None = None) -> list[str]:
    """The report: the compartment table, per compartment the ratios to Donahue's and
    the share beside the published one, the region table, balance, penetration, dofs and
    times (`wall_s`: the whole run's wall time, s)."""
    out = [f"{'compartment':<11} {'model':<13} {'menisc. N':>9} {'springs N':>9} "
           f"{'cart. N':>8} {'share':>6} {'area mm²':>9} {'p_max MPa':>9}"]
    for row in rows(result):
        out.append(f"{row['compartment']:<11} {row['model']:<13} "
                   f"{_cell(row['meniscus_N'], '.2f', 9)} {_cell(row['springs_N'], '.2f', 9)} "
                   f"{_cell(row['cartilage_N'], '.2f', 8)} {_cell(row['share'], '.3f', 6)} "
                   f"{_cell(row['area_mm2'], '.1f', 9)} {_cell(row['p_max_MPa'], '.3f', 9)}")
    for c, fe in result.fe.items():
        ref = DONAHUE_2002[c][1.0]
        out.append(f"{c}: FE area {fe.area_mm2 / ref.area_mm2:.2f}x and p_max "
                   f"{fe.p_max_MPa / ref.max_pressure_MPa:.2f}x Donahue's; meniscal share "
                   f"{fe.share:.1%} (published for intact knees near full extension: about "
                   f"{PUBLISHED_SHARE[c]:.0%}); the meniscus slides {fe.meniscus_slide_mm:.3f} "
                   f"mm in the tibial plane; its balance {fe.meniscus_balance_N:.1e} N")
    out.append("tibial contact per region (axial load N, part of the compartment's load, "
               "area mm², p_max MPa)")
    out.append(f"{'compartment':<11} {'region':<15} {'load N':>8} {'part':>6} {'area mm²':>9} "
               f"{'p_max MPa':>9}")
    for row in region_rows(result):
        out.append(f"{row['compartment']:<11} {row['region']:<15} "
                   f"{row['load_N']:8.2f} {row['part']:6.1%} "
                   f"{_cell(row['area_mm2'], '.1f', 9)} {_cell(row['p_max_MPa'], '.3f', 9)}")
    out += load_path_lines(result)
    out.append(f"balance: femur contact along its axis - load = {result.balance_N:.2e} N "
               f"({abs(result.balance_N) / result.load_N:.1e} of the load); worst "
               f"penetration {result.max_penetration_mm:.2e} mm; femur travel from the EF "
               f"pose {result.approach_mm:+.4f} mm in {result.outer_iterations} "
               "linearisations")
    for turn, moment in zip(result.turn_deg, result.moment_balance_Nmm, strict=True):
        out.append(f"femur turn from the EF pose (a rotation the tibia is free in) "
                   f"{turn:+.4f} deg; its moment balance {moment:.2e} N mm "
                   f"({abs(moment) / result.load_N:.1e} of the load x 1 mm)")
    wall = "" if wall_s is None else f", wall {wall_s:.1f}"
    out.append(f"dofs {result.n_dofs}; time s: " + ", ".join(
        f"{k} {v:.1f}" for k, v in result.seconds.items()) + wall)
    out.append(donahue_note(result.cartilage))
    return out


def _shown(value) -> str:
    if isinstance(value, list | tuple):
        return ", ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in value)
    return f"{value:g}" if isinstance(value, float) else str(value)


def choice_rows(scene) -> list[dict]:
    """Per modelling choice of Donahue 2002 (`DONAHUE_2002_CHOICES`): what it is, its scene
    key, Donahue's value, the scene's (fecheck's meniscus material where no key makes it),
    whether they agree, and the source."""
    out = []
    for ch in DONAHUE_2002_CHOICES:
        if ch.key is None:
            mine = (MENISCUS.E_t, MENISCUS.E_p, MENISCUS.nu_tp, MENISCUS.nu_p)
            same = mine == ch.value
        else:
            mine = scene[ch.key]
            same = (sorted(mine) == sorted(ch.value) if isinstance(ch.value, list)
                    else mine == ch.value)
        out.append({"what": ch.what, "key": ch.key or "(fecheck's meniscus material)",
                    "donahue_2002": _shown(ch.value), "scene": _shown(mine),
                    "same": bool(same), "source": ch.source})
    return out


def choice_lines(scene) -> list[str]:
    """The modelling-choices block: per choice of Donahue 2002 the scene key, the scene's
    value, whether it is Donahue's, and the source."""
    rows_ = choice_rows(scene)
    out = [f"modelling choices beside Donahue 2002's ({sum(r['same'] for r in rows_)} of "
           f"{len(rows_)} the same; the geometry is this knee's, not Donahue's cadaver's):"]
    for r in rows_:
        mark = "same as" if r["same"] else "differs from"
        out.append(f"  {r['what']}: {r['key']} = {r['scene']}, {mark} Donahue's "
                   f"{r['donahue_2002']} [{r['source']}]")
    return out


def published_rows(result) -> list[dict]:
    """Per compartment the tibial contact area (mm²) and p_max (MPa) of this FE (at its
    load), Donahue 2002 (800 N, 1 mm elements) and the subject FE of 2020 (1150 N; its
    largest compressive stress, mean ± SD)."""
    out = []
    for c, fe in result.fe.items():
        don, sub = DONAHUE_2002[c][1.0], SUBJECT_FE_2020[c]
        out += [{"compartment": c, "model": "fecheck FE", "load_N": result.load_N,
                 "area_mm2": fe.area_mm2, "area_sd_mm2": float("nan"),
                 "p_max_MPa": fe.p_max_MPa, "p_max_sd_MPa": float("nan")},
                {"compartment": c, "model": "Donahue 2002", "load_N": 800.0,
                 "area_mm2": don.area_mm2, "area_sd_mm2": float("nan"),
                 "p_max_MPa": don.max_pressure_MPa, "p_max_sd_MPa": float("nan")},
                {"compartment": c, "model": "subject FE 2020", "load_N": sub.load_N,
                 "area_mm2": sub.area_mm2, "area_sd_mm2": sub.area_sd_mm2,
                 "p_max_MPa": sub.p_max_MPa, "p_max_sd_MPa": sub.p_max_sd_MPa}]
    return out


def published_lines(result) -> list[str]:
    """The table beside the published FE knees: tibial contact area and p_max per
    compartment of this FE, Donahue 2002 and the subject FE at 1150 N, each at its load."""
    out = ["tibial contact beside published FE knees with menisci (each at its own load; "
           "Donahue 2002: 1 mm elements; subject FE 2020: mean ± SD, its largest compressive "
           "stress)",
           f"{'compartment':<11} {'model':<16} {'load N':>7} {'area mm²':>13} "
           f"{'p_max MPa':>12}"]
    for r in published_rows(result):
        sd = math.isfinite(r["area_sd_mm2"])
        area = (f"{r['area_mm2']:.0f} ± {r['area_sd_mm2']:.0f}" if sd
                else f"{r['area_mm2']:.1f}")
        peak = (f"{r['p_max_MPa']:.2f} ± {r['p_max_sd_MPa']:.2f}" if sd
                else f"{r['p_max_MPa']:.3f}")
        out.append(f"{r['compartment']:<11} {r['model']:<16} {r['load_N']:7.0f} "
                   f"{area:>13} {peak:>12}")
    return out


def comparison_dict(result, scene) -> dict:
    """The JSON of the two blocks: ``published`` (`published_rows`, null where a model gives
    no SD) and ``choices`` (`choice_rows`)."""
    return _finite({"published": published_rows(result), "choices": choice_rows(scene)})


def load_path_lines(result) -> list[str]:
    """Per meniscus the load path (axial N: femur → meniscus; meniscus → tibia by contact
    and through its horn roots) with each root's tension, and its hoop force along the
    arc (N, at arc coordinates 0 anterior tip … 1 posterior tip)."""
    out = []
    for c, m in result.menisci.items():
        fe = result.fe[c]
        roots = ", ".join(f"{h} {v:.1f} N" for h, v in m.roots_N.items()) or "none"
        out.append(f"{c} meniscus load path: femur -> meniscus {fe.femur_on_meniscus_N:.1f} N; "
                   f"meniscus -> tibia by contact {fe.meniscus_N - fe.springs_N:.1f} N, "
                   f"through its horn roots {fe.springs_N:.1f} N (axial; root tension "
                   f"{roots})")
        out.append(f"{c} meniscus hoop force N at arc " + ", ".join(
            f"{a:g}: {f:.1f}" for a, f in zip(m.hoop.section_arc, m.hoop.force_N,
                                              strict=True)))
    return out


def _finite(value):
    """`value` with every non-finite float as None (JSON has no NaN)."""
    if isinstance(value, dict):
        return {str(k): _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    if hasattr(value, "tolist"):
        return _finite(value.tolist())
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    return value


def as_dict(result, scene_name: str = "") -> dict:
    """The JSON of the run: load (N), per compartment the FE (`CompartmentFE` with its
    regions), the EF, Donahue 2002 and the published share; per meniscus its contact,
    radial displacement and hoop force; the cartilage model; balance, penetration,
    travel, the femur's turns and moment balance, dofs, times."""
    compartments = {}
    for c, fe in result.fe.items():
        ref = DONAHUE_2002[c][1.0]
        compartments[c] = {
            "fe": asdict(fe), "ef": dict(result.ef[c]),
            "fe_without_menisci": (asdict(result.without_menisci[c])
                                   if c in result.without_menisci else None),
            "donahue_2002": {"area_mm2": float(ref.area_mm2),
                             "p_max_MPa": float(ref.max_pressure_MPa)},
            "published_share": PUBLISHED_SHARE[c]}
    menisci = {c: {"contact_mm2": m.contact_mm2,
                   "near_mm2": {f"{d:g}": v for d, v in m.near_mm2.items()},
                   "radial_mm": m.radial_mm, "roots_N": m.roots_N,
                   "hoop": {"arc": m.hoop.section_arc, "force_N": m.hoop.force_N,
                            "section_mm2": m.hoop.section_area_mm2}}
               for c, m in result.menisci.items()}
    return _finite({"scene": scene_name, "kind": "fe with menisci",
                    "cartilage": result.cartilage, "load_N": result.load_N,
                    "compartments": compartments, "menisci": menisci,
                    "balance_N": result.balance_N,
                    "max_penetration_mm": result.max_penetration_mm,
                    "approach_mm": result.approach_mm, "turn_deg": result.turn_deg,
                    "moment_balance_Nmm": result.moment_balance_Nmm, "n_dofs": result.n_dofs,
                    "outer_iterations": result.outer_iterations,
                    "seconds": dict(result.seconds)})
