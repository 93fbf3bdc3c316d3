"""Error versus samples per pixel against the Mitsuba reference: the convergence figure.

For each integrator, K independent replicas are rendered at every spp of a
geometric ladder (default 1, 4, 16, 64, 256) and compared with the committed
Mitsuba 3 reference (4096 spp, its own noise subtracted). The figure shows

1. RMSE vs spp, log-log: median over replicas, min-max band, the fitted slope
   with its 95 % CI (:func:`mitsuba_refs.stats.convergence_law`) and the
   N^-1/2 guide: a correct Monte Carlo estimator runs parallel to it;
2. relMSE vs spp (error relative to pixel brightness), with the N^-1 guide;
3. RMSE vs render seconds (one core): at equal time, the lowest curve wins;
   efficiency = 1 / (MSE x seconds) is in the legend.

It prints a verdict table (slope, RMSE(N)/RMSE(4N), mean agreement at 64
spp, time) and writes convergence.png/.svg, convergence.csv (every render),
summary.csv/.json and results.jsonl (rerunning resumes from it).

Run: ``python -m experiments.convergence [--scene cornell-box] [--out out/convergence]``
"""
from __future__ import annotations

import argparse
import math
import sys

import numpy as np

from mitsuba_refs.report.wording import verdict_line
from mitsuba_refs.stats import compare_means, convergence_law, effective_rows, rare_errors_dominate, reference_mse_floor

from . import common

DEFAULT_INTEGRATORS = ("path", "path_nee", "path_bsdf")
DEFAULT_LADDER = (1, 4, 16, 64, 256)
DEFAULT_REPLICAS = 4
#: spp at which the mean is compared with the reference (the references are 64x as precise).
AGREEMENT_SPP = 64


