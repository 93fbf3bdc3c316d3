"""Mitsuba's samplers against its own ``independent`` reference: mean, error law, where.

For each sampler (``independent``, ``stratified``, ``multijitter``, ``orthogonal``,
``ldsampler``) and scene (``cornell-box``, ``cornell-caustics``: a mirror and a glass sphere),
Mitsuba 3 renders the scene file with only the sampler's type changed, at every level of a
ladder with the same number of samples per level (``--top`` replicas at the highest count),
each render with a seed of its own, spread far apart (``seed * 8192 mod 2^31 - 1``: Mitsuba's
samplers seeded with consecutive integers replay shifted streams). Measured against the
committed 4096-spp reference of the ``independent`` sampler:

* the MSE law: the least-squares slope of log mean image MSE on log N
  (:func:`mitsuba_refs.stats.convergence_law`; the RMSE exponent is half of it);
* where: the same slope on the pixels whose camera ray first hits a sphere and on the rest;
* the variance of the mean: the replicas' spread at each level times N, over the independent
  sampler's per-sample variance (1 at every level for independent samples; falling with N
  when stratification helps; rising when a pixel's samples are positively correlated);
* a bias: the mean of all renders at the top level against the reference
  (:func:`mitsuba_refs.stats.compare_means`, variance from the replicas' spread).

``python -m experiments.samplers --scenes cornell-caustics --samplers independent ldsampler``
writes ``docs/data/samplers_<scene>.json``. It renders through Mitsuba's Python API in
``scalar_rgb`` (the code the command line runs), one process. ``--dimensions SPP`` measures
how correlated a sampler's dimensions are (:func:`dimension_pairs`), ``--bias SPP`` its image
mean against the independent sampler's (:func:`paired_bias`), ``--check`` runs the harness.
"""
from __future__ import annotations

import argparse
import json
import math
import re
import tempfile
import time
from pathlib import Path

import numpy as np

from mitsuba_refs.external.check import check
from mitsuba_refs.reference.cache import get_reference
from mitsuba_refs.stats import compare_means, convergence_law, image_mse
from mitsuba_refs.verdicts.scenes import default_params
from pathtracer.scene.load import scene_file

SAMPLERS = ("independent", "stratified", "multijitter", "orthogonal", "ldsampler")
#: Sample counts each sampler renders exactly (Mitsuba rounds others up: stratified to a
#: square, orthogonal to a prime squared, ldsampler to a power of 4).
LADDERS = {"independent": (4, 16, 64, 256), "stratified": (4, 16, 64, 256),
           "multijitter": (4, 16, 64, 256), "ldsampler": (4, 16, 64, 256),
           "orthogonal": (4, 25, 121)}
#: Mitsuba's command line given consecutive seeds replays shifted streams: spread them.
SEED_SPREAD = 8192
SEED_MODULUS = 2147483647


def sampler_file(scene: str, sampler: str, folder: Path) -> Path:
    """A copy of the built-in ``scene`` whose sampler is ``sampler`` (nothing else changed)."""
    text = Path(scene_file(scene)).read_text()
    changed, count = re.subn(r'<sampler type="independent">', f'<sampler type="{sampler}">', text)
    if count != 1:
        raise ValueError(f"{scene}: expected one independent sampler, found {count}")
    path = folder / f"{scene}-{sampler}.xml"
    path.write_text(changed)
    return path


def sphere_mask(mi, scene) -> np.ndarray:
    """(H, W) True where the pixel centre's camera ray first hits a sphere."""
    sensor = scene.sensors()[0]
    width, height = sensor.film().crop_size()
    mask = np.zeros((height, width), dtype=bool)
    for row in range(height):
        for col in range(width):
            ray, _ = sensor.sample_ray(0.0, 0.0, mi.Point2f((col + 0.5) / width,
                                                            (row + 0.5) / height),
                                       mi.Point2f(0.5, 0.5))
            hit = scene.ray_intersect(ray)
            mask[row, col] = bool(hit.is_valid()) and "sphere" in str(hit.shape.id())
    return mask


