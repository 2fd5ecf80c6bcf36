"""`fecheck atlas [SCENE] --vary KEY=DIST [--vary ...] --fe N`: where the EF is within a tolerance
of the FE over some keys, from an error model fitted to N FE runs.

Only the standard library is imported here; the study inside `run`.

Exit codes: 0 done, 2 a user error before the first run, 130 interrupted.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
from pathlib import Path

from fecheck.cli import add_scene_arguments


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "atlas", help="where the EF is within a tolerance of the FE over some scene keys",
        description="Run the EF at many samples of the --vary keys and the FE (`fecheck fe`) "
                    "at N design points (space-filling first, then where the error model "
                    "is least sure); fit one Gaussian process per error (p_max, area, "
                    "split, centre of pressure), cross-validate it, and report the region "
                    "where the EF is within the tolerance of the FE.")
    add_scene_arguments(p, "override a scene key for every run (TOML literal)")
    p.add_argument("--vary", action="append", required=True, metavar="KEY=DIST",
                   help="a key and its distribution, as for `fecheck population`")
    p.add_argument("--fe", type=int, required=True, metavar="N",
                   help="number of FE design points (at least 3 + the number of keys)")
    p.add_argument("--samples", type=int, default=1000, metavar="M",
                   help="EF samples where the region is mapped (default 1000)")
    p.add_argument("--holdout", type=int, default=0, metavar="H",
                   help="H more FE runs at random points the model never saw, checked "
                        "against its stated error")
    p.add_argument("--tolerance", type=float, default=0.05,
                   help="relative tolerance of p_max and area, and of the medial share "
                        "(default 0.05)")
    p.add_argument("--seed", type=int, default=0, help="seed of the designs (default 0)")
    p.add_argument("--json", metavar="PATH", help="write the atlas as JSON")
    p.add_argument("--plot", type=Path, metavar="DIR",
                   help="write error maps over pairs of keys and partial dependence (PNG)")
    p.add_argument("--workers", type=int, default=1, metavar="N",
                   help="run the EF samples and FE points in N local processes")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run them on a Dask distributed scheduler (needs fecheck[dask])")
    p.set_defaults(run=run)


def _say(text: str) -> None:
    print(f"fecheck atlas: {text}", file=sys.stderr, flush=True)


def _check(args, scene, varied) -> None:
    from fecheck.errors import FecheckError
    from fecheck.io.outputs import check_output

    d = len(varied)
    if args.fe < d + 3:
        raise FecheckError(f"--fe {args.fe}: an error model over {d} key(s) needs at least "
                           f"{d + 3} FE design points")
    if args.samples < 10:
        raise FecheckError(f"--samples {args.samples}: give at least 10 EF samples")
    if args.holdout < 0 or args.workers < 1:
        raise FecheckError("--holdout must be 0 or more and --workers at least 1")
    if not 0.0 < args.tolerance < 1.0:
        raise FecheckError(f"--tolerance {args.tolerance:g}: give a fraction between 0 and 1")
    check_output(args.json)
    check_output(args.plot, directory=True)


def _design(args, scene, varied, model_u, executor, fe_done):
    """The FE design: space-filling first (half), then batches where the model is least
    sure; returns (u of the solved points, their errors, the model)."""
    import numpy as np

    from fecheck.studies import atlas

    d = len(varied)
    first = max(d + 3, args.fe // 2)
    batch = max(1, args.workers)
    u = atlas.initial_design(first, d, args.seed)
    todo = list(range(first))
    points = [tuple(o) for o in atlas.atlas_points(varied, scene, u)]
    while True:
        found = atlas.run_fe(scene, points, todo, executor, _say)
        fe_done.update(found)
        solved = [i for i in sorted(fe_done) if not isinstance(fe_done[i], str)]
        errors = {o: np.array([fe_done[i][o] for i in solved]) for o in atlas.OUTPUTS}
        if len(fe_done) >= args.fe:
            model = atlas.fit_error_model(u[solved], errors, args.seed)
            return u[solved], errors, model, [i for i in fe_done if i not in solved]
        model = atlas.fit_error_model(u[solved], errors, args.seed, cross_validate=False)
        k = min(batch, args.fe - len(fe_done))
        pick = atlas.least_sure(model, model_u, u, k)
        start = len(u)
        u = np.vstack([u, model_u[pick]])
        points += [tuple(o) for o in atlas.atlas_points(varied, scene, model_u[pick])]
        todo = list(range(start, len(u)))


def _holdout(args, scene, varied, model, executor) -> dict:
    """FE at --holdout random points: the model's prediction against the FE."""
    import numpy as np

    from fecheck.studies import atlas

    rng = np.random.default_rng(args.seed + 104729)
    u = rng.random((args.holdout, len(varied)))
    points = [tuple(o) for o in atlas.atlas_points(varied, scene, u)]
    found = atlas.run_fe(scene, points, list(range(args.holdout)), executor, _say)
    solved = [i for i in sorted(found) if not isinstance(found[i], str)]
    pred = model.predict(u[solved]) if solved else {}
    out = {"points": len(solved), "failed": args.holdout - len(solved), "outputs": {}}
    for name in model.models:
        if not solved:
            break
        actual = np.array([found[i][name] for i in solved])
        miss = pred[name][0] - actual
        miss = miss[np.isfinite(miss)]          # the calibrated EF may not run everywhere
        if miss.size == 0:
            continue
        stated = model.cv_rmse[name]
        out["outputs"][name] = {
            "stated_rmse": stated, "rmse": float(np.sqrt(np.mean(miss**2))),
            "max_abs": float(np.max(np.abs(miss))), "points": int(miss.size),
            "within_2_stated": float(np.mean(np.abs(miss) <= 2.0 * stated))}
    return out


