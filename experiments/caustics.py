"""The caustics experiment: who finds the light focused by a glass sphere, at equal time.

The built-in ``caustics`` scene (a glass sphere over a diffuse floor, a small light above
it; ``-D light=area`` or ``point``) is rendered with ``path_bsdf``, ``path``, ``light`` and
``bdpt``, each for the same CPU-time budget (``--seconds``), progressively: batches of
samples with fresh seeds are pooled, and after each batch the RMSE against Mitsuba's
``ptracer`` reference (the committed ``caustics`` references, 32 x 32) is recorded.

The caustic is the floor seen along L S S D E paths. BSDF sampling reaches the small area
light through the glass only by chance (slow), shadow rays never pass the glass, so with
the point light ``path`` converges to an image *without* the caustic; light tracing
starts at the light and finds it at once, BDPT gives those paths to its light-tracing
strategy. The harness's mean test (:func:`mitsuba_refs.stats.compare_means` at
``--alpha``) says so: ``path`` on the point light DISAGREES, at the caustic.

Errors and verdicts use the pixels that see the floor: ptracer joins its light subpaths
to the camera at diffuse vertices only, so it cannot render the floor seen *through* the
glass (L ... D S S E), which the other three do.

Writes caustics.png (the images at the end of the budget, one row per light, one exposure
per row, the reference last), caustics-error.png (RMSE against CPU seconds, log-log) and
caustics.json (every time point, each integrator's efficiency 1 / (MSE x seconds) and the
verdicts). MSE = variance + bias^2: the image's variance from its own samples, plus whatever
of the squared error against the reference (the reference's noise removed) exceeds it; so an
image less noisy than the 4096-spp reference still gets a finite, honest MSE.
Run: ``python -m experiments.caustics [--seconds 15]``.
"""
from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np

from mitsuba_refs.reference.cache import get_reference
from mitsuba_refs.report.wording import mean_region, verdict_line
from mitsuba_refs.stats import compare_means, image_mse
from pathtracer import load_scene, render
from pathtracer.bsdfs.shading import is_delta
from pathtracer.core.tonemap import auto_scale, tonemap
from pathtracer.integrators import INTEGRATORS as REGISTERED
from pathtracer.integrators.wavefront import subset_hit
from pathtracer.sensors.perspective import camera_rays
from pathtracer.shapes.intersect import intersect

from . import common

INTEGRATORS = ("path_bsdf", "path", "light", "bdpt")
LIGHTS = ("area", "point")
#: Integrators whose light subpaths splat into any pixel: pixels are correlated across the
#: image, so the mean test leaves out its whole-image components (docs/statistics.md).
SPLATTING = tuple(name for name, cls in REGISTERED.items() if cls.splats)
#: Where the sphere (centre (0, 0.8, 0), radius 0.5) focuses the light: around the floor
#: point below it, within this distance.
CAUSTIC_CENTRE = np.array([0.0, 0.0, 0.0])
CAUSTIC_RADIUS = 0.35


def build_parser():
    """The command line of the caustics experiment."""
    parser = argparse.ArgumentParser(
        prog="python -m experiments.caustics", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seconds", type=float, default=15.0,
                        help="CPU seconds per integrator and light (default: %(default)s)")
    parser.add_argument("--integrators", nargs="+", default=list(INTEGRATORS), choices=INTEGRATORS,
                        help="integrators to compare (default: all four)")
    parser.add_argument("--lights", nargs="+", default=list(LIGHTS), choices=LIGHTS,
                        help="light variants (default: both)")
    parser.add_argument("--alpha", type=float, default=1e-3,
                        help="level of the mean test's verdicts (default: %(default)s)")
    parser.add_argument("--seed", type=int, default=31000, help="base seed (default: %(default)s)")
    common.add_run_args(parser, "docs/figures", workers=False)
    return parser


# ---------------------------------------------------------------------------------------
# pixels

