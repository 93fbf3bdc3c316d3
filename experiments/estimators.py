"""Estimator comparisons: variance, time and efficiency of the lecture's choices.

Four parts (``--parts``, default all), one figure each:

``mis``        Veach's figure on the glossy ``veach-mis`` scene, direct lighting
               only (max_depth 2): BSDF sampling vs shadow rays (light sampling) vs
               MIS. Where is each strategy better? (log2 variance ratio map)
``hemisphere`` uniform vs cosine-weighted hemisphere sampling (Cornell box): same
               mean, different variance.
``roulette``   Russian roulette off / Mitsuba's rule / the slide's constant q: same
               mean, different time and variance.
``recursive``  recursive Monte Carlo ray tracing with N indirect rays per hit down
               to depth d vs path tracing, at equal time: the cost of one camera
               sample grows like N^d (the slide's "exponential growth"), so at
               equal time the error is larger.

Efficiency is 1 / (variance x time): the inverse of the error reached per second
of rendering; 2x more efficient = half the time for the same noise.
Variances are per-sample variances averaged over pixels and RGB (the variance of
a 1-spp image), so they do not depend on the spp used to estimate them.

Writes estimators-PART.png/.svg, estimators.csv and estimators.json.
Run: ``python -m experiments.estimators [--parts mis recursive]``
"""
from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np

from mitsuba_refs.report.wording import verdict_line
from mitsuba_refs.stats import compare_means
from pathtracer import load_scene
from pathtracer import render as _render
from pathtracer.core.tonemap import auto_scale, tonemap

from . import common

PARTS = ("mis", "hemisphere", "roulette", "recursive")


def build_parser():
    """The command line of the estimator comparisons."""
    parser = argparse.ArgumentParser(
        prog="python -m experiments.estimators", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--parts", nargs="+", choices=PARTS, default=list(PARTS),
                        help="which comparisons to run (default: all)")
    parser.add_argument("--spp", type=int, default=16,
                        help="spp of the hemisphere / roulette renders (default: %(default)s)")
    parser.add_argument("--mis-spp", type=int, default=64, help="spp of the MIS renders (default: %(default)s)")
    parser.add_argument("--mis-scene", default="veach-mis", help="scene of the MIS part (default: veach-mis)")
    parser.add_argument("--mis-size", type=int, nargs=2, default=(128, 96), metavar=("W", "H"))
    parser.add_argument("--scene", default="cornell-box",
                        help="scene of the hemisphere / roulette / recursive parts (default: cornell-box)")
    parser.add_argument("--repeats", type=int, default=2,
                        help="renders per configuration; the fastest time counts (default: %(default)s)")
    parser.add_argument("--budget", type=float, default=2.0,
                        help="recursive part: seconds per configuration at equal time (default: %(default)s)")
    parser.add_argument("--branches", type=int, nargs="+", default=[2, 4, 8],
                        help="recursive part: N indirect rays per hit (default: %(default)s)")
    parser.add_argument("--depths", type=int, nargs="+", default=[1, 2, 3],
                        help="recursive part: branch depths d (default: %(default)s)")
    parser.add_argument("--seed", type=int, default=9000, help="base seed (default: %(default)s)")
    parser.add_argument("--alpha", type=float, default=0.01,
                        help="significance level of the same-mean tests (default: %(default)s)")
    common.add_run_args(parser, "out/estimators")
    return parser


def pixel_variance(variance) -> float:
    """Per-sample variance averaged over pixels and channels."""
    return float(np.mean(variance))


def render(scene, integrator, spp, seed, workers, repeats=1, **options):
    """Render ``repeats`` times with independent seeds: the pooled image, and the *fastest*
    time of one render (timings on a shared machine only ever get slower by noise)."""
    runs = []
    for k in range(max(1, repeats)):
        cpu = time.process_time()
        r = _render(scene, integrator, spp=spp, seed=seed + 7919 * k, processes=workers, progress=False,
                    **options)
        if workers == 1:   # CPU time of this process: immune to other programs on the machine
            r.seconds = time.process_time() - cpu
        runs.append(r)
    if len(runs) == 1:
        return runs[0]
    first = runs[0]
    first.mean = sum(r.mean for r in runs) / len(runs)
    first.variance = sum(r.variance for r in runs) / len(runs)
    first.spp = spp * len(runs)
    first.seconds = min(r.seconds for r in runs) * len(runs)
    return first


def _axes_images(ax, image, exposure, title):
    ax.imshow(tonemap(image, exposure), interpolation="nearest")
    ax.set_title(title, fontsize=9)
    ax.set_xticks([])
    ax.set_yticks([])


