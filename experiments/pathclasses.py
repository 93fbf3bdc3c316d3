"""Heckbert path classes: one image per regular expression, and the bounce split against Mitsuba.

Every contribution of the MIS path tracer is routed to the classes whose
expression accepts its path (:mod:`pathtracer.core.pathclasses`,
:mod:`pathtracer.integrators.pathclass`): ``LE`` emitters seen directly, ``LDE``
direct light on diffuse surfaces, ``LDD+E`` diffuse inter-reflection,
``LS+DE`` caustics, ``LS*E`` lights seen in mirrors and glass, ``L.*E``
everything (``.`` = any of D, S, G).

Figure 1 (pathclasses.png) shows the class images at the same exposure, each
titled with its share of the image's energy, plus a partition of path space
(by the vertex next to the light: ``LE | LDE | LD.+E | LS.*E | LG.*E``) whose
classes must add up to the full image exactly: the largest difference is in
the title.

Figure 2 (pathclasses-bounces.png) splits paths by number of bounces, a split
Mitsuba can make too: ``LE`` = Mitsuba with max_depth 1, ``L.E`` = max_depth 2
minus 1, ``L..E`` = max_depth 3 minus 2 (differences of the committed
references). Each row shows ours, Mitsuba's and the tile z-test verdict.

Writes pathclasses.png/.svg, pathclasses-bounces.png/.svg, pathclasses.csv,
pathclasses.json. Run: ``python -m experiments.pathclasses [--scene cornell-caustics]``
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

from mitsuba_refs.reference.cache import ReferenceUnavailable, get_reference
from mitsuba_refs.report.wording import verdict_line
from mitsuba_refs.stats import compare_means
from pathtracer import load_scene, render
from pathtracer.core.pathclasses import LECTURE_CLASSES, compile_classes, is_partition
from pathtracer.core.tonemap import auto_scale, tonemap
from pathtracer.render.classes import render_classes

from . import common

PARTITION = ("LE", "LDE", "LD.+E", "LS.*E", "LG.*E")
BOUNCES = ("LE", "L.E", "L..E")
DEFAULT_CLASSES = ("LE", "LDE", "LDD+E", "LS+DE", "LS*E", "L(D|S)*E")


def build_parser():
    """The command line of the path-class experiment."""
    parser = argparse.ArgumentParser(
        prog="python -m experiments.pathclasses", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scene", default="cornell-caustics",
                        help="built-in scene or XML file (default: cornell-caustics)")
    parser.add_argument("--classes", nargs="+", default=list(DEFAULT_CLASSES),
                        help="path expressions, light first (default: %(default)s)")
    parser.add_argument("--spp", type=int, default=64, help="samples per pixel (default: %(default)s)")
    parser.add_argument("--size", type=int, nargs=2, default=(128, 128), metavar=("W", "H"),
                        help="film of the class images (default: 128 128)")
    parser.add_argument("--glossy", default="G",
                        help="letter of rough conductors: G, D, S, or an alpha threshold (<= t: S, else D)")
    parser.add_argument("--seed", type=int, default=11000, help="base seed (default: %(default)s)")
    parser.add_argument("--alpha", type=float, default=0.01, help="level of the bounce tests (default: %(default)s)")
    parser.add_argument("--no-bounces", action="store_true", help="skip the comparison with Mitsuba")
    common.add_run_args(parser, "out/pathclasses")
    return parser


def plot_classes(result, named, partition, full, title, out):
    """Draw the named classes and a partition of path space beside the full image."""
    import matplotlib  # matplotlib: heavy, imported only to draw
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    exposure = auto_scale(full)
    total = float(full.mean())
    cols = max(len(named) + 1, len(partition) + 1)
    fig, axes = plt.subplots(2, cols, figsize=(2.9 * cols, 7.4), squeeze=False)
    for ax in axes.ravel():
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_frame_on(False)
    for j, expression in enumerate(named):
        image = result[expression]
        ax = axes[0, j]
        ax.imshow(tonemap(image, exposure), interpolation="nearest")
        share = 100 * float(image.mean()) / total if total > 0 else 0.0
        ax.set_title(f"{expression}\n{LECTURE_CLASSES.get(expression, '')}\n{share:.1f} % of the energy",
                     fontsize=9)
    ax = axes[0, len(named)]
    ax.imshow(tonemap(full, exposure), interpolation="nearest")
    ax.set_title("full image (path, same seed)\n100 %", fontsize=9)
    summed = sum(result[e] for e in partition)
    error = float(np.max(np.abs(summed - full)))
    for j, expression in enumerate(partition):
        image = result[expression]
        ax = axes[1, j]
        ax.imshow(tonemap(image, exposure), interpolation="nearest")
        share = 100 * float(image.mean()) / total if total > 0 else 0.0
        ax.set_title(f"{expression}\n{share:.1f} %", fontsize=9)
    ax = axes[1, len(partition)]
    ax.imshow(tonemap(summed, exposure), interpolation="nearest")
    ax.set_title(f"sum of the row\nmax |sum − full| = {error:.1e}", fontsize=9)
    axes[0, 0].set_ylabel("the lecture's classes", fontsize=10)
    axes[1, 0].set_ylabel("a partition\n(by the vertex next to L)", fontsize=10)
    for row in (0, 1):
        axes[row, 0].set_frame_on(True)
    fig.suptitle(title, fontsize=11)
    fig.tight_layout(h_pad=3.0)
    return common.save_figure(fig, out, "pathclasses"), error


def plot_bounces(rows, title, out):
    """Draw each bounce class beside Mitsuba's difference of max_depth references."""
    import matplotlib.pyplot as plt  # matplotlib: heavy, imported only to draw
    fig, axes = plt.subplots(len(rows), 3, figsize=(12, 3.6 * len(rows)), squeeze=False)
    for i, row in enumerate(rows):
        exposure = auto_scale(row["mitsuba"]) if row["mitsuba"].max() > 0 else 1.0
        for j, (key, label) in enumerate((("ours", "ours (path classes)"),
                                          ("mitsuba", f"Mitsuba: {row['mitsuba_label']}"))):
            ax = axes[i, j]
            ax.imshow(tonemap(np.maximum(row[key], 0), exposure), interpolation="nearest")
            ax.set_title(f"{row['expression']}: {label}", fontsize=9)
            ax.set_xticks([])
            ax.set_yticks([])
        ax = axes[i, 2]
        z = row["agreement"].z_tiles
        zmax = np.take_along_axis(z, np.argmax(np.abs(z), axis=2)[..., None], axis=2)[..., 0]
        im = ax.imshow(np.clip(zmax, -6, 6), cmap="RdBu_r", vmin=-6, vmax=6, interpolation="nearest")
        verdict = "agree" if row["agreement"].agree else "DIFFER"
        ax.set_title(f"tile z (ours − Mitsuba)/se: {verdict} (p = {row['agreement'].p_value:.2g})\n"
                     f"relative bias {100 * row['agreement'].rel_bias:+.2f} %", fontsize=9)
        ax.set_xlabel("tile column")
        ax.set_ylabel("tile row")
        fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04).set_label("z (clipped ±6)")
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    return common.save_figure(fig, out, "pathclasses-bounces")