def first_hits(scene, sub=4):
    """Per pixel and sub-pixel offset (sub x sub grid): (points, hit Dirac BSDF, valid)."""
    pixels = np.arange(scene.camera.width * scene.camera.height)
    grid = (np.stack(np.meshgrid(np.arange(sub), np.arange(sub)), -1).reshape(-1, 2) + 0.5) / sub
    for offset in grid:
        rays = camera_rays(scene.camera, pixels, np.tile(offset, (len(pixels), 1)))
        hit = intersect(scene, rays.o, rays.d, rays.tmax)
        glass = np.zeros(len(pixels), dtype=bool)
        glass[hit.valid] = is_delta(scene, subset_hit(hit, hit.valid))
        points = rays.o + rays.d * np.where(hit.valid, hit.t, np.inf)[:, None]
        yield points, glass, hit.valid


def pixel_masks(scene) -> tuple[np.ndarray, np.ndarray]:
    """(H, W) masks: *floor*, no part of the pixel sees the glass first; *caustic*, some part
    of it sees the floor within CAUSTIC_RADIUS of the point below the sphere, not through
    the glass."""
    size = scene.camera.width * scene.camera.height
    glass, near = np.zeros(size, dtype=bool), np.zeros(size, dtype=bool)
    for points, seen, valid in first_hits(scene):
        glass |= seen
        with np.errstate(invalid="ignore"):
            distance = np.linalg.norm((points - CAUSTIC_CENTRE)[:, [0, 2]], axis=1)
            on_floor = np.abs(points[:, 1]) < 1e-4
        near |= valid & ~seen & on_floor & (distance < CAUSTIC_RADIUS)
    shape = (scene.camera.height, scene.camera.width)
    return ~glass.reshape(shape), near.reshape(shape)


def tile_pixels(tile: tuple, size: int, shape) -> np.ndarray:
    """(H, W) True inside tile (row, col) of edge ``size``."""
    mask = np.zeros(shape[:2], dtype=bool)
    row, col = tile[0], tile[1]
    mask[row * size:(row + 1) * size, col * size:(col + 1) * size] = True
    return mask


# ---------------------------------------------------------------------------------------
# rendering

class Pool:
    """Running pooled mean and per-sample variance of batches of samples (Chan's formula)."""

    def __init__(self):
        self.n, self.mean, self.m2 = 0, None, None

    def add(self, mean, variance, n):
        """Pool a batch of ``n`` samples per pixel with its mean and unbiased variance."""
        m2 = np.nan_to_num(variance, posinf=0.0) * (n - 1)
        if self.mean is None:
            self.n, self.mean, self.m2 = n, mean.copy(), m2
            return
        total = self.n + n
        delta = mean - self.mean
        self.mean = self.mean + delta * (n / total)
        self.m2 = self.m2 + m2 + delta ** 2 * (self.n * n / total)
        self.n = total

    @property
    def variance(self):
        """Unbiased per-sample variance."""
        return self.m2 / max(self.n - 1, 1)


def equal_time_render(scene, integrator: str, seconds: float, seed: int):
    """Render progressively for about ``seconds`` of CPU time.

    Batches double (2, 2, 4, 8 ... samples per pixel), the last one cut to the time left
    at the speed measured so far. Returns the pool and a list of (cpu seconds, spp, mean,
    variance of the mean).
    """
    pool, spent, points, batch, index = Pool(), 0.0, [], 2, 0
    while spent < seconds:
        start = time.process_time()
        result = render(scene, integrator, spp=batch, seed=seed + index, processes=1, progress=False)
        spent += time.process_time() - start
        pool.add(result.mean, result.variance, batch)
        points.append((spent, pool.n, pool.mean.copy(), pool.variance / pool.n))
        index += 1
        rate = spent / pool.n
        batch = int(max(2, min(pool.n, (seconds - spent) / max(rate, 1e-9))))
    return pool, points


