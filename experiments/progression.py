"""The lecture's progression figure: 1, 4, 16, 64, 256, 1024 paths per pixel, ours beside Mitsuba.

"Path Tracing with Shadow Rays" on the slides shows the same scene at
1, 4, ..., 1024 paths per pixel: noise halves with every 4x. This script
renders that row with our tracer (``path_nee`` by default, the slide's
algorithm) and, when Mitsuba 3 is installed, the same XML file with the same
estimator in Mitsuba at equal spp. Renders are progressive: level k adds
spp_k - spp_{k-1} new samples (independent seed) to the previous image, as
an interactive renderer would, so the total work is that of the last level.

Writes progression.png/.svg (same exposure everywhere), progression.csv
(seconds and mean brightness per level and renderer) and progression.npz
(the images). Run: ``python -m experiments.progression [--scene cornell-box]``.
``--lecture-media`` draws the lecture's participating-media sequence instead
(:mod:`experiments.lecture_media`).
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from mitsuba_refs.reference.render import (
    INTEGRATOR_MAP,
    check_box_filter,
    integrator_dict,
    resolve_scene,
    split_params,
    stream_id,
)
from mitsuba_refs.reference.seeds import pass_seeds
from mitsuba_refs.reference.variant import set_variant
from pathtracer import load_scene, render
from pathtracer.core.tonemap import auto_scale, tonemap

from . import common, lecture_media

DEFAULT_SPP = (1, 4, 16, 64, 256, 1024)


def build_parser():
    """The command line of the lecture's progression figure."""
    parser = argparse.ArgumentParser(
        prog="python -m experiments.progression", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scene", default="cornell-box", help="built-in scene or XML file (default: cornell-box)")
    parser.add_argument("--integrator", default="path_nee",
                        help="our integrator; Mitsuba runs the same estimator (default: %(default)s)")
    parser.add_argument("--spp", nargs="+", type=int, default=list(DEFAULT_SPP),
                        help="paths per pixel of each panel (default: %(default)s)")
    parser.add_argument("--size", type=int, nargs=2, default=(80, 80), metavar=("W", "H"),
                        help="film size in pixels (default: 80 80; -D width=... overrides)")
    parser.add_argument("--seed", type=int, default=7000, help="base seed (default: %(default)s)")
    parser.add_argument("--no-mitsuba", action="store_true", help="render our tracer only")
    parser.add_argument("--lecture-media", action="store_true",
                        help="instead: the lecture's four participating-media scenes at equal spp "
                             "(64 unless --spp gives one value), volpath_phase and volpath, with "
                             "their RMSE against the Mitsuba references (experiments/lecture_media.py)")
    parser.add_argument("--variant", default=None, help="Mitsuba variant (default: probed)")
    common.add_run_args(parser, "out/progression")
    return parser


def increments(levels):
    """spp added at each level of a progressive render."""
    previous, out = 0, []
    for n in levels:
        out.append(n - previous)
        previous = n
    return out


def progressive(render_increment, levels, bar):
    """Images and cumulative seconds at each level: running weighted mean of the increments."""
    images, seconds = [], []
    total, mean, spent = 0, None, 0.0
    for j, add in enumerate(increments(levels)):
        start = time.perf_counter()
        image = render_increment(add, j)
        spent += time.perf_counter() - start
        mean = image if mean is None else (mean * total + image * add) / (total + add)
        total += add
        images.append(mean.copy())
        seconds.append(spent)
        bar.update()
    return images, seconds


def mitsuba_ready() -> tuple[bool, str]:
    """Whether Mitsuba 3 can be imported, and why not."""
    try:
        import mitsuba  # noqa: F401  (only whether it imports)
    except ImportError:
        return False, "Mitsuba 3 is not installed (pip install -e '.[mitsuba]')"
    return True, ""


def mitsuba_renderer(scene, params, integrator, variant=None):
    """A function (spp, seed) -> mean image rendering ``scene`` in Mitsuba with our estimator's twin.

    Uses :mod:`mitsuba_refs.reference.render`'s integrator mapping and seed spacing; the
    scene file is the one our tracer reads (box filter: a pixel is a plain mean).
    """
    path = resolve_scene(scene)
    check_box_filter(path)
    scene_kw, integ_kw = split_params(path, params)
    chosen, _ = set_variant(variant)
    import mitsuba as mi  # Mitsuba: optional and heavy, imported where it renders
    mi_scene = mi.load_file(str(path), **scene_kw)
    integ = mi.load_dict(integrator_dict(integrator, integ_kw))
    width, height = (int(v) for v in mi_scene.sensors()[0].film().crop_size())
    stream = stream_id(integrator, params)

    def render(spp, seed):
        mi_seed = pass_seeds(seed, 1, width, height, stream)[0]
        image = mi.render(mi_scene, integrator=integ, spp=int(spp), seed=mi_seed)
        return np.array(image, dtype=np.float64)[..., :3]

    return render, chosen


def plot(rows, levels, title, out, exposure):
    """Draw one row of images per renderer at every sample count; return the figure paths."""
    import matplotlib  # matplotlib: heavy, imported only to draw
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    cols = len(levels)
    fig, axes = plt.subplots(len(rows), cols, figsize=(2.35 * cols, 2.55 * len(rows) + 0.6),
                             squeeze=False)
    for i, (label, images, seconds, note) in enumerate(rows):
        for j, n in enumerate(levels):
            ax = axes[i, j]
            ax.set_xticks([])
            ax.set_yticks([])
            if images is None:
                ax.set_facecolor("0.92")
                if j == 0:
                    ax.text(0.05, 0.5, note, transform=ax.transAxes, fontsize=8, wrap=True)
            else:
                ax.imshow(tonemap(images[j], exposure), interpolation="nearest")
                ax.set_xlabel(f"{seconds[j]:.2f} s so far", fontsize=8)
            if i == 0:
                ax.set_title(f"{n} path{'s' if n > 1 else ''}/pixel", fontsize=10)
            if j == 0:
                ax.set_ylabel(label, fontsize=9)
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    return common.save_figure(fig, out, "progression")


def main(argv=None) -> int:
    """Draw the lecture's progression figure (command line); exit code."""
    args = build_parser().parse_args(argv)
    if args.lecture_media:
        spp = args.spp[0] if len(args.spp) == 1 else 64
        lecture_media.run(spp, args.seed, args.out or "out/lecture-media", args.workers)
        return 0
    levels = sorted(set(args.spp))
    out = common.out_dir(args.out)
    params = {"width": args.size[0], "height": args.size[1], **dict(args.defines)}
    scene = load_scene(args.scene, **params)
    use_mitsuba, why = (False, "Mitsuba skipped (--no-mitsuba)") if args.no_mitsuba else mitsuba_ready()
    bar = common.progress_bar(len(levels) * (2 if use_mitsuba else 1), "progression", not args.no_progress)

    def ours(add, j):
        return render(scene, args.integrator, spp=add, seed=args.seed + j, processes=args.workers,
                      progress=False).mean

    our_images, our_seconds = progressive(ours, levels, bar)
    rows = [(f"pathtracer\n({args.integrator})", our_images, our_seconds, "")]
    mi_images = mi_seconds = None
    if use_mitsuba:
        try:
            theirs, variant = mitsuba_renderer(args.scene, params, args.integrator, args.variant)
            mi_images, mi_seconds = progressive(lambda add, j: theirs(add, args.seed + j), levels, bar)
            rows.append((f"Mitsuba 3 {variant}\n({INTEGRATOR_MAP.get(args.integrator, args.integrator)})",
                         mi_images, mi_seconds, ""))
        except Exception as error:   # report and draw ours alone
            why = f"Mitsuba failed: {error}"
            use_mitsuba = False
    if not use_mitsuba:
        rows.append(("Mitsuba 3", None, None, why))
        print(f"note: {why}", file=sys.stderr)
    bar.close()

    exposure = auto_scale((mi_images or our_images)[-1])
    w, h = scene.camera.width, scene.camera.height
    title = (f"{args.scene} ({w}×{h} px) at increasing paths per pixel: noise halves with every 4× "
             f"(same exposure; times include all previous levels)")
    figures = plot(rows, levels, title, out, exposure)
    table = []
    for j, n in enumerate(levels):
        row = dict(spp=n, ours_seconds=our_seconds[j], ours_mean=float(our_images[j].mean()))
        if mi_images is not None:
            row.update(mitsuba_seconds=mi_seconds[j], mitsuba_mean=float(mi_images[j].mean()))
        table.append(row)
    common.write_csv(out / "progression.csv", table)
    arrays = {f"ours_{n}": im.astype(np.float32) for n, im in zip(levels, our_images)}
    if mi_images is not None:
        arrays.update({f"mitsuba_{n}": im.astype(np.float32) for n, im in zip(levels, mi_images)})
    np.savez_compressed(out / "progression.npz", **arrays)
    for row in table:
        line = f"{row['spp']:5d} spp: ours {row['ours_seconds']:7.2f} s, mean {row['ours_mean']:.4f}"
        if "mitsuba_mean" in row:
            line += f" | Mitsuba {row['mitsuba_seconds']:7.2f} s, mean {row['mitsuba_mean']:.4f}"
        print(line)
    print(f"wrote {', '.join(figures)}, {out / 'progression.csv'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