def _bars(ax, labels, values, colours, fmt, title, ylabel, log=False):
    x = np.arange(len(labels))
    bars = ax.bar(x, values, color=colours)
    ax.set_xticks(x)
    ax.set_xticklabels(labels, fontsize=8, rotation=15, ha="right")
    ax.set_title(title, fontsize=9)
    ax.set_ylabel(ylabel)
    if log:
        ax.set_yscale("log")
    for b, v in zip(bars, values):
        ax.annotate(fmt.format(v), (b.get_x() + b.get_width() / 2, b.get_height()),
                    ha="center", va="bottom", fontsize=8)
    ax.grid(True, axis="y", alpha=0.3)
    ax.margins(y=0.15)


# ---------------------------------------------------------------------------------------

def part_mis(args, bar):
    """BSDF sampling vs light sampling vs MIS on the glossy plates, direct light only."""
    import matplotlib  # matplotlib: heavy, imported only to draw
    import matplotlib.pyplot as plt

    w, h = args.mis_size
    scene = load_scene(args.mis_scene, **{"width": w, "height": h, **dict(args.defines)})
    configs = [("path_bsdf", "BSDF sampling"), ("path_nee", "light sampling (shadow rays)"),
               ("path", "MIS (power heuristic)")]
    results, rows = {}, []
    for i, (name, label) in enumerate(configs):
        r = render(scene, name, args.mis_spp, args.seed + i, args.workers, args.repeats, max_depth=2)
        results[name] = r
        var = pixel_variance(r.variance)
        seconds_per_spp = r.seconds / r.spp
        rows.append(dict(part="mis", config=label, integrator=name, spp=r.spp, seconds=r.seconds,
                         variance=var, efficiency=1.0 / (var * seconds_per_spp),
                         image_mean=float(r.mean.mean())))
        bar.update()
    best = max(r["efficiency"] for r in rows)
    for r in rows:
        r["efficiency_relative"] = r["efficiency"] / best

    exposure = auto_scale(results["path"].mean)
    fig, axes = plt.subplots(2, 4, figsize=(19, 8.2))
    std = {n: np.sqrt(np.maximum(results[n].variance.mean(axis=2), 0)) for n, _ in configs}
    positive = np.concatenate([s[s > 0] for s in std.values()])
    from matplotlib.colors import LogNorm
    norm = LogNorm(vmin=max(np.percentile(positive, 2), 1e-6), vmax=np.percentile(positive, 99.8))
    for j, (name, label) in enumerate(configs):
        _axes_images(axes[0, j], results[name].mean, exposure, f"{label}\n{results[name].spp} spp, same exposure")
        magma = matplotlib.colormaps["magma"].with_extremes(bad="0.8")
        im = axes[1, j].imshow(np.where(std[name] > 0, std[name], np.nan), norm=norm, cmap=magma,
                               interpolation="nearest")
        axes[1, j].set_title(f"{label}: per-sample std. dev.\n(grey: zero)", fontsize=9)
        axes[1, j].set_xticks([])
        axes[1, j].set_yticks([])
        fig.colorbar(im, ax=axes[1, j], fraction=0.035, pad=0.02).set_label("radiance")
    vb, vl = results["path_bsdf"].variance.mean(axis=2), results["path_nee"].variance.mean(axis=2)
    mb, ml = results["path_bsdf"].mean.mean(axis=2), results["path_nee"].mean.mean(axis=2)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.log2(vb / vl)
    # A strategy that never found the light shows zero variance but a zero mean where the
    # other one sees light: it is the worse one there (infinitely so), not the better.
    ratio = np.where((vb == 0) & (ml > 0), 8.0, ratio)
    ratio = np.where((vl == 0) & (mb > 0), -8.0, ratio)
    ratio = np.where((vb == 0) & (vl == 0), np.nan, np.clip(ratio, -8, 8))
    cmap = matplotlib.colormaps["RdBu"].with_extremes(bad="0.8")
    im = axes[0, 3].imshow(ratio, cmap=cmap, vmin=-8, vmax=8, interpolation="nearest")
    axes[0, 3].set_title("which strategy wins where: log2 var(BSDF) / var(light)\n"
                         "blue: light sampling better, red: BSDF sampling better\n"
                         "(grey: no light reaches the pixel)", fontsize=9)
    axes[0, 3].set_xticks([])
    axes[0, 3].set_yticks([])
    fig.colorbar(im, ax=axes[0, 3], fraction=0.035, pad=0.02).set_label("log2 variance ratio")
    _bars(axes[1, 3], [c[1] for c in configs], [r["efficiency_relative"] for r in rows],
          [common.COLOURS[c[0]] for c in configs], "{:.2f}×",
          "efficiency 1/(variance × time), relative to the best", "relative efficiency")
    fig.suptitle(f"Veach's MIS figure on {args.mis_scene} ({w}×{h} px), direct lighting only "
                 "(max_depth 2): plates get rougher towards the camera, lights smaller to the left",
                 fontsize=11)
    fig.tight_layout()
    return rows, common.save_figure(fig, args.out, "estimators-mis")