def masked_mse(mean, variance_of_mean, reference, mask) -> dict:
    """Errors over the pixels of ``mask``: ``mse_reference``, the squared error against the
    reference with the reference's noise removed (unbiased, may be < 0); ``variance``, the
    image's own; ``mse`` = variance + bias^2, the bias^2 being what of ``mse_reference``
    exceeds the variance; ``rmse`` its root."""
    ref_n = reference.n[mask] if np.ndim(reference.n) == 2 else reference.n
    against = image_mse(mean[mask], reference.mean[mask], reference.var[mask], ref_n)
    variance = float(np.mean(variance_of_mean[mask]))
    mse = max(against, variance)
    return dict(mse_reference=against, variance=variance, mse=mse, rmse=math.sqrt(mse))


def reference_noise(reference, mask) -> float:
    """RMS of the reference's own noise over ``mask``: errors below it are not resolved."""
    ref_n = reference.n[mask] if np.ndim(reference.n) == 2 else reference.n
    if np.ndim(ref_n) == 1:
        ref_n = ref_n[:, None]
    return math.sqrt(float(np.mean(np.maximum(reference.var[mask], 0) / ref_n)))


def verdict(pool, reference, mask, integrator, alpha):
    """The harness's mean test of ``pool`` against ``reference`` on the pixels of ``mask``."""
    keep = mask[:, :, None]
    return compare_means(pool.mean * keep, pool.variance * keep, pool.n,
                         reference.mean * keep, reference.var * keep, reference.n, alpha=alpha,
                         image_components=integrator not in SPLATTING)


def run_light(light, args, bar):
    """Every integrator on one light variant: images, error curves, efficiencies, verdicts."""
    params = {k: v for k, v in common.scene_params("caustics", args.defines).items() if k != "light"}
    if light != "area":    # the file's default: not part of the reference's name
        params["light"] = light
    reference = get_reference("caustics", params, "light", render=False)
    scene = load_scene("caustics", **params)
    floor, caustic = pixel_masks(scene)
    rows = {}
    for k, name in enumerate(args.integrators):
        pool, points = equal_time_render(scene, name, args.seconds, args.seed + 100 * k)
        curve = [dict(seconds=s, spp=n, **masked_mse(mean, var, reference, floor))
                 for s, n, mean, var in points]
        mse = curve[-1]["mse"]
        test = verdict(pool, reference, floor, name, args.alpha)
        worst = test.worst_tile
        rows[name] = dict(
            curve=curve, seconds=curve[-1]["seconds"], spp=pool.n, rmse=curve[-1]["rmse"],
            mse=mse, efficiency=1.0 / (mse * curve[-1]["seconds"]),
            agree=bool(test.agree), p_value=test.p_value, verdict=verdict_line(test),
            worst_tile=None if worst is None else list(worst[:2]), worst_region=mean_region(test),
            worst_in_caustic=bool(worst is not None
                                  and (tile_pixels(worst, test.tile, floor.shape) & caustic).any()),
            image=pool.mean)
        bar.update()
    return dict(params=params, reference=reference.mean, floor=floor, caustic=caustic,
                reference_noise=reference_noise(reference, floor), integrators=rows)


# ---------------------------------------------------------------------------------------
# figures

def plot_images(results, out) -> str:
    """One row per light: each integrator's image at the end of its budget, then the reference."""
    import matplotlib  # matplotlib: heavy, imported only to draw
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    names = list(next(iter(results.values()))["integrators"])
    fig, axes = plt.subplots(len(results), len(names) + 1, squeeze=False,
                             figsize=(2.0 * (len(names) + 1), 2.25 * len(results)))
    for axis_row, (light, result) in zip(axes, results.items()):
        exposure = auto_scale(result["reference"])
        panels = [(name, row["image"], f"{row['spp']} spp, RMSE {row['rmse']:.3g}")
                  for name, row in result["integrators"].items()]
        panels.append(("Mitsuba ptracer", result["reference"], "reference"))
        for ax, (name, image, note) in zip(axis_row, panels):
            ax.imshow(tonemap(image, exposure), interpolation="nearest")
            ax.set_title(f"{name}\n{note}", fontsize=8)
            ax.set_xticks([])
            ax.set_yticks([])
        axis_row[0].set_ylabel(f"{light} light")
    low, high = seconds_range(results)
    fig.suptitle(f"caustics at equal CPU time ({low:.3g} to {high:.3g} s each)", fontsize=10)
    return save_png(fig, out, "caustics")