def build_parser():
    """The command line of the error-vs-spp experiment."""
    parser = argparse.ArgumentParser(
        prog="python -m experiments.convergence", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scene", default="cornell-box", help="built-in scene or XML file (default: cornell-box)")
    parser.add_argument("--integrators", nargs="+", default=list(DEFAULT_INTEGRATORS),
                        help="integrators to compare (default: %(default)s)")
    parser.add_argument("--spp", nargs="+", type=int, default=list(DEFAULT_LADDER),
                        help="spp ladder, increasing, >= 3 levels (default: %(default)s)")
    parser.add_argument("--replicas", type=int, default=DEFAULT_REPLICAS,
                        help="independent renders per level (default: %(default)s)")
    parser.add_argument("--seed", type=int, default=5000, help="base seed (default: %(default)s)")
    parser.add_argument("--alpha", type=float, default=0.01,
                        help="significance level of each verdict (default: %(default)s)")
    common.add_run_args(parser, "out/convergence")
    return parser


def make_tasks(scene, params, integrators, ladder, replicas, seed):
    """One render per integrator, replica and ladder level, each with its own seed."""
    tasks = []
    for i, name in enumerate(integrators):
        for k in range(replicas):
            for j, n in enumerate(ladder):
                tasks.append(common.Task.make(scene, name, n, seed + 100_000 * i + 1000 * k + j, params,
                                              replica=k, level=j))
    return tasks


def analyse(store, tasks, references, ladder, replicas, alpha):
    """Per integrator: (K, L) tables of mse, relmse, seconds and the convergence law."""
    out = {}
    for name, ref in references.items():
        shape = (replicas, len(ladder))
        table = {m: np.full(shape, np.nan) for m in ("mse", "relmse", "seconds")}
        agreement = None
        for task in tasks:
            if task.integrator != name:
                continue
            record = store.get(task)
            labels = dict(task.labels)
            for m in table:
                table[m][labels["replica"], labels["level"]] = record[m]
            if "agree" in record:
                agreement = record
        law = None
        if np.isfinite(table["mse"]).all() and replicas >= 2 and len(ladder) >= 3:
            try:
                law = convergence_law(np.array(ladder), table["mse"],
                                      ref_mse_floor=reference_mse_floor(ref.var, ref.n),
                                      alpha=alpha, image_mean=float(ref.mean.mean()))
            except ValueError as error:
                print(f"note: {name}: no convergence law ({error})", file=sys.stderr)
        out[name] = dict(table, law=law, agreement=agreement,
                         lowest_effective=rare_path_caution(table["mse"][:, 0]))
    return out


def rare_path_caution(lowest_mses) -> float | None:
    """Kish's effective number of replicas at the lowest level when a few carry its MSE, else None.

    Every level has the same replicas here, so rare bright paths (small lights, caustics)
    are mostly absent from the 1-spp renders and, when present, dominate their mean: the
    slope can then flatten for a correct tracer. ``mitsuba_refs.verdicts.compare`` avoids this with
    equal samples per level; the figure only warns.
    """
    lowest = np.asarray(lowest_mses, dtype=float)
    if lowest.size < 2 or not np.isfinite(lowest).all() or not rare_errors_dominate(lowest):
        return None
    return effective_rows(lowest)


def summary_rows(results, ladder):
    """One table row per integrator: the convergence law's fit and the efficiency at the top level."""
    rows = []
    best = max((1.0 / (np.nanmedian(r["mse"][:, -1]) * np.nanmedian(r["seconds"][:, -1]))
                for r in results.values()), default=1.0)
    for name, r in results.items():
        law, agreement = r["law"], r["agreement"] or {}
        mse_top, sec_top = np.nanmedian(r["mse"][:, -1]), np.nanmedian(r["seconds"][:, -1])
        efficiency = 1.0 / (mse_top * sec_top) if mse_top > 0 else math.inf
        rows.append(dict(
            integrator=name,
            mse_slope=law.slope if law else math.nan,
            mse_slope_lo=law.slope_ci[0] if law else math.nan,
            mse_slope_hi=law.slope_ci[1] if law else math.nan,
            rmse_ratio_4x=law.ratio if law else math.nan,
            rmse_ratio_lo=law.ratio_ci[0] if law else math.nan,
            rmse_ratio_hi=law.ratio_ci[1] if law else math.nan,
            convergence_passed=law.passed if law else None,
            convergence_verdict=verdict_line(law) if law else "",
            mean_agrees=agreement.get("agree"),
            mean_p=agreement.get("p_value"),
            mean_rel_bias=agreement.get("rel_bias"),
            mean_verdict=agreement.get("verdict", ""),
            rmse_at_max_spp=math.sqrt(max(mse_top, 0.0)),
            seconds_at_max_spp=sec_top,
            seconds_total=float(np.nansum(r["seconds"])),
            efficiency=efficiency,
            efficiency_relative=efficiency / best if math.isfinite(best) and best > 0 else math.nan,
            max_spp=ladder[-1]))
    return rows


def print_table(rows, file=sys.stdout):
    """Print the summary rows as an aligned table."""
    head = (f"{'integrator':<11} {'RMSE slope [95% CI]':<26} {'RMSE(N)/RMSE(4N)':<20} "
            f"{'mean vs Mitsuba':<24} {'time':>7} {'efficiency':>10}  verdict")
    print(head, file=file)
    print("-" * len(head), file=file)
    for r in rows:
        slope = (f"{r['mse_slope'] / 2:+.3f} [{r['mse_slope_lo'] / 2:+.3f}, {r['mse_slope_hi'] / 2:+.3f}]"
                 if math.isfinite(r["mse_slope"]) else "n/a")
        ratio = (f"{r['rmse_ratio_4x']:.2f} [{r['rmse_ratio_lo']:.2f}, {r['rmse_ratio_hi']:.2f}]"
                 if math.isfinite(r["rmse_ratio_4x"]) else "n/a")
        if r["mean_agrees"] is None:
            mean = "not tested"
        else:
            bias = r["mean_rel_bias"]
            mean = (("agrees" if r["mean_agrees"] else "DIFFERS")
                    + (f" ({100 * bias:+.2f}%)" if bias is not None and math.isfinite(bias) else ""))
        ok = r["convergence_passed"] and r["mean_agrees"] is not False
        verdict = "PASS" if ok else "FAIL"
        print(f"{r['integrator']:<11} {slope:<26} {ratio:<20} {mean:<24} {r['seconds_total']:6.1f}s "
              f"{r['efficiency_relative']:9.2f}x  {verdict}", file=file)


def plot(results, ladder, title, out):
    """Draw RMSE against spp for every integrator; return the figure paths."""
    import matplotlib  # matplotlib: heavy, imported only to draw
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    N = np.asarray(ladder, dtype=float)
    fig, axes = plt.subplots(1, 3, figsize=(18, 5.6))
    firsts_rmse, firsts_rel = [], []
    for name, r in results.items():
        colour = common.COLOURS.get(name, None)
        law = r["law"]
        with np.errstate(invalid="ignore"):
            rmse = np.sqrt(np.where(r["mse"] > 0, r["mse"], np.nan))
            rel = np.where(r["relmse"] > 0, r["relmse"], np.nan)
        med = np.nanmedian(rmse, axis=0)
        firsts_rmse.append(med[0])
        if law:
            label = (f"{name}: RMSE ∝ N^{law.slope / 2:.3f} "
                     f"[{law.slope_ci[0] / 2:.3f}, {law.slope_ci[1] / 2:.3f}]")
        else:
            label = name
        ax = axes[0]
        ax.fill_between(N, np.nanmin(rmse, 0), np.nanmax(rmse, 0), color=colour, alpha=0.2, lw=0)
        ax.plot(N, med, "o-", color=colour, label=label)
        if law:  # fitted line through the median's geometric centre
            b = law.slope / 2
            a = np.nanmean(np.log(med) - b * np.log(N))
            ax.plot(N, np.exp(a) * N ** b, ":", color=colour, lw=1)

        rel_med = np.nanmedian(rel, axis=0)
        firsts_rel.append(rel_med[0])
        axes[1].fill_between(N, np.nanmin(rel, 0), np.nanmax(rel, 0), color=colour, alpha=0.2, lw=0)
        axes[1].plot(N, rel_med, "o-", color=colour, label=name)

        seconds = np.nanmedian(r["seconds"], axis=0)
        mse_med = np.nanmedian(r["mse"], axis=0)
        eff = 1.0 / (mse_med[-1] * seconds[-1]) if mse_med[-1] > 0 else math.inf
        axes[2].plot(seconds, med, "o-", color=colour,
                     label=f"{name}: efficiency 1/(MSE·t) = {eff:.3g}")
        for n, s, m in zip(N, seconds, med):
            axes[2].annotate(f"{int(n)}", (s, m), textcoords="offset points", xytext=(4, 4),
                             fontsize=7, color=colour)

    guide = np.geomspace(N[0], N[-1], 50)
    y0 = np.exp(np.nanmean(np.log(firsts_rmse)))
    axes[0].plot(guide, y0 * (guide / N[0]) ** -0.5, "k--", lw=1.2, label="N^-1/2 guide (the law)")
    r0 = np.exp(np.nanmean(np.log(firsts_rel)))
    axes[1].plot(guide, r0 * (guide / N[0]) ** -1.0, "k--", lw=1.2, label="N^-1 guide")

    axes[0].set(xlabel="samples per pixel N", ylabel="RMSE vs Mitsuba reference [radiance]",
                title="RMSE vs spp (median and min–max band over replicas)")
    axes[1].set(xlabel="samples per pixel N", ylabel=f"relMSE  (mean (t−r)² / (r² + {common.RELMSE_EPS:g}))",
                title="relative MSE vs spp")
    axes[2].set(xlabel="render time [s, one core]", ylabel="RMSE vs Mitsuba reference [radiance]",
                title="error vs time (lower-left is better; labels = spp)")
    for ax in axes:
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8, loc="lower left")
    fig.suptitle(title, fontsize=12)
    fig.tight_layout()
    return common.save_figure(fig, out, "convergence")