def _slope(ladder, mses) -> dict:
    law = convergence_law(np.array(ladder), [np.asarray(m) for m in mses], alpha=0.001)
    return {"mse_slope": law.slope, "mse_slope_ci": law.slope_ci,
            "rmse_exponent": law.slope / 2, "slope_p": law.slope_p, "floor_p": law.floor_p}


def measure(mi, scene: str, sampler: str, top: int, folder: Path, log=print) -> dict:
    """Every number of the module notes for one sampler on one scene."""
    params = default_params(scene)
    reference = get_reference(scene, params, "path", render=False)
    loaded = mi.load_file(str(sampler_file(scene, sampler, folder)),
                          **{k: str(v) for k, v in params.items()})
    mask = sphere_mask(mi, loaded)
    ladder = LADDERS[sampler]
    ref_var_mean = reference.var / reference.n
    indep_var = np.mean(reference.var)          # per-sample variance of the independent sampler
    out = {"scene": scene, "sampler": sampler, "ladder": ladder, "top_replicas": top,
           "sphere_pixels": int(mask.sum()), "levels": []}
    whole, spheres, rest, top_images = [], [], [], []
    start = time.perf_counter()
    counter = 0
    for level, n in enumerate(ladder):
        replicas = top * ladder[-1] // n
        images = []
        for k in range(replicas):
            counter += 1
            seed = (1_000_003 * (SAMPLERS.index(sampler) + 1) + counter) * SEED_SPREAD % SEED_MODULUS
            image = np.asarray(mi.render(loaded, spp=n, seed=seed), dtype=np.float64)[..., :3]
            images.append(image)
        stack = np.stack(images)
        whole.append([image_mse(i, reference.mean, reference.var, reference.n) for i in stack])
        spheres.append([image_mse(i[mask], reference.mean[mask], reference.var[mask],
                                  reference.n) for i in stack])
        rest.append([image_mse(i[~mask], reference.mean[~mask], reference.var[~mask],
                               reference.n) for i in stack])
        spread = float(np.mean(stack.var(axis=0, ddof=1)))
        out["levels"].append({"spp": n, "renders": replicas,
                              "mean_mse": float(np.mean(whole[-1])),
                              "variance_of_mean_times_n_over_independent": spread * n / indep_var})
        if level == len(ladder) - 1:
            top_images = stack
        log(f"{scene} {sampler} {n} spp x {replicas}: MSE {np.mean(whole[-1]):.4g}, "
            f"spread x N / independent {spread * n / indep_var:.3f} ({time.perf_counter() - start:.0f} s)")
    out["whole"] = _slope(ladder, whole)
    out["spheres"] = _slope(ladder, spheres)
    out["diffuse"] = _slope(ladder, rest)
    # The mean of every top-level render against the reference, variance from their spread.
    mean = top_images.mean(axis=0)
    var = top_images.var(axis=0, ddof=1) * ladder[-1]
    samples = ladder[-1] * len(top_images)
    agreement = compare_means(mean, var, samples, reference.mean, reference.var, reference.n,
                              alpha=0.001)
    out["mean"] = {"p_value": agreement.p_value, "rel_bias": agreement.rel_bias,
                   "rel_bias_ci": agreement.rel_bias_ci, "samples": samples}
    out["reference_variance_of_mean"] = float(np.mean(ref_var_mean))
    out["seconds"] = time.perf_counter() - start
    return out


#: Mitsuba's command line as the harness runs it.
MITSUBA_COMMAND = ("mitsuba -m scalar_rgb -o {out} {defines} -D spp={spp} -D seed={seed} "
                   "-D max_depth={max_depth} {scene}")
#: Per sampler: the check's mean render (spp, replicas) and ladder, every count one it renders
#: exactly (an image with more samples than asked would bend the measured law).
CHECK_PLANS = {"independent": (64, 4, (4, 16, 64)), "stratified": (64, 4, (4, 16, 64)),
               "multijitter": (64, 4, (4, 16, 64)), "ldsampler": (64, 4, (4, 16, 64)),
               "orthogonal": (100, 4, (4, 9, 25, 49))}