def plot_errors(results, out) -> str:
    """RMSE against CPU seconds, log-log, one panel per light."""
    import matplotlib  # matplotlib: heavy, imported only to draw
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter
    colours = {"path_bsdf": "C2", "path": "C0", "light": "C3", "bdpt": "C4"}
    fig, axes = plt.subplots(1, len(results), figsize=(4.2 * len(results), 3.4), squeeze=False)
    for ax, (light, result) in zip(axes[0], results.items()):
        for name, row in result["integrators"].items():
            seconds = [p["seconds"] for p in row["curve"]]
            rmse = [max(p["rmse"], 1e-12) for p in row["curve"]]
            ax.loglog(seconds, rmse, "o-", ms=3, color=colours.get(name), label=name)
        ax.axhline(result["reference_noise"], color="0.5", ls="--", lw=1,
                   label="reference noise")
        ax.set_title(f"{light} light", fontsize=10)
        ax.set_xlabel("CPU seconds")
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_minor_formatter(NullFormatter())
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("RMSE vs Mitsuba ptracer (floor pixels)")
    axes[0][0].legend(fontsize=8)
    return save_png(fig, out, "caustics-error")


def seconds_range(results) -> tuple[float, float]:
    """The shortest and longest CPU time actually spent (the last batch overshoots a little)."""
    spent = [row["seconds"] for r in results.values() for row in r["integrators"].values()]
    return min(spent), max(spent)


def save_png(fig, out, stem) -> str:
    """``stem.png`` only (the figures are committed: no SVG twin), small."""
    import matplotlib.pyplot as plt  # matplotlib: heavy, imported only to draw
    path = common.out_dir(out) / f"{stem}.png"
    fig.savefig(path, dpi=90, bbox_inches="tight")
    plt.close(fig)
    return str(path)


# ---------------------------------------------------------------------------------------

def summary(results, args) -> dict:
    """The JSON of the numbers (images left out)."""
    return dict(seconds=args.seconds, alpha=args.alpha, seed=args.seed, lights={
        light: dict(params=r["params"], floor_pixels=int(r["floor"].sum()),
                    reference_noise_rmse=r["reference_noise"],
                    caustic_pixels=int(r["caustic"].sum()),
                    integrators={name: {k: v for k, v in row.items() if k != "image"}
                                 for name, row in r["integrators"].items()})
        for light, r in results.items()})


def main(argv=None) -> int:
    """Render, draw, write the numbers; print the table and the point light's verdicts."""
    args = build_parser().parse_args(argv)
    if args.seconds <= 0:
        print("error: --seconds must be positive", file=sys.stderr)
        return 2
    results = common.run_with_progress(args.lights, lambda key, bar: run_light(key, args, bar),
                                       len(args.integrators), "caustics", not args.no_progress)
    if results is None:
        return 2
    files = [plot_images(results, args.out), plot_errors(results, args.out),
             common.write_json(common.out_dir(args.out) / "caustics.json", summary(results, args))]
    for light, result in results.items():
        for name, row in result["integrators"].items():
            print(f"{light:5s} {name:9s} {row['seconds']:6.2f} s {row['spp']:6d} spp  "
                  f"RMSE {row['rmse']:.4g}  1/(MSE x s) {row['efficiency']:.4g}  "
                  f"{'agrees' if row['agree'] else 'DISAGREES'} (p = {row['p_value']:.2g}, "
                  f"worst at {row['worst_region']}{', in the caustic' if row['worst_in_caustic'] else ''})")
    if "point" in results and "path" in results["point"]["integrators"]:
        row = results["point"]["integrators"]["path"]
        print(f"verdict, path on the point light vs ptracer (alpha = {args.alpha:g}): {row['verdict']}")
    print("wrote " + ", ".join(files), file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