def main(argv=None) -> int:
    """Run the error-vs-spp experiment (command line); exit code."""
    args = build_parser().parse_args(argv)
    ladder = sorted(set(args.spp))
    if len(ladder) < 3 and args.replicas >= 2:
        print("note: the slope test needs >= 3 spp levels", file=sys.stderr)
    out = common.out_dir(args.out)
    params = common.scene_params(args.scene, args.defines)
    references = {}
    for name in args.integrators:
        ref = common.get_reference(args.scene, params, name)
        if ref is not None:
            references[name] = ref
    if not references:
        print("error: no reference for any integrator; nothing to compare", file=sys.stderr)
        return 2
    integrators = [n for n in args.integrators if n in references]
    tasks = make_tasks(args.scene, params, integrators, ladder, args.replicas, args.seed)
    agreement_spp = max([n for n in ladder if n <= AGREEMENT_SPP], default=None)

    def on_result(task, output):
        ref = references[task.integrator]
        record = common.error_metrics(output["mean"], ref)
        if task.spp == agreement_spp and dict(task.labels)["replica"] == 0:
            agreement = compare_means(output["mean"], output["variance"], task.spp,
                                      ref.mean, ref.var, ref.n, alpha=args.alpha)
            record.update(agree=agreement.agree, p_value=agreement.p_value,
                          rel_bias=agreement.rel_bias, verdict=verdict_line(agreement))
        return record

    store = common.ResultStore(out / "results.jsonl")
    common.run_tasks(tasks, store, on_result, workers=args.workers, dask=args.dask,
                     progress=not args.no_progress, desc="convergence")
    results = analyse(store, tasks, {n: references[n] for n in integrators}, ladder,
                      args.replicas, args.alpha)
    rows = summary_rows(results, ladder)
    h, w = next(iter(references.values())).mean.shape[:2]
    title = (f"Convergence on {args.scene} ({w}×{h} px): error against the Mitsuba 3 reference "
             f"({next(iter(references.values())).n} spp), {args.replicas} independent replicas per point")
    figures = plot(results, ladder, title, out)
    raw = [dict(store.get(t)["task"], **{k: store.get(t)[k] for k in ("mse", "rmse", "relmse", "seconds")})
           for t in tasks]
    common.write_csv(out / "convergence.csv", raw)
    common.write_csv(out / "summary.csv", rows)
    common.write_json(out / "summary.json", dict(scene=args.scene, params=params, ladder=ladder,
                                                 replicas=args.replicas, alpha=args.alpha, rows=rows))
    print_table(rows)
    for r in rows:
        print(f"  {r['integrator']}: {r['convergence_verdict']}")
        effective = results[r["integrator"]]["lowest_effective"]
        if effective is not None:
            print(f"  {r['integrator']}: caution: {effective:.1f} of "
                  f"{args.replicas} replicas carry the {ladder[0]}-spp error (rare bright paths); "
                  "the slope can flatten for a correct tracer: raise --replicas, or use "
                  "`mitsuba-refs compare` (equal samples per level)")
        if r["mean_verdict"]:
            print(f"  {r['integrator']}: mean at {agreement_spp} spp: {r['mean_verdict']}")
    print(f"wrote {', '.join(figures)}, {out / 'summary.csv'}, {out / 'convergence.csv'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