def compare_bounces(args, bar):
    """Our bounce classes against differences of Mitsuba's max_depth references."""
    params = common.scene_params(args.scene, args.defines)
    try:
        refs = [get_reference(args.scene, {**params, "max_depth": d}, "path") for d in (1, 2, 3)]
    except (ReferenceUnavailable, FileNotFoundError, KeyError, ValueError) as error:
        print(f"note: no per-bounce Mitsuba references, bounce comparison skipped: {error}", file=sys.stderr)
        return [], []
    scene = load_scene(args.scene, **params)
    result = render_classes(scene, BOUNCES, spp=min(args.spp, 64), seed=args.seed + 1,
                            processes=args.workers, glossy=args.glossy)
    bar.update()
    rows = []
    for k, expression in enumerate(BOUNCES):
        if k == 0:
            m_mean, m_var, label = refs[0].mean, refs[0].var, "max_depth 1"
        else:
            m_mean = refs[k].mean - refs[k - 1].mean
            m_var = refs[k].var + refs[k - 1].var   # independent references: variances add
            label = f"max_depth {k + 1} − max_depth {k}"
        agreement = compare_means(result["mean"][k], result["variance"][k], result["spp"],
                                  m_mean, m_var, refs[k].n, alpha=args.alpha)
        rows.append(dict(expression=expression, ours=result["mean"][k], mitsuba=m_mean,
                         mitsuba_label=label, agreement=agreement))
    h, w = scene.camera.height, scene.camera.width
    figures = plot_bounces(rows, f"Bounce classes on {args.scene} ({w}×{h} px, {result['spp']} spp) against "
                                 f"differences of Mitsuba's max_depth references ({refs[0].n} spp)",
                           args.out)
    return rows, figures