def part_hemisphere(args, bar):
    """Uniform vs cosine-weighted hemisphere sampling."""
    import matplotlib.pyplot as plt  # matplotlib: heavy, imported only to draw

    scene = load_scene(args.scene, **common.scene_params(args.scene, args.defines))
    results, rows = {}, []
    for i, integrator in enumerate(("path_bsdf", "path")):
        for hemisphere in ("cosine", "uniform"):
            r = render(scene, integrator, args.spp, args.seed + 10 + i, 1, args.repeats,
                       hemisphere=hemisphere)
            results[integrator, hemisphere] = r
            var = pixel_variance(r.variance)
            rows.append(dict(part="hemisphere", config=f"{integrator}, {hemisphere}", integrator=integrator,
                             hemisphere=hemisphere, spp=r.spp, seconds=r.seconds, variance=var,
                             efficiency=1.0 / (var * r.seconds / r.spp), image_mean=float(r.mean.mean())))
            bar.update()
        cos, uni = results[integrator, "cosine"], results[integrator, "uniform"]
        same = compare_means(uni.mean, uni.variance, uni.spp, cos.mean, cos.variance, cos.spp,
                             alpha=args.alpha)
        for row in rows[-2:]:
            row["same_mean_as_cosine"] = same.agree
            row["same_mean_verdict"] = verdict_line(same)
    for integrator in ("path_bsdf", "path"):
        pair = [r for r in rows if r["integrator"] == integrator]
        for r in pair:
            r["efficiency_relative"] = r["efficiency"] / pair[0]["efficiency"]

    fig, axes = plt.subplots(1, 4, figsize=(19, 4.6))
    exposure = auto_scale(results["path_bsdf", "cosine"].mean)
    _axes_images(axes[0], results["path_bsdf", "cosine"].mean, exposure,
                 f"path_bsdf, cosine-weighted, {results['path_bsdf', 'cosine'].spp} spp")
    _axes_images(axes[1], results["path_bsdf", "uniform"].mean, exposure,
                 f"path_bsdf, uniform hemisphere, {results['path_bsdf', 'uniform'].spp} spp")
    vu = results["path_bsdf", "uniform"].variance.mean(axis=2)
    vc = results["path_bsdf", "cosine"].variance.mean(axis=2)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where((vu == 0) & (vc == 0), np.nan, np.log2((vu + 1e-12) / (vc + 1e-12)))
    im = axes[2].imshow(np.clip(ratio, -4, 4), cmap="RdBu_r", vmin=-4, vmax=4, interpolation="nearest")
    axes[2].set_title("path_bsdf: log2 var(uniform) / var(cosine)\nred: uniform noisier", fontsize=9)
    axes[2].set_xticks([])
    axes[2].set_yticks([])
    fig.colorbar(im, ax=axes[2], fraction=0.046, pad=0.04).set_label("log2 variance ratio")
    _bars(axes[3], [r["config"] for r in rows], [r["efficiency_relative"] for r in rows],
          [common.COLOURS[r["integrator"]] if r["hemisphere"] == "cosine" else "0.6" for r in rows],
          "{:.2f}×", "efficiency relative to cosine sampling\n(same mean: "
          + ", ".join(f"{i} {'yes' if [r for r in rows if r['integrator'] == i][1]['same_mean_as_cosine'] else 'NO'}"
                      for i in ("path_bsdf", "path")) + ")", "relative efficiency")
    fig.suptitle(f"Uniform vs cosine-weighted hemisphere sampling on {args.scene}", fontsize=11)
    fig.tight_layout()
    return rows, common.save_figure(fig, args.out, "estimators-hemisphere")


ROULETTE_CONFIGS = (
    ("off", dict(roulette="off")),
    ("Mitsuba: q=min(max β·η², .95)\nfrom depth 5", dict(roulette="mitsuba", rr_depth=5)),
    ("slide: constant q=0.5\nfrom depth 1", dict(roulette="constant", rr_q=0.5, rr_depth=1)),
    ("constant q=0.2\nfrom depth 1", dict(roulette="constant", rr_q=0.2, rr_depth=1)),
)


