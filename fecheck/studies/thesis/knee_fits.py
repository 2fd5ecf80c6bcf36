"""Surface fits of thesis §2.2 on the scanned lenhart2015 knee: Tables 2.1, 2.4 and 2.5.

Per tibial compartment (its cartilage sheet, face centroids): the plane z = ax + by + c
with and without statistical outliers (2σ̂, σ̂ = 1.4826·MAD; area-weighted as the data
set's fits.json), its angles λ (sagittal) and γ (frontal) and mean errors, beside the
transverse plane's; the polynomial z = f(x, y) of degrees k = m = 0…5 with mean errors and
rank deficiency. Per femoral condyle (the posterior-distal cartilage faces of fits.json's
definition): the sphere, then r = f(θ, φ) about its centre for degrees 0…6. Each is
printed beside the thesis's number; the trends are compared at the end. The plane angles
and degree-3 coefficients are printed as the TOML blocks of
``validation/scenes/{inclined,polynomial}*.toml`` (`plateau_values` is what the scene
test compares them with).

    python validation/knee_fits.py [--quick] [--out DIR]

--quick fits degrees up to 3 only. Writes DIR/knee_fits_table_2_{1,4,5}.csv.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from fecheck.model.condyles import condyle_faces
from fecheck.scene import lenhart
from fecheck.scene.constants import COMPARTMENTS as SIDES
from fecheck.studies.thesis import thesis_values as tv
from fecheck.studies.thesis.report import knee_script_args
from geometry.fits import fit_plane, fit_polynomial_surface, fit_sphere, fit_spherical_polynomial

POLY_DEGREE = 3
"""Degree of the polynomial plateaus (thesis Table 5.10)."""


def tibial_points(side: str) -> tuple[np.ndarray, np.ndarray]:
    """Face centroids (mm) and areas (mm²) of one tibial cartilage compartment."""
    m = lenhart.mesh(f"tibia_cartilage_{side}")
    return m.face_centroids, m.face_areas


def condyle_points(side: str) -> tuple[np.ndarray, np.ndarray]:
    """Posterior-distal femoral cartilage face centroids and areas of one condyle (the
    selection of fits.json, `fecheck.model.condyles.condyle_faces`; a right knee)."""
    femur = lenhart.mesh("femur_cartilage")
    keep = condyle_faces(femur, side, "right")
    return femur.face_centroids[keep], femur.face_areas[keep]


def table_2_1() -> list[dict]:
    """Plane fits with and without outliers, per compartment."""
    rows = []
    for side in SIDES:
        p, w = tibial_points(side)
        for label, sigma in (("with outliers", None), ("without outliers", 2.0)):
            f = fit_plane(p, outlier_sigma=sigma, weights=w)
            t = tv.TABLE_2_1[label][side]
            rows.append({"case": label, "side": side, "lambda_deg": f.sagittal_deg,
                         "gamma_deg": f.frontal_deg, "me_free_mm": f.mean_error_mm,
                         "me_transverse_mm": f.transverse_mean_error_mm,
                         "inliers": int(f.inlier_mask.sum()), "points": len(p),
                         "a": f.a, "b": f.b, "c_mm": f.c,
                         "thesis_lambda_deg": t["lambda_deg"], "thesis_gamma_deg": t["gamma_deg"],
                         "thesis_me_free_mm": t["me_free_mm"],
                         "thesis_me_transverse_mm": t["me_transverse_mm"]})
    return rows


def table_2_4(max_degree: int) -> list[dict]:
    """Tibial z = f(x, y) polynomials, degrees k = m = 0…max_degree."""
    rows = []
    for side in SIDES:
        p, _ = tibial_points(side)
        for k in range(max_degree + 1):
            f = fit_polynomial_surface(p, k, k)
            thesis = tv.TABLE_2_4.get(k)
            rows.append({"side": side, "degree": k, "mean_error_mm": f.mean_error_mm,
                         "rank": f.rank, "rank_deficient": f.rank_deficient,
                         "thesis_mean_error_mm": None if thesis is None
                         else thesis[SIDES.index(side)]})
    return rows


def table_2_5(max_degree: int) -> list[dict]:
    """Femoral condyle sphere, then r = f(θ, φ) about its centre, degrees 0…max_degree."""
    rows = []
    for side in SIDES:
        p, w = condyle_points(side)
        sphere = fit_sphere(p, weights=w)
        rows.append({"side": side, "degree": "sphere", "mean_error_mm": sphere.mean_error_mm,
                     "rank": 4, "rank_deficient": False, "thesis_mean_error_mm": None,
                     "radius_mm": sphere.radius_mm})
        for k in range(max_degree + 1):
            f = fit_spherical_polynomial(p, sphere.center, k, k)
            thesis = tv.TABLE_2_5.get(k)
            rows.append({"side": side, "degree": k, "mean_error_mm": f.mean_error_mm,
                         "rank": f.rank, "rank_deficient": f.rank_deficient,
                         "thesis_mean_error_mm": None if thesis is None
                         else thesis[SIDES.index(side)]})
    return rows


def plateau_values() -> dict:
    """Inclined-plane angles (λ, γ) without outliers and degree-3 coefficients c[i][j]
    (z = Σ c_ij x^i y^j, mm) per compartment, as the scenes hold them."""
    out = {}
    for side in SIDES:
        p, w = tibial_points(side)
        plane = fit_plane(p, outlier_sigma=2.0, weights=w)
        poly = fit_polynomial_surface(p, POLY_DEGREE, POLY_DEGREE).poly
        out[side] = {"angles_deg": [round(plane.sagittal_deg, 4), round(plane.frontal_deg, 4)],
                     "coefficients": [[float(f"{v:.9g}") for v in row]
                                      for row in np.asarray(poly.coeffs)]}
    return out


def toml_blocks(values: dict) -> str:
    """The [plateau] TOML of the inclined and polynomial scenes."""
    lines = ["# inclined.toml", "[plateau]", 'kind = "inclined"']
    lines += [f"{s}_angles_deg = {values[s]['angles_deg']}" for s in SIDES]
    lines += ["", "# polynomial.toml", "[plateau]", 'kind = "polynomial"']
    for s in SIDES:
        rows = ",\n    ".join(str(r) for r in values[s]["coefficients"])
        lines.append(f"{s}_coefficients = [\n    {rows},\n]")
    return "\n".join(lines)


def _write(path: Path, rows: list[dict]) -> None:
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, keys)
        w.writeheader()
        w.writerows(rows)


def _fmt(x) -> str:
    return "–" if x is None else (f"{x:.3f}" if isinstance(x, float) else str(x))


def print_tables(t21: list[dict], t24: list[dict], t25: list[dict]) -> None:
    print("Table 2.1 — plateau planes (scanned knee | thesis): λ°, γ°, ME free, ME transverse mm")
    for r in t21:
        print(f"  {r['case']:17s} {r['side']:8s} λ {r['lambda_deg']:7.2f} | "
              f"{r['thesis_lambda_deg']:6.2f}   γ {r['gamma_deg']:7.2f} | "
              f"{r['thesis_gamma_deg']:6.2f}   ME {r['me_free_mm']:.2f} | "
              f"{r['thesis_me_free_mm']:.2f}   Tran {r['me_transverse_mm']:.2f} | "
              f"{r['thesis_me_transverse_mm']:.2f}   ({r['inliers']}/{r['points']} faces)")
    for title, rows in (("Table 2.4 — tibial z = f(x, y), k = m", t24),
                        ("Table 2.5 — femoral r = f(θ, φ)", t25)):
        print(f"{title}: mean error mm (scanned | thesis), RD = rank deficient")
        for side in SIDES:
            cells = [f"{_fmt(r['degree'])}: {r['mean_error_mm']:.3f}"
                     f"{' RD' if r['rank_deficient'] else ''} | "
                     f"{_fmt(r['thesis_mean_error_mm'])}"
                     for r in rows if r["side"] == side]
            print(f"  {side:8s} " + ";  ".join(cells))


def trends(t21: list[dict], t24: list[dict], t25: list[dict]) -> list[str]:
    """The qualitative statements of thesis §2.2.3 checked on the scanned knee."""
    out = []
    for side in SIDES:
        w, wo = (next(r for r in t21 if r["side"] == side and r["case"] == c)
                 for c in ("with outliers", "without outliers"))
        out.append(f"{side}: removing outliers lowers the plane ME "
                   f"({w['me_free_mm']:.2f} → {wo['me_free_mm']:.2f} mm): "
                   f"{wo['me_free_mm'] < w['me_free_mm']}; the free plane beats the "
                   f"transverse one ({wo['me_free_mm']:.2f} < {wo['me_transverse_mm']:.2f}): "
                   f"{wo['me_free_mm'] < wo['me_transverse_mm']}")
        me = [r["mean_error_mm"] for r in t24 if r["side"] == side]
        out.append(f"{side}: tibial ME decreases with degree: "
                   f"{bool(np.all(np.diff(me) <= 1e-12))} ({', '.join(f'{v:.2f}' for v in me)})")
        me = [r["mean_error_mm"] for r in t25 if r["side"] == side and r["degree"] != "sphere"]
        out.append(f"{side}: femoral ME decreases with degree: "
                   f"{bool(np.all(np.diff(me) <= 1e-12))} ({', '.join(f'{v:.3f}' for v in me)})")
    return out


def main(argv: list[str] | None = None) -> int:
    args = knee_script_args(__doc__.splitlines()[0], "degrees up to 3 only", argv)
    if args is None:
        return 0
    t21 = table_2_1()
    t24 = table_2_4(3 if args.quick else 5)
    t25 = table_2_5(3 if args.quick else 6)
    args.out.mkdir(parents=True, exist_ok=True)
    for name, rows in (("2_1", t21), ("2_4", t24), ("2_5", t25)):
        _write(args.out / f"knee_fits_table_{name}.csv", rows)
    print_tables(t21, t24, t25)
    print("Trends (thesis §2.2.3):")
    for line in trends(t21, t24, t25):
        print("  " + line)
    print("\nScene values (validation/scenes/inclined*.toml, polynomial*.toml):")
    print(toml_blocks(plateau_values()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
