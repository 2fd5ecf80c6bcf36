"""Mesh convergence of the FE of the scanned femur on the scanned tibia (`fecheck fe`).

The FE of validation/scenes/femur_tibia.toml (the tibial cartilage sheets extruded by the
bone-distance thickness into bonded P2 layers under the rigid scanned femoral sheet,
whole-joint load control) on three kinds of mesh series, reporting p_max, p_max on the EF
faces and contact area per compartment, the FE dofs, time and peak memory per level:

1. ``refine``: ``fe.refine`` 0 / 1 / 2 on one decimated surface (each split quarters the
   surface triangles and keeps the surface exactly: element size ratio 2). The surface
   is small (``REFINE_FACES``) because the layer's extrusion directions are smoothed over
   the 1-ring of the refined surface, and on a finer scanned surface refined once or
   twice some prisms stay inverted after the 64 smoothing rounds `fecheck.fe.solve.press`
   allows (the run says which levels failed).
2. ``decimate`` (full mode): the scanned surface decimated to about 250 and 1,500
   tibial faces and at full resolution (8,602), element size ratio about 2.4 twice.
   Decimation changes the surface at each level (and the EF answer with it), so this
   series measures geometry and discretisation together; it is the only one that ends
   at the default mesh (full surface, refine 0), whose error it estimates. The levels
   are where the layer extrudes at all: with the bone-distance thickness most
   decimations in between (about 1,700 to 8,000 faces, e.g. 2,150 and 4,300) leave
   prisms inverted after the 64 smoothing rounds.
3. ``layers``: ``fe.layers`` 2 (default) / 3 / 4 through the thickness at the default
   surface (grading 1.6 kept).

p_max is the largest FE vertex pressure; "p_max on EF faces" the largest FE pressure
averaged over the EF run's faces (the same faces at every refine and layers level; not
analysed on the decimate series, whose EF faces change).
Under fe.refine the surface keeps its creases (it is piecewise flat), and the vertex
p_max grows at every split without settling (observed order about 0.1-0.2, as at a
crease in contact, where the pressure concentrates as the mesh resolves it; it does so
under an exact sphere too); the face-averaged p_max, the area and the split converge.

Per series and quantity: the observed order of convergence p from the three levels
(Richardson; the generalised form of Celik et al. 2008 for unequal size ratios), the
extrapolated value and the estimated error of the default level (refine 0, full
surface, 2 layers) against it. Oscillating triples (the differences change sign) get no
order, and orders outside `ORDER_RANGE` are taken as not yet asymptotic: for both no
extrapolation is claimed, and the default level's change against the finest one and the
last step's change are given instead. Times are wall clock on a shared machine.

    python validation/fe_scanned_convergence.py [--quick] [--out DIR]

--quick: refine 0 / 1 / 2 and layers 2 / 3 / 4 on a surface decimated to about 150
tibial faces (so that refine 2 stays cheap). Skipped (exit 0) when the scanned knee data
is absent. Writes DIR/fe_scanned_convergence.csv, DIR/fe_scanned_richardson.csv and
DIR/fe_scanned_convergence.png.
"""

from __future__ import annotations

import csv
import math
import resource
import sys
import time
from pathlib import Path

import numpy as np

from fecheck.errors import FecheckError
from fecheck.fe.knee.crosscheck import cross_check
from fecheck.scene import load_scene

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.studies.thesis.report import knee_script_args, save_figure

SCENE = Path(__file__).resolve().parent / "scenes" / "femur_tibia.toml"
COMPARTMENTS = ("medial", "lateral")
QUANTITIES = {"pmax": "max_pressure_MPa", "pmax_faces": None, "area": "area_mm2"}
"""SideMetrics attributes; pmax_faces (None) = the largest FE pressure averaged over the EF
run's faces (the same faces at every fe.refine level and layer count)."""
REFINE_FACES = {"quick": 150, "full": 250}
DECIMATE_FACES = (250, 1500, 0)
LAYERS = (2, 3, 4)
SAME_EF_FACES = ("refine", "layers")
"""Series whose levels share the EF run's faces: only there is "p_max on EF faces" one
quantity at every level (decimation changes the faces it averages over)."""
ORDER_RANGE = (0.5, 4.0)
"""Observed orders outside this range are taken as not yet asymptotic: no extrapolated
error is claimed, only the default level's change against the finest and the last step."""