def check_sampler(scene: str, sampler: str, folder: Path, *, alpha=1e-3, replicas=4,
                  seed_offset=0, spp=None, params=None, ladder=None):
    """``mitsuba-refs check`` of Mitsuba's command line with ``sampler`` on ``scene``
    (the reference: the scene file's own ``independent`` sampler)."""
    mean_spp, variance_replicas, planned = CHECK_PLANS[sampler]
    ladder = ladder or planned
    return check(scene, command=MITSUBA_COMMAND, renderer_scene=sampler_file(scene, sampler, folder),
                 params=params,
                 same_estimator=True, spp=spp or mean_spp, variance_replicas=variance_replicas,
                 ladder=ladder, ladder_replicas=replicas, alpha=alpha, bounces=False, jobs=2,
                 seed_offset=seed_offset)


def checks(args) -> None:
    """``--check``: the harness's verdicts on every sampler, one line each."""
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for scene in args.scenes:
            for sampler in args.samplers:
                for offset in range(args.repeat):
                    start = time.perf_counter()
                    params = None if args.max_depth is None else {"max_depth": args.max_depth}
                    result = check_sampler(scene, sampler, Path(folder), seed_offset=offset,
                                           replicas=args.replicas, spp=args.spp, params=params,
                                           alpha=args.alpha)
                    law = result.convergence
                    row = {"scene": scene, "sampler": sampler, "seed_offset": offset,
                           "params": params, "ladder": list(result.ladder),
                           "seconds": time.perf_counter() - start, "agree": result.agree,
                           "mean_p": result.mean.p_value, "rel_bias": result.mean.rel_bias,
                           "rel_bias_ci": result.mean.rel_bias_ci,
                           "mse_slope": law.slope, "mse_slope_ci": law.slope_ci,
                           "convergence_p": law.p_value, "faster_p": law.faster_p,
                           "faster": law.faster, "convergence_passed": law.passed,
                           "variance": (result.variance.agree if result.variance is not None
                                        else "n/a"),
                           "variance_p": (result.variance.p_value if result.variance is not None
                                          else None),
                           "report": result.report()}
                    rows.append(row)
                    print(result.report(), flush=True)
                    print(f"== {scene} {sampler} offset {offset}: {row['seconds']:.1f} s", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))


