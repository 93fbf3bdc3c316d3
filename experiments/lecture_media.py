"""The lecture's example scene with participating media, step by step, at equal spp.

"A Simple Example Scene" on the slides is built in four steps: a scattering
medium behind an index-matched boundary (eta = 1, a ``null`` BSDF), + a
dielectric boundary (eta = 1.00001), + glossy materials, + an inconveniently
placed light. Each step is rendered here at the same number of paths per pixel
with ``volpath_phase`` (phase/BSDF sampling only) and ``volpath`` (shadow rays
through media, MIS), next to the committed Mitsuba ``volpath`` reference; each
panel gives its RMSE against the reference (the reference's own noise removed).
What it shows: the dielectric boundary blocks every shadow ray that starts in
the medium, although optically it is almost nothing, so ``volpath`` loses its
advantage there; glossy surfaces add noise to both; and a light that paths
reach only through a bounce makes both noisy.

Run: ``python -m experiments.progression --lecture-media [--spp 64]`` (or
``python -m experiments.lecture_media [--spp 64]``). Writes lecture-media.png/.svg and
lecture-media.csv (RMSE and seconds per panel).
"""
from __future__ import annotations

import argparse
import sys
import time

from mitsuba_refs.verdicts.scenes import default_params
from pathtracer import load_scene, render
from pathtracer.core.tonemap import auto_scale, tonemap

from . import common

STEPS = {
    "lecture-media-1": "medium, eta = 1\n(null boundary)",
    "lecture-media-2": "+ dielectric boundary\neta = 1.00001",
    "lecture-media-3": "+ glossy materials",
    "lecture-media-4": "+ inconveniently\nplaced light",
}
INTEGRATORS = ("volpath_phase", "volpath")


def run(spp: int, seed: int, out, workers=None) -> list[dict]:
    """Render every step with both integrators; write the figure and the table."""
    out = common.out_dir(out)
    panels, table = {}, []
    for scene_name in STEPS:
        params = default_params(scene_name)
        scene = load_scene(scene_name, **params)
        reference = common.get_reference(scene_name, params, "volpath")
        panels[(scene_name, "reference")] = None if reference is None else reference.mean
        for integrator in INTEGRATORS:
            start = time.perf_counter()
            image = render(scene, integrator, spp=spp, seed=seed, processes=workers,
                           progress=False).mean
            seconds = time.perf_counter() - start
            rmse = (common.error_metrics(image, reference)["rmse"] if reference is not None
                    else float("nan"))
            panels[(scene_name, integrator)] = image
            table.append(dict(scene=scene_name, integrator=integrator, spp=spp, rmse=rmse,
                              seconds=seconds))
            print(f"{scene_name} {integrator:14s} {spp} spp: RMSE {rmse:.4f}, {seconds:.1f} s")
    figures = plot(panels, table, spp, out)
    common.write_csv(out / "lecture-media.csv", table)
    print(f"wrote {', '.join(figures)}, {out / 'lecture-media.csv'}")
    return table


def plot(panels, table, spp, out) -> list[str]:
    """The figure: one column per step, rows volpath_phase, volpath and the reference."""
    import matplotlib  # a heavy optional part: imported only to draw
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # matplotlib: heavy, imported only to draw
    rows = list(INTEGRATORS) + ["reference"]
    rmse = {(r["scene"], r["integrator"]): r["rmse"] for r in table}
    fig, axes = plt.subplots(len(rows), len(STEPS), figsize=(2.4 * len(STEPS), 2.5 * len(rows) + 0.5),
                             squeeze=False)
    reference = panels[("lecture-media-1", "reference")]
    exposure = auto_scale(reference if reference is not None
                                    else panels[("lecture-media-1", "volpath")])
    for j, scene_name in enumerate(STEPS):
        for i, row in enumerate(rows):
            ax = axes[i, j]
            ax.set_xticks([])
            ax.set_yticks([])
            image = panels[(scene_name, row)]
            if image is None:
                ax.set_facecolor("0.92")
            else:
                ax.imshow(tonemap(image, exposure), interpolation="nearest")
            if row != "reference":
                ax.set_xlabel(f"RMSE {rmse[(scene_name, row)]:.3f}", fontsize=9)
            if i == 0:
                ax.set_title(STEPS[scene_name], fontsize=9)
            if j == 0:
                ax.set_ylabel(f"{row}\n({spp} spp)" if row != "reference" else
                              "Mitsuba volpath\n(4096 spp)", fontsize=9)
    fig.suptitle("The lecture's example scene with a participating medium: equal paths per "
                 "pixel, RMSE against Mitsuba", fontsize=10)
    fig.tight_layout()
    return common.save_figure(fig, out, "lecture-media")


def main(argv=None) -> int:
    """The lecture's media steps (command line); exit code."""
    parser = argparse.ArgumentParser(prog="python -m experiments.lecture_media", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--spp", type=int, default=64, help="paths per pixel (default: %(default)s)")
    parser.add_argument("--seed", type=int, default=7000, help="base seed (default: %(default)s)")
    common.add_run_args(parser, "out/lecture-media")
    args = parser.parse_args(argv)
    run(args.spp, args.seed, args.out, args.workers)
    return 0


if __name__ == "__main__":
    sys.exit(main())
