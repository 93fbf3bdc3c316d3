"""Sweeps at scale: scenes x integrators x spp x seeds on a process pool or a Dask cluster.

Every combination is one task (one render on one core). Tasks run on any
``concurrent.futures`` executor: a local process pool by default, or a Dask
cluster with ``--dask tcp://SCHEDULER:8786`` (``--dask local`` starts a
LocalCluster), so a class can spread a large sweep over many machines: start
``dask scheduler`` on one machine and ``dask worker tcp://SCHEDULER:8786`` on
the others (each with this project installed at the same commit, and the
scene files at the same paths), then run this script anywhere.

Each finished render appends one line to ``results.jsonl`` at once; rerun the
same command after an interruption and only the missing renders run. Metrics
(MSE, RMSE, relMSE against the Mitsuba reference, the reference's own noise
removed) are computed by the driver, so workers need no references.

Writes results.jsonl, sweep.csv (one row per render), summary.csv (median over
seeds) and sweep.png/.svg (RMSE vs spp, one panel per scene).
Run: ``python -m experiments.sweep --scenes cornell-box furnace --spp 1 4 16 --seeds 3``
"""
from __future__ import annotations

import argparse
import math
import sys

import numpy as np

from . import common


def build_parser():
    """The command line of the parameter sweep."""
    parser = argparse.ArgumentParser(
        prog="python -m experiments.sweep", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scenes", nargs="+", default=["cornell-box", "cornell-caustics"],
                        help="built-in scenes or XML files (default: %(default)s)")
    parser.add_argument("--integrators", nargs="+", default=["path", "path_nee", "path_bsdf"],
                        help="integrators (default: %(default)s)")
    parser.add_argument("--spp", nargs="+", type=int, default=[1, 4, 16],
                        help="samples per pixel (default: %(default)s)")
    parser.add_argument("--seeds", type=int, default=2, help="independent renders per point (default: %(default)s)")
    parser.add_argument("--seed", type=int, default=20000, help="base seed (default: %(default)s)")
    parser.add_argument("--max-depth", type=int, default=None, help="integrator max_depth (default: the scene's)")
    common.add_run_args(parser, "out/sweep")
    return parser


def make_tasks(scenes, integrators, spps, seeds, base_seed, defines=(), options=None):
    """One render per scene, integrator, spp and seed."""
    tasks = []
    for a, scene in enumerate(scenes):
        params = common.scene_params(scene, defines) if not scene.endswith(".xml") else dict(defines)
        for b, integrator in enumerate(integrators):
            for c, spp in enumerate(spps):
                for k in range(seeds):
                    seed = base_seed + 1_000_000 * a + 10_000 * b + 100 * c + k
                    tasks.append(common.Task.make(scene, integrator, spp, seed, params, options,
                                                  replica=k))
    return tasks


def run_sweep(tasks, out, *, workers=None, dask=None, pool=None, progress=True):
    """Run (or resume) a sweep; return the store. Metrics need the references of each
    (scene, params, integrator); missing ones leave the error fields empty."""
    out = common.out_dir(out)
    references = {}

    def reference_for(task):
        key = (task.scene, task.params, task.integrator, task.options)
        if key not in references:
            params = {**dict(task.params), **{k: v for k, v in dict(task.options).items()
                                             if k in ("max_depth", "rr_depth")}}
            references[key] = common.get_reference(task.scene, params, task.integrator, quiet=True)
        return references[key]

    def on_result(task, output):
        record = dict(image_mean=float(output["mean"].mean()),
                      variance=float(output["variance"].mean()))
        ref = reference_for(task)
        if ref is not None and ref.mean.shape == output["mean"].shape:
            record.update(common.error_metrics(output["mean"], ref))
        return record

    store = common.ResultStore(out / "results.jsonl")
    common.run_tasks(tasks, store, on_result, workers=workers, dask=dask, pool=pool,
                     progress=progress, desc="sweep")
    return store


