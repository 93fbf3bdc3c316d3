"""Bidirectional path tracing, strategy by strategy: Veach's triangle of images.

Row k holds the paths of k segments (k = 1: lights seen directly, 2: direct light, ...);
column s the strategy (s, t = k + 1 - s) that takes s vertices from the light subpath and
t from the camera subpath: s = 0 is pure path tracing (the camera subpath hits the light),
s = 1 next-event estimation, s = k + 1 - 1 = k light tracing (t = 1, splatted).

Figure 1 (bdpt-strategies.png): the *unweighted* images. Each one alone estimates the
whole row's light (tests/test_bdpt.py checks them against the per-bounce Mitsuba
references); they differ in where they are noisy. Figure 2 (bdpt-weighted.png): the same
strategies with their MIS weights; a row adds up to the paths of its length, the whole
triangle to the image. Both share one exposure.

Writes bdpt-strategies.png/.svg, bdpt-weighted.png/.svg and bdpt-strategies.csv (each
strategy's mean pixel value, unweighted and weighted, and the per-bounce reference's where
one is committed). Run: ``python -m experiments.bdpt_strategies [--scene cornell-box]``
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

from mitsuba_refs.errors import ReferenceUnavailable
from mitsuba_refs.reference.cache import get_reference
from pathtracer import load_scene
from pathtracer.core.tonemap import auto_scale, tonemap
from pathtracer.integrators.bdpt import BDPTIntegrator
from pathtracer.render.strategies import render_strategies

from . import common


def build_parser():
    """The command line of the strategy experiment."""
    parser = argparse.ArgumentParser(
        prog="python -m experiments.bdpt_strategies", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scene", default="cornell-box",
                        help="built-in scene or XML file (default: cornell-box)")
    parser.add_argument("--longest", type=int, default=4,
                        help="longest path length (segments) shown (default: %(default)s)")
    parser.add_argument("--spp", type=int, default=64, help="samples per pixel (default: %(default)s)")
    parser.add_argument("--seed", type=int, default=12000, help="seed (default: %(default)s)")
    parser.add_argument("--mis", choices=("power", "balance"), default="power",
                        help="heuristic of the weighted figure (default: %(default)s)")
    common.add_run_args(parser, "out/bdpt-strategies", workers=False)
    return parser


def plot_triangle(images: dict, longest: int, exposure: float, title: str, out, stem: str):
    """Row k = path length, column s = strategy; one exposure for every image."""
    import matplotlib  # matplotlib: heavy, imported only to draw
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(longest, longest + 1, figsize=(2.2 * (longest + 1), 2.3 * longest),
                             squeeze=False)
    for ax in axes.ravel():
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_frame_on(False)
    for k in range(1, longest + 1):
        for s in range(k + 1):
            t = k + 1 - s
            image = images.get((s, t))
            ax = axes[k - 1, s]
            if image is None:
                image = np.zeros_like(next(iter(images.values())))
            ax.imshow(tonemap(image, exposure), interpolation="nearest")
            ax.set_title(f"s={s}, t={t}", fontsize=9)
        axes[k - 1, 0].set_ylabel(f"k = {k}")
    fig.suptitle(title)
    return common.save_figure(fig, out, stem)


def main(argv=None) -> int:
    """Render both triangles and write the figures and the table."""
    args = build_parser().parse_args(argv)
    params = common.scene_params(args.scene, args.defines)
    scene = load_scene(args.scene, max_depth=args.longest,
                       **{k: v for k, v in params.items() if k != "max_depth"})
    integrator = BDPTIntegrator(max_depth=args.longest, mis=args.mis)
    bar = common.progress_bar(2, "bdpt strategies", not args.no_progress)
    unweighted = render_strategies(scene, integrator, args.spp, args.seed, weighted=False)
    bar.update(1)
    weighted = render_strategies(scene, integrator, args.spp, args.seed, weighted=True)
    bar.update(1)
    bar.close()
    full = sum(mean for mean, _ in weighted.values())
    exposure = auto_scale(full)
    out = common.out_dir(args.out)
    files = plot_triangle({k: v[0] for k, v in unweighted.items()}, args.longest, exposure,
                          f"{args.scene}: unweighted strategies (each estimates its row)",
                          out, "bdpt-strategies")
    files += plot_triangle({k: v[0] for k, v in weighted.items()}, args.longest, exposure,
                           f"{args.scene}: {args.mis}-heuristic weighted strategies (sum = image)",
                           out, "bdpt-weighted")
    rows = []
    for k in range(1, args.longest + 1):
        reference = bounce_reference(args.scene, params, k)
        for s in range(k + 1):
            key = (s, k + 1 - s)
            rows.append({"k": k, "s": s, "t": k + 1 - s,
                         "unweighted": float(unweighted[key][0].mean()) if key in unweighted else 0.0,
                         "weighted": float(weighted[key][0].mean()) if key in weighted else 0.0,
                         "reference": reference})
    files.append(common.write_csv(out / "bdpt-strategies.csv", rows))
    for row in rows:
        print(f"k={row['k']} (s={row['s']}, t={row['t']}): unweighted {row['unweighted']:.4f}, "
              f"weighted {row['weighted']:.4f}, reference {row['reference']}")
    print("wrote " + ", ".join(files), file=sys.stderr)
    return 0


def bounce_reference(scene: str, params: dict, k: int):
    """Mean pixel value of the paths of k segments from the committed per-bounce references
    (Mitsuba path at max_depth k minus k - 1), or None where one is missing."""
    try:
        upper = get_reference(scene, {**params, "max_depth": k}, "path", render=False)
        lower = (get_reference(scene, {**params, "max_depth": k - 1}, "path", render=False).mean
                 if k > 1 else 0.0)
    except (ReferenceUnavailable, ValueError):
        return None
    return float(np.mean(upper.mean - lower))


if __name__ == "__main__":
    sys.exit(main())