def part_roulette(args, bar):
    """Russian roulette on/off: unbiased either way; time vs variance."""
    import matplotlib.pyplot as plt  # matplotlib: heavy, imported only to draw

    params = common.scene_params(args.scene, args.defines)
    scene = load_scene(args.scene, **params)
    reference = common.get_reference(args.scene, params, "path")
    rows = []
    for i, (label, options) in enumerate(ROULETTE_CONFIGS):
        r = render(scene, "path", args.spp, args.seed + 20 + i, 1, args.repeats, **options)
        var = pixel_variance(r.variance)
        row = dict(part="roulette", config=label.replace("\n", " "), integrator="path", spp=r.spp,
                   seconds=r.seconds, variance=var, efficiency=1.0 / (var * r.seconds / r.spp),
                   image_mean=float(r.mean.mean()), **options)
        if reference is not None and reference.mean.shape == r.mean.shape:
            agreement = compare_means(r.mean, r.variance, r.spp, reference.mean, reference.var, reference.n,
                                      alpha=args.alpha)
            row.update(agrees_with_mitsuba=agreement.agree, rel_bias=agreement.rel_bias,
                       mean_verdict=verdict_line(agreement))
        rows.append(row)
        bar.update()
    for r in rows:
        r["efficiency_relative"] = r["efficiency"] / rows[0]["efficiency"]
    labels = [c[0] for c in ROULETTE_CONFIGS]
    colours = ["0.55", "C0", "C1", "C3"]
    fig, axes = plt.subplots(1, 3, figsize=(17, 4.8))
    _bars(axes[0], labels, [1e3 * r["seconds"] / r["spp"] for r in rows], colours, "{:.0f} ms",
          "CPU time per sample per pixel (whole image)", "milliseconds per spp (one core)")
    _bars(axes[1], labels, [r["variance"] for r in rows], colours, "{:.3g}",
          "per-sample variance (mean over pixels)", "variance [radiance²]")
    _bars(axes[2], labels, [r["efficiency_relative"] for r in rows], colours, "{:.2f}×",
          "efficiency 1/(variance × time), relative to 'off'", "relative efficiency")
    if "rel_bias" in rows[0]:
        text = "mean vs Mitsuba: " + "; ".join(
            f"{l.splitlines()[0]} {'agrees' if r['agrees_with_mitsuba'] else 'DIFFERS'} "
            f"({100 * r['rel_bias']:+.1f}%)" for l, r in zip(labels, rows))
        fig.text(0.5, -0.04, text, ha="center", fontsize=9)
    fig.suptitle(f"Russian roulette on {args.scene}, path (MIS), {rows[0]['spp']} spp: "
                 "roulette trades variance for time, without bias", fontsize=11)
    fig.tight_layout()
    return rows, common.save_figure(fig, args.out, "estimators-roulette")