def summarise(store, tasks):
    """One row per finished task, with its metrics, from the result store."""
    rows = []
    for task in tasks:
        record = store.get(task)
        rows.append(dict(record["task"], seconds=record["seconds"], host=record.get("host"),
                         image_mean=record.get("image_mean"), variance=record.get("variance"),
                         mse=record.get("mse"), rmse=record.get("rmse"), relmse=record.get("relmse")))
    groups = {}
    for row in rows:
        groups.setdefault((row["scene"], row["integrator"], row["spp"]), []).append(row)
    summary = []
    for (scene, integrator, spp), group in groups.items():
        def med(key):
            values = [g[key] for g in group if g.get(key) is not None]
            return float(np.median(values)) if values else math.nan
        summary.append(dict(scene=scene, integrator=integrator, spp=spp, renders=len(group),
                            rmse_median=med("rmse"), relmse_median=med("relmse"),
                            seconds_median=med("seconds"), image_mean_median=med("image_mean")))
    return rows, summary


def plot(summary, rows, out):
    """Draw RMSE against spp per scene; return the figure paths."""
    import matplotlib  # matplotlib: heavy, imported only to draw
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    scenes = list(dict.fromkeys(s["scene"] for s in summary))
    fig, axes = plt.subplots(1, len(scenes), figsize=(5.6 * len(scenes), 4.6), squeeze=False)
    for ax, scene in zip(axes[0], scenes):
        drawn = False
        for integrator in dict.fromkeys(s["integrator"] for s in summary):
            pts = sorted((s["spp"], s["rmse_median"]) for s in summary
                         if s["scene"] == scene and s["integrator"] == integrator)
            if not pts or not any(math.isfinite(v) for _, v in pts):
                continue
            spp, rmse = np.array(pts, dtype=float).T
            ax.plot(spp, rmse, "o-", color=common.COLOURS.get(integrator), label=integrator)
            each = [(r["spp"], r["rmse"]) for r in rows if r["scene"] == scene and
                    r["integrator"] == integrator and r["rmse"] is not None]
            if each:
                xs, ys = np.array(each, dtype=float).T
                ax.plot(xs, ys, ".", color=common.COLOURS.get(integrator), alpha=0.35)
            drawn = True
        if drawn:
            finite = [s for s in summary if s["scene"] == scene and math.isfinite(s["rmse_median"])]
            n0 = min(s["spp"] for s in finite)
            y0 = np.exp(np.mean([np.log(s["rmse_median"]) for s in finite if s["spp"] == n0]))
            guide = np.geomspace(n0, max(s["spp"] for s in finite), 20)
            ax.plot(guide, y0 * (guide / n0) ** -0.5, "k--", lw=1, label="N^-1/2")
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.legend(fontsize=8)
        else:
            ax.text(0.5, 0.5, "no Mitsuba reference:\nno error to plot", ha="center",
                    transform=ax.transAxes)
        ax.set(title=scene, xlabel="samples per pixel N", ylabel="RMSE vs Mitsuba reference [radiance]")
        ax.grid(True, which="both", alpha=0.3)
    fig.suptitle("Sweep: median RMSE over seeds (dots: single renders)", fontsize=11)
    fig.tight_layout()
    return common.save_figure(fig, out, "sweep")


def main(argv=None) -> int:
    """Run the sweep (command line); exit code."""
    args = build_parser().parse_args(argv)
    options = {} if args.max_depth is None else {"max_depth": args.max_depth}
    tasks = make_tasks(args.scenes, args.integrators, sorted(set(args.spp)), args.seeds, args.seed,
                       args.defines, options)
    store = run_sweep(tasks, args.out, workers=args.workers, dask=args.dask, progress=not args.no_progress)
    rows, summary = summarise(store, tasks)
    common.write_csv(args.out / "sweep.csv", rows)
    common.write_csv(args.out / "summary.csv", summary)
    figures = plot(summary, rows, args.out)
    hosts = sorted({r["host"] for r in rows if r.get("host")})
    print(f"{len(tasks)} renders ({len(store)} in {args.out / 'results.jsonl'}) on {len(hosts)} host(s)")
    print(f"{'scene':<18} {'integrator':<11} {'spp':>5} {'RMSE':>9} {'relMSE':>9} {'seconds':>8}")
    for s in summary:
        print(f"{s['scene']:<18} {s['integrator']:<11} {s['spp']:5d} {s['rmse_median']:9.4g} "
              f"{s['relmse_median']:9.4g} {s['seconds_median']:8.2f}")
    print(f"wrote {', '.join(figures)}, {args.out / 'sweep.csv'}, {args.out / 'summary.csv'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