def _print(args, varied, model, pred, ranges, within, holdout) -> None:
    from fecheck.studies import atlas

    print(f"error model: {model.n_points} FE design points; cross-validated RMSE of the "
          f"EF's error ({atlas.FOLDS}-fold):")
    for name in model.models:
        unit = " mm" if name == "cop_mm" else ""
        mean = float(pred[name][0].mean())
        print(f"  {name:8s} RMSE {model.cv_rmse[name]:.4g}{unit}   mean over the samples "
              f"{mean:+.4g}{unit}")
    for name, share in within["per_output"].items():
        print(f"EF within {args.tolerance:g} of the FE in {name}: {100 * share:.1f} % of "
              f"the samples")
    print(f"EF within {args.tolerance:g} in p_max, area and split together: "
          f"{100 * within['all']:.1f} % of the samples"
          + ("" if within.get("calibrated") is None else
             f" (the calibrated EF: {100 * within['calibrated']:.1f} %)")
          + "; per key (drawn range -> range where p_max is within):")
    for v in varied:
        r = ranges[v.name]
        print(f"  {v.name:28s} {r['low']:.4g} .. {r['high']:.4g} -> "
              f"{r['within_low']:.4g} .. {r['within_high']:.4g}")
    if holdout:
        print(f"held-out FE runs: {holdout['points']} solved, {holdout['failed']} failed")
        for name, h in holdout["outputs"].items():
            print(f"  {name:8s} RMSE {h['rmse']:.4g} against the stated {h['stated_rmse']:.4g}"
                  f"; largest miss {h['max_abs']:.4g}; {100 * h['within_2_stated']:.0f} % "
                  f"of {h['points']} within twice the stated")


@contextlib.contextmanager
def _local_pool(workers: int):
    """A local process pool for the EF samples and the FE points, ended with the block."""
    from fecheck.studies.pool import ProcessPool, interrupts_ignored

    pool = ProcessPool(workers)
    try:
        yield pool
    finally:
        with interrupts_ignored():
            pool.terminate()


def run(args: argparse.Namespace) -> int:
    """Check, run the EF samples, the FE design and the hold-out, report."""
    import numpy as np

    from fecheck.io.outputs import write_text
    from fecheck.scene import load_scene
    from fecheck.scene.provenance import with_provenance
    from fecheck.studies import atlas
    from fecheck.studies.pool import interrupts_raised
    from fecheck.studies.population import make_plan, run_population
    from fecheck.studies.population_inputs import check_ranges, parse_varied
    from fecheck.studies.sweep import dask_executor

    scene = load_scene(args.scene, args.overrides)
    varied = parse_varied(args.vary, scene)
    check_ranges(varied, scene)
    _check(args, scene, varied)
    plan = make_plan(scene, varied, args.samples, "sobol", args.seed, indices=False)
    if args.scheduler:
        executor = dask_executor(args.scheduler)
    elif args.workers > 1:
        executor = _local_pool(args.workers)
    else:
        executor = contextlib.nullcontext(None)
    fe_done: dict = {}
    with interrupts_raised(), executor as pool:
        samples = run_population(scene, plan, workers=1 if pool is None else args.workers,
                                 executor=pool)
        u_fe, errors, model, failed = _design(args, scene, varied, plan.u, pool, fe_done)
        holdout = _holdout(args, scene, varied, model, pool) if args.holdout else {}
    ef_ok = np.array([samples[i].converged if i in samples else False
                      for i in range(plan.runs)])
    pred = model.predict(plan.u)
    per_output = {n: float(np.mean(np.abs(pred[n][0][ef_ok]) <= args.tolerance))
                  for n in (*atlas.LINEAR, *atlas.CALIBRATED) if n in pred}
    inside = atlas.within(pred, args.tolerance) & ef_ok
    p_inside = (np.abs(pred["p_max"][0]) <= args.tolerance) & ef_ok
    within = {"per_output": per_output, "all": float(inside.mean()), "calibrated": None}
    if all(n in pred for n in atlas.CALIBRATED):
        within["calibrated"] = float(
            (atlas.within(pred, args.tolerance, atlas.CALIBRATED) & ef_ok).mean())
    ranges = atlas.key_ranges(varied, plan.drawn(), p_inside)
    _print(args, varied, model, pred, ranges, within, holdout)
    if args.plot:
        from fecheck.studies import atlas_plots

        for path in atlas_plots.write(args.plot, varied, model, plan, u_fe, args.tolerance):
            print(f"wrote {path}")
    if args.json:
        data = {"scene": scene.source, "tolerance": args.tolerance,
                "keys": {v.name: v.dist.text() for v in varied},
                "ef_samples": plan.runs, "ef_failed": int((~ef_ok).sum()),
                "fe_points": {"solved": int(len(u_fe)), "failed": failed,
                              "values": plan_values(varied, u_fe).tolist(),
                              "errors": {k: v.tolist() for k, v in errors.items()}},
                "cv_rmse": model.cv_rmse, "within": within, "key_ranges": ranges,
                "holdout": holdout}
        write_text(args.json, json.dumps(with_provenance(data, scene), indent=2,
                                         default=float) + "\n")
    return 0


def plan_values(varied, u):
    """(n, d) the drawn values of unit-cube points `u`."""
    import numpy as np

    return np.column_stack([v.drawn(u[:, j]) for j, v in enumerate(varied)])