def part_recursive(args, bar):
    """Recursive ray tracing (N branches down to depth d) vs path tracing at equal time."""
    import matplotlib.pyplot as plt  # matplotlib: heavy, imported only to draw

    params = common.scene_params(args.scene, args.defines)
    scene = load_scene(args.scene, **params)
    pilot_scene = load_scene(args.scene, **{**params, "width": 16, "height": 16})
    reference = common.get_reference(args.scene, params, "path")
    pixels = scene.camera.width * scene.camera.height
    configs = [("path tracing", "path", {}, 1, 0)]
    configs += [(f"N={n}, d={d}", "recursive", dict(branches=n, branch_depth=d), n, d)
                for n in args.branches for d in args.depths]
    rows = []
    for i, (label, integrator, options, n, d) in enumerate(configs):
        # pilot: time per camera sample on a small film (the same camera, so the same paths)
        pilot_spp = 4 if n ** d <= 64 else 1
        pilot = render(pilot_scene, integrator, pilot_spp, args.seed + 500 + i, 1, 2, **options)
        per_sample = pilot.seconds / (pilot.spp * 256)          # seconds per camera sample, one core
        est_spp = args.budget * max(1, args.workers or common.cpu_count()) / (per_sample * pixels)
        row = dict(part="recursive", config=label, integrator=integrator, branches=n, branch_depth=d,
                   us_per_camera_sample=1e6 * per_sample)
        if est_spp < 0.34:   # even 1 spp would take 3x the budget: the point of the slide
            row.update(spp=0, seconds=math.nan, rmse=math.nan, note="1 spp exceeds 3x the time budget")
        else:
            spp = max(1, int(round(est_spp)))
            r = render(scene, integrator, spp, args.seed + 600 + i, args.workers, **options)
            row.update(spp=spp, seconds=r.seconds)
            if reference is not None:
                row.update(common.error_metrics(r.mean, reference))
                # the same render time for every configuration: scale the MSE by t / budget
                row["rmse_equal_time"] = math.sqrt(max(row["mse"], 0) * r.seconds / args.budget)
        rows.append(row)
        bar.update()

    fig, axes = plt.subplots(1, 2, figsize=(15, 5.2))
    ax = axes[0]
    pt = rows[0]["us_per_camera_sample"]
    ax.axhline(pt, color="C0", lw=2, label="path tracing (1 ray per bounce)")
    for k, n in enumerate(args.branches):
        sel = [r for r in rows[1:] if r["branches"] == n]
        ds = [r["branch_depth"] for r in sel]
        ax.plot(ds, [r["us_per_camera_sample"] for r in sel], "o-", color=f"C{k + 1}",
                label=f"recursive, N={n} rays per hit")
        dd = np.array(sorted(ds), dtype=float)
        ax.plot(dd, sel[0]["us_per_camera_sample"] * float(n) ** (dd - dd[0]), ":", color=f"C{k + 1}",
                label=f"∝ {n}^d")
    ax.set_yscale("log")
    ax.set_xticks(args.depths)
    ax.set(xlabel="branch depth d (hits above it spawn N indirect rays)",
           ylabel="time per camera sample [µs, one core]",
           title="cost of one camera sample grows exponentially with depth")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)

    ax = axes[1]
    done = [r for r in rows
            if r.get("rmse_equal_time") is not None and math.isfinite(r.get("rmse_equal_time", math.nan))]
    labels = [r["config"] for r in done]
    values = [r["rmse_equal_time"] for r in done]
    colours = ["C0" if r["integrator"] == "path" else f"C{args.branches.index(r['branches']) + 1}" for r in done]
    x = np.arange(len(done))
    bars = ax.bar(x, values, color=colours)
    for b, r in zip(bars, done):
        ax.annotate(f"{r['spp']} spp", (b.get_x() + b.get_width() / 2, b.get_height()), ha="center",
                    va="bottom", fontsize=7)
    skipped = [r["config"] for r in rows if r.get("spp") == 0]
    ax.set_xticks(x)
    ax.set_xticklabels(labels, rotation=30, ha="right", fontsize=8)
    ax.set(ylabel="RMSE vs Mitsuba reference at equal time [radiance]",
           title=f"equal time ({args.budget:g} s each): lower is better"
                 + (f"\nnot rendered (1 spp > 3× budget): {', '.join(skipped)}" if skipped else ""))
    ax.grid(True, axis="y", alpha=0.3)
    ax.margins(y=0.12)
    fig.suptitle(f"Recursive Monte Carlo ray tracing vs path tracing on {args.scene} "
                 f"({scene.camera.width}×{scene.camera.height} px)", fontsize=11)
    fig.tight_layout()
    return rows, common.save_figure(fig, args.out, "estimators-recursive")


def main(argv=None) -> int:
    """Run the estimator comparisons (command line); exit code."""
    args = build_parser().parse_args(argv)
    common.out_dir(args.out)
    args.workers = args.workers or common.cpu_count()
    steps = {"mis": 3, "hemisphere": 4, "roulette": len(ROULETTE_CONFIGS),
             "recursive": 1 + len(args.branches) * len(args.depths)}
    bar = common.progress_bar(sum(steps[p] for p in args.parts), "estimators", not args.no_progress)
    functions = dict(mis=part_mis, hemisphere=part_hemisphere, roulette=part_roulette,
                     recursive=part_recursive)
    rows, figures, timing = [], [], {}
    for part in args.parts:
        start = time.perf_counter()
        part_rows, part_figures = functions[part](args, bar)
        timing[part] = time.perf_counter() - start
        rows += part_rows
        figures += part_figures
    bar.close()
    common.write_csv(args.out / "estimators.csv", rows)
    common.write_json(args.out / "estimators.json", dict(rows=rows, seconds=timing))
    for part in args.parts:
        print(f"== {part} ({timing[part]:.1f} s)")
        for r in rows:
            if r["part"] != part:
                continue
            line = f"  {r['config']:<44}"
            if "variance" in r:
                line += f" var {r['variance']:9.4g}  {r['seconds']:6.2f} s  efficiency {r['efficiency_relative']:5.2f}x"
            if part == "recursive":
                line += f" {r['us_per_camera_sample']:9.0f} us/sample  spp {r['spp']:4d}"
                if r.get("rmse_equal_time") is not None:
                    line += f"  RMSE@equal time {r['rmse_equal_time']:.4f}"
            print(line)
    print(f"wrote {', '.join(f for f in figures if f.endswith('.png'))}, {args.out / 'estimators.csv'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