def series_plan(quick: bool) -> list[tuple[str, list[tuple[str, dict]]]]:
    """[(series, [(level label, scene overrides as a dict)])], coarse to fine."""
    base = REFINE_FACES["quick" if quick else "full"]
    plan = [("refine", [(f"{base} faces, refine {r}",
                         {"scanned.decimate_faces": base, "fe.refine": r}) for r in range(3)])]
    if not quick:
        plan.append(("decimate", [(f"{n} faces" if n else "full (8,602 faces)",
                                   {"scanned.decimate_faces": n}) for n in DECIMATE_FACES]))
    layer_faces = base if quick else 0
    plan.append(("layers", [(f"{layer_faces or 'full'} faces, {n} layers",
                             {"scanned.decimate_faces": layer_faces, "fe.layers": n})
                            for n in LAYERS]))
    return plan


def _key(overrides: dict) -> tuple:
    full = {"scanned.decimate_faces": 0, "fe.refine": 0, "fe.layers": 2, **overrides}
    return tuple(sorted(full.items()))


def solve_level(overrides: dict) -> dict:
    """One mesh: the FE (and EF) metrics, the FE surface size, dofs, time, peak memory."""
    scene = load_scene(SCENE, [f"{k}={v}" for k, v in overrides.items()])
    t0 = time.perf_counter()
    check = cross_check(scene, log=None)
    wall = time.perf_counter() - t0
    faces = sum(chk.layer.surface.n_faces for chk in check.compartments.values())
    area = sum(float(chk.layer.surface.face_areas.sum()) for chk in check.compartments.values())
    row = {"tibial_faces_fe": faces,
           "edge_mm": math.sqrt(4 * area / (math.sqrt(3) * faces)),
           "fe_dofs": check.geometry["dofs"]}
    for c in COMPARTMENTS:
        chk = check.compartments[c]
        for key, attr in QUANTITIES.items():
            if attr is None:
                row[f"{c}_fe_{key}"] = float(np.nanmax(chk.fe_face_pressure_MPa))
                row[f"{c}_ef_{key}"] = (math.nan if chk.ef_face_pressure_MPa is None
                                        else float(np.nanmax(chk.ef_face_pressure_MPa)))
            else:
                row[f"{c}_fe_{key}"] = getattr(chk.fe, attr)
                row[f"{c}_ef_{key}"] = getattr(chk.ef_model, attr)
    row["medial_share_fe"] = check.split("fe")["medial"]
    row["fe_s"] = check.timing_s["fe"]
    row["total_s"] = wall
    row["peak_rss_MB"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return row


def run_plan(plan) -> tuple[list[dict], int]:
    """Every level of every series (a level shared by two series is solved once)."""
    done: dict[tuple, dict | str] = {}
    rows, failed = [], 0
    for series, levels in plan:
        for label, overrides in levels:
            key = _key(overrides)
            if key not in done:
                print(f"{series}: {label} ...", flush=True)
                try:
                    done[key] = solve_level(overrides)
                except FecheckError as err:
                    done[key] = str(err)
                    failed += 1
                    print(f"  failed: {err}")
            result = done[key]
            base = {"series": series, "level": label,
                    "decimate_faces": overrides.get("scanned.decimate_faces", 0),
                    "refine": overrides.get("fe.refine", 0),
                    "layers": overrides.get("fe.layers", 2)}
            if isinstance(result, str):
                rows.append({**base, "failed": result})
            else:
                rows.append({**base, **result, "failed": ""})
    return rows, failed


def richardson(sizes: list[float], values: list[float]) -> dict:
    """Observed order, extrapolated value from three levels, coarse to fine.

    sizes : element sizes h3 > h2 > h1 (coarse to fine); values : f3, f2, f1.
    The generalised Richardson form (Celik et al. 2008, J. Fluids Eng. 130:078001):
    p = |ln|ε32/ε21| + q(p)| / ln r21, q(p) = ln((r21^p − s)/(r32^p − s)), with
    ε32 = f3 − f2, ε21 = f2 − f1, r21 = h2/h1, r32 = h3/h2, s = sign(ε32/ε21);
    f_ext = (r21^p f1 − f2)/(r21^p − 1). Oscillating (s < 0) or unchanged triples get
    p = NaN and f_ext = NaN; `status` says which ("monotone", "oscillating", "unchanged").
    """
    (h3, h2, h1), (f3, f2, f1) = sizes, values
    e32, e21 = f3 - f2, f2 - f1
    if e21 == 0 or e32 == 0 or e32 * e21 < 0:
        status = "oscillating" if e32 * e21 < 0 else "unchanged"
        return {"order": math.nan, "extrapolated": math.nan, "status": status}
    r21, r32 = h2 / h1, h3 / h2
    p, q = 0.0, 0.0
    for _ in range(200):
        p_new = abs(math.log(abs(e32 / e21)) + q) / math.log(r21)
        q = math.log((r21 ** p_new - 1) / (r32 ** p_new - 1)) if p_new > 0 else 0.0
        if abs(p_new - p) < 1e-10:
            break
        p = p_new
    p = p_new
    ext = (r21 ** p * f1 - f2) / (r21 ** p - 1) if p > 0 else math.nan
    return {"order": p, "extrapolated": ext, "status": "monotone"}


def default_level(series: str, rows: list[dict]) -> dict:
    """The default mesh of a series: refine 0 / the full surface / 2 layers."""
    pick = {"refine": lambda r: r["refine"] == 0,
            "decimate": lambda r: r["decimate_faces"] == 0,
            "layers": lambda r: r["layers"] == 2}[series]
    return next(r for r in rows if pick(r))


def analyse(rows: list[dict]) -> list[dict]:
    """Per series (with three solved levels) and quantity: order, extrapolation, error of
    the default level."""
    out = []
    for series in dict.fromkeys(r["series"] for r in rows):
        levels = [r for r in rows if r["series"] == series]
        if len(levels) != 3 or any(r["failed"] for r in levels):
            print(f"{series}: fewer than three solved levels, no Richardson estimate")
            continue
        sizes = ([1.0 / r["layers"] for r in levels] if series == "layers"
                 else [r["edge_mm"] for r in levels])
        default = default_level(series, levels)
        for c in COMPARTMENTS:
            for key in QUANTITIES:
                if key == "pmax_faces" and series not in SAME_EF_FACES:
                    continue
                values = [r[f"{c}_fe_{key}"] for r in levels]
                rich = richardson(sizes, values)
                fine = values[-1]
                spread = (max(values) - min(values)) / fine
                asymptotic = ORDER_RANGE[0] <= rich["order"] <= ORDER_RANGE[1]
                if rich["status"] == "monotone" and not asymptotic:
                    rich["status"] = f"order outside {ORDER_RANGE[0]:g}-{ORDER_RANGE[1]:g}"
                err = (default[f"{c}_fe_{key}"] / rich["extrapolated"] - 1
                       if asymptotic and math.isfinite(rich["extrapolated"]) else math.nan)
                out.append({"series": series, "compartment": c, "quantity": key,
                            "size_ratio_21": sizes[1] / sizes[2],
                            "size_ratio_32": sizes[0] / sizes[1],
                            "coarse": values[0], "medium": values[1], "fine": fine,
                            "order": rich["order"], "extrapolated": rich["extrapolated"],
                            "default_level": default["level"],
                            "default_value": default[f"{c}_fe_{key}"],
                            "default_error": err,
                            "default_vs_finest": default[f"{c}_fe_{key}"] / fine - 1,
                            "last_step": fine / values[1] - 1,
                            "spread": spread,
                            "status": rich["status"]})
    return out


def print_levels(rows: list[dict]) -> None:
    print(f"\n{'series':9s}{'level':28s}{'faces':>7s}{'edge':>6s}{'dofs':>8s} | "
          f"{'p_max med':>9s}{'lat':>6s} | {'on EF faces':>11s}{'lat':>6s} | "
          f"{'area med':>8s}{'lat':>6s} | {'share':>6s} | {'FE s':>6s}{'RSS MB':>7s}")
    for r in rows:
        head = f"{r['series']:9s}{r['level']:28s}"
        if r["failed"]:
            print(f"{head} failed: {r['failed'][:90]}")
            continue
        print(f"{head}{r['tibial_faces_fe']:7d}{r['edge_mm']:6.2f}{r['fe_dofs']:8d} | "
              f"{r['medial_fe_pmax']:9.3f}{r['lateral_fe_pmax']:6.3f} | "
              f"{r['medial_fe_pmax_faces']:11.3f}{r['lateral_fe_pmax_faces']:6.3f} | "
              f"{r['medial_fe_area']:8.1f}{r['lateral_fe_area']:6.1f} | "
              f"{r['medial_share_fe']:6.3f} | {r['fe_s']:6.1f}{r['peak_rss_MB']:7.0f}")


def print_richardson(est: list[dict]) -> None:
    print(f"\n{'series':9s}{'quantity':19s}{'coarse':>8s}{'medium':>8s}{'fine':>8s}"
          f"{'order':>7s}{'extrap.':>9s} | error of the default level")
    for e in est:
        name = f"{e['compartment']} {e['quantity']}"
        order = f"{e['order']:7.2f}" if math.isfinite(e["order"]) else f"{'–':>7s}"
        if math.isfinite(e["default_error"]):
            tail = (f"{e['extrapolated']:9.3f} | {e['default_level']}: "
                    f"{100 * e['default_error']:+.1f} % against the extrapolation")
        else:
            against = (f"{e['default_level']} {100 * e['default_vs_finest']:+.1f} % against "
                       "the finest level; " if e["default_vs_finest"] else "")
            tail = (f"{'–':>9s} | {e['status']}: {against}last step "
                    f"{100 * e['last_step']:+.1f} %")
        print(f"{e['series']:9s}{name:19s}{e['coarse']:8.3f}{e['medium']:8.3f}"
              f"{e['fine']:8.3f}{order}{tail}")
    print(f"(an order outside {ORDER_RANGE[0]:g}-{ORDER_RANGE[1]:g} is taken as not yet "
          "asymptotic: no extrapolation is claimed)")


def write_csv(rows: list[dict], path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    names = list(dict.fromkeys(k for r in rows for k in r))
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=names)
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {path}")


def plot(rows: list[dict], est: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in rows if not r["failed"]]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    panels = ((axes[0], ("pmax", "pmax_faces"), "p_max (MPa)"),
              (axes[1], ("area",), "area (mm²)"))
    for ax, keys, unit in panels:
        for series, key, style in ((ser, k, st) for ser, st in (("refine", "o-"),
                                                                 ("decimate", "s--"))
                                   for k in keys
                                   if k != "pmax_faces" or ser in SAME_EF_FACES):
            sub = [r for r in ok if r["series"] == series]
            for c, color in (("medial", "C0"), ("lateral", "C3")):
                if not sub:
                    continue
                face = key == "pmax_faces"
                ax.plot([r["edge_mm"] for r in sub], [r[f"{c}_fe_{key}"] for r in sub],
                        style, color=color, alpha=0.45 if face else 1.0,
                        mfc="none" if face else color,
                        label=f"{c}, {series}" + (", on EF faces" if face else ""))
                ext = [e for e in est if (e["series"], e["compartment"], e["quantity"])
                       == (series, c, key) and math.isfinite(e["default_error"])]
                if ext:
                    ax.plot([0.0], [ext[0]["extrapolated"]], marker="*", ms=11,
                            color=color, ls="none")
        ax.set_xlim(left=-0.15)
        ax.set_xlabel("FE surface element size (equilateral edge, mm)")
        ax.set_ylabel(unit)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6.5, title="★ Richardson extrapolation", title_fontsize=7)
    sub = [r for r in ok if r["series"] == "layers"]
    if sub:
        finest = sub[-1]
        for c, color in (("medial", "C0"), ("lateral", "C3")):
            for key, style in (("pmax", "o-"), ("area", "s--")):
                axes[2].plot([r["layers"] for r in sub],
                             [100 * (r[f"{c}_fe_{key}"] / finest[f"{c}_fe_{key}"] - 1)
                              for r in sub], style, color=color, label=f"{c} {key}")
        axes[2].set_xticks([r["layers"] for r in sub])
        axes[2].legend(fontsize=7)
    axes[2].axhline(0, color="k", lw=0.8)
    axes[2].set_xlabel("levels of elements through the thickness (fe.layers)")
    axes[2].set_ylabel(f"change against {sub[-1]['layers'] if sub else '?'} layers (%)")
    axes[2].grid(alpha=0.3)
    fig.suptitle("FE of the scanned femur on the scanned tibia: mesh convergence")
    print(f"wrote {save_figure(fig, path)}")


def main(argv: list[str] | None = None) -> int:
    args = knee_script_args(__doc__.splitlines()[0],
                            "refine 0/1/2 and layers 2/3/4 on a ~150-face surface", argv)
    if args is None:
        return 0
    rows, failed = run_plan(series_plan(args.quick))
    print_levels(rows)
    est = analyse(rows)
    print_richardson(est)
    write_csv(rows, args.out / "fe_scanned_convergence.csv")
    if est:
        write_csv(est, args.out / "fe_scanned_richardson.csv")
    plot(rows, est, args.out / "fe_scanned_convergence.png")
    if failed:
        print(f"{failed} level(s) failed (see above)")
    return 0 if any(not r["failed"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