def main(argv=None) -> int:
    """Run the path-class experiment (command line); exit code."""
    args = build_parser().parse_args(argv)
    out = common.out_dir(args.out)
    args.workers = args.workers or common.cpu_count()
    compile_classes(args.classes)          # fail early on a malformed expression
    bar = common.progress_bar(2 + (0 if args.no_bounces else 1), "path classes", not args.no_progress)
    params = {"width": args.size[0], "height": args.size[1], **dict(args.defines)}
    scene = load_scene(args.scene, **params)
    expressions = list(dict.fromkeys(list(args.classes) + list(PARTITION)))
    result = render_classes(scene, expressions, spp=args.spp, seed=args.seed, processes=args.workers,
                            glossy=args.glossy)
    bar.update()
    full = render(scene, "path", spp=args.spp, seed=args.seed, processes=args.workers, progress=False)
    bar.update()
    images = dict(zip(result["classes"], result["mean"]))
    ok, why = is_partition(PARTITION)
    h, w = scene.camera.height, scene.camera.width
    figures, error = plot_classes(images, list(args.classes), PARTITION, full.mean,
                                  f"Heckbert path classes on {args.scene} ({w}×{h} px, {args.spp} spp, "
                                  f"MIS path tracer; glossy = {args.glossy}), same exposure", out)
    table = [dict(expression=e, mean=float(images[e].mean()),
                  share=float(images[e].mean() / full.mean.mean()) if full.mean.mean() > 0 else 0.0,
                  in_partition=e in PARTITION) for e in expressions]
    bounce_rows, bounce_figures = ([], []) if args.no_bounces else compare_bounces(args, bar)
    bar.close()
    common.write_csv(out / "pathclasses.csv", table)
    common.write_json(out / "pathclasses.json", dict(
        scene=args.scene, params=params, spp=args.spp, seed=args.seed, glossy=args.glossy,
        classes=table, partition=list(PARTITION), partition_check=why, partition_max_abs_error=error,
        render_seconds=result["seconds"],
        bounces=[dict(expression=r["expression"], mitsuba=r["mitsuba_label"], agree=r["agreement"].agree,
                      p_value=r["agreement"].p_value, rel_bias=r["agreement"].rel_bias,
                      verdict=verdict_line(r["agreement"])) for r in bounce_rows]))
    print(f"{args.scene}: {len(expressions)} classes in {result['seconds']:.1f} s")
    for row in table:
        print(f"  {row['expression']:<12} {100 * row['share']:6.2f} % of the image")
    print(f"partition {' | '.join(PARTITION)}: {why}; max |sum - full| = {error:.2e}")
    for r in bounce_rows:
        print(f"  {r['expression']:<6} vs Mitsuba {r['mitsuba_label']}: {verdict_line(r['agreement'])}")
    print(f"wrote {', '.join(f for f in figures + bounce_figures if f.endswith('.png'))}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