def dimension_pairs(mi, sampler: str, spp: int, pixels: int, dimensions: int = 64) -> dict:
    """How far apart two of a sampler's 1-D dimensions must be to be independent.

    ``pixels`` sequences (seeds far apart) of ``spp`` samples each, ``dimensions`` values
    ``next_1d`` per sample: for every pair of dimensions E[x_a x_b] - 1/4, which is 0 for
    independent uniform numbers (standard error sqrt(7/144 / draws)). Returns the count of
    pairs beyond 5 standard errors and the mean excess at each lag, as a correlation
    (12 x the excess).
    """
    generator = mi.load_dict({"type": sampler, "sample_count": spp})
    spp = generator.sample_count()
    products = np.zeros((dimensions, dimensions))
    for pixel in range(pixels):
        generator.seed((pixel + 1) * SEED_SPREAD * 12_289 % SEED_MODULUS)
        values = np.empty((spp, dimensions))
        for sample in range(spp):
            for dimension in range(dimensions):
                values[sample, dimension] = generator.next_1d()
            generator.advance()
        products += values.T @ values
    excess = products / (pixels * spp) - 0.25
    se = math.sqrt(7 / 144 / (pixels * spp))
    upper = np.triu_indices(dimensions, 1)
    lags = {lag: 12 * float(np.mean(np.diagonal(excess, lag))) for lag in range(1, dimensions // 2)}
    return {"sampler": sampler, "spp": spp, "pixels": pixels, "dimensions": dimensions,
            "pairs_beyond_5_se": int(np.sum(np.abs(excess[upper]) > 5 * se)),
            "pairs": len(upper[0]), "standard_error": se, "correlation_by_lag": lags}


def paired_bias(mi, scene: str, sampler: str, spp: int, renders: int, folder: Path,
                **params) -> dict:
    """The image mean of ``sampler`` over the ``independent`` sampler's, minus 1, per channel,
    from ``renders`` renders of each at ``spp`` with the scene parameters ``params`` (e.g.
    ``max_depth``, ``rr_depth``), and its z from the renders' spread."""
    defines = {**{k: str(v) for k, v in default_params(scene).items()},
               **{k: str(v) for k, v in params.items()}}
    means = {}
    for offset, name in ((1000, sampler), (5000, "independent")):
        loaded = mi.load_file(str(sampler_file(scene, name, folder)), **defines)
        means[name] = np.array([
            np.asarray(mi.render(loaded, spp=spp, seed=(k + offset) * SEED_SPREAD % SEED_MODULUS),
                       dtype=np.float64)[..., :3].mean(axis=(0, 1)) for k in range(renders)])
    a, b = means[sampler], means["independent"]
    se = np.sqrt(a.var(axis=0, ddof=1) / renders + b.var(axis=0, ddof=1) / renders)
    return {"scene": scene, "sampler": sampler, "spp": spp, "renders": renders, "params": params,
            "relative": (a.mean(axis=0) / b.mean(axis=0) - 1).tolist(),
            "z": ((a.mean(axis=0) - b.mean(axis=0)) / se).tolist()}


def main(argv=None) -> None:
    """Measure every sampler (module notes), or with ``--check`` judge each with the harness."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="run mitsuba-refs check instead")
    parser.add_argument("--repeat", type=int, default=1, help="--check: seed offsets per case")
    parser.add_argument("--replicas", type=int, default=4, help="--check: ladder replicas")
    parser.add_argument("--spp", type=int, default=None, help="--check: the mean render's spp")
    parser.add_argument("--json", default=None, help="--check: write the rows here")
    parser.add_argument("--max-depth", type=int, default=None,
                        help="--check, --bias: -D max_depth")
    parser.add_argument("--rr-depth", type=int, default=None, help="--bias: -D rr_depth")
    parser.add_argument("--dimensions", type=int, default=0, metavar="SPP",
                        help="measure the correlation of 1-D dimensions at this spp instead")
    parser.add_argument("--bias", type=int, default=0, metavar="SPP",
                        help="measure the image mean against the independent sampler's at this "
                             "spp instead (--pixels renders each)")
    parser.add_argument("--pixels", type=int, default=200,
                        help="--dimensions: sequences; --bias: renders per sampler")
    parser.add_argument("--alpha", type=float, default=1e-3, help="--check: the verdicts' level")
    parser.add_argument("--scenes", nargs="+", default=["cornell-box", "cornell-caustics"])
    parser.add_argument("--samplers", nargs="+", default=list(SAMPLERS), choices=SAMPLERS)
    parser.add_argument("--top", type=int, default=4, help="renders at the top level")
    parser.add_argument("--out", default="docs/data")
    args = parser.parse_args(argv)
    if args.check:
        checks(args)
        return
    import mitsuba as mi  # heavy: only when the experiment runs
    mi.set_variant("scalar_rgb")
    if args.dimensions:
        for sampler in args.samplers:
            result = dimension_pairs(mi, sampler, args.dimensions, args.pixels)
            print(json.dumps(result))
        return
    if args.bias:
        with tempfile.TemporaryDirectory() as folder:
            for scene in args.scenes:
                for sampler in args.samplers:
                    params = {} if args.max_depth is None else {"max_depth": args.max_depth}
                    if args.rr_depth is not None:
                        params["rr_depth"] = args.rr_depth
                    print(json.dumps(paired_bias(mi, scene, sampler, args.bias, args.pixels,
                                                 Path(folder), **params)))
        return
    with tempfile.TemporaryDirectory() as folder:
        for scene in args.scenes:
            target = Path(args.out) / f"samplers_{scene}.json"
            results = json.loads(target.read_text()) if target.exists() else {}
            for sampler in args.samplers:
                results[sampler] = measure(mi, scene, sampler, args.top, Path(folder))
                target.write_text(json.dumps(results, indent=1))
                r = results[sampler]
                print(f"{scene} {sampler}: MSE slope {r['whole']['mse_slope']:.3f} "
                      f"[{r['whole']['mse_slope_ci'][0]:.3f}, {r['whole']['mse_slope_ci'][1]:.3f}]"
                      f" spheres {r['spheres']['mse_slope']:.3f} diffuse "
                      f"{r['diffuse']['mse_slope']:.3f}; mean p={r['mean']['p_value']:.2g} "
                      f"bias {100 * r['mean']['rel_bias']:+.2f}%")


if __name__ == "__main__":
    main()
