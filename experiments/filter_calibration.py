"""Calibration of the statistics on filtered films (docs/statistics.md, section 7).

Simulated renders (no tracer, no Mitsuba): every sample of the moderate simulated scene lands
at a uniform position in its pixel and is splatted through the filter by the tracer's film
code (:mod:`mitsuba_refs.stats.simulate_filtered`). For each filter it reports how often a
correct renderer is rejected, at alpha 0.05 and 0.2, with 95 % Clopper-Pearson intervals:

* ``tests``: mean and variance tests (``compare_means(max_var_ratio=4)``, ``compare_variances``)
  with the filter's pixel correlation, and with pixels taken as independent;
* ``convergence``: :func:`mitsuba_refs.verdicts.convergence.convergence_test` (ladder, blocks, equal work)
  with one reference shared by all seeds.

    python -m experiments.filter_calibration tests --seeds 400          # ~5 min per filter
    python -m experiments.filter_calibration convergence --seeds 200    # ~5 min per filter
"""
from __future__ import annotations

import argparse
from types import SimpleNamespace

import numpy as np

from mitsuba_refs.reference.rfilter import filter_metadata
from mitsuba_refs.stats import MeanTestOptions, VarianceTestOptions, clopper_pearson, compare_means, compare_variances
from mitsuba_refs.stats.correlation import pixel_correlation
from mitsuba_refs.stats.simulate import make_scene
from mitsuba_refs.stats.simulate_filtered import render_filtered
from mitsuba_refs.verdicts.convergence import LadderPlan, convergence_ladder, convergence_test
from pathtracer.sensors.film import ReconstructionFilter

LEVELS = (0.05, 0.2)


def _rate(p_values) -> str:
    p = np.asarray(p_values)
    parts = []
    for level in LEVELS:
        k, n = int(np.sum(p <= level)), len(p)
        lo, hi = clopper_pearson(k, n)
        parts.append(f"{k}/{n} = {100 * k / n:.1f} % [{100 * lo:.1f}, {100 * hi:.1f}]")
    return " | ".join(parts)


def tests(kind: str, seeds: int, size: int, n_test: int, n_ref: int) -> None:
    """False rejections of the mean and variance tests, corrected and as if independent."""
    rfilter = ReconstructionFilter.make(kind)
    scene = make_scene(size, size, seed=3, p_range=(0.1, 0.6))
    rng = np.random.default_rng(11)
    rows = {}
    for _ in range(seeds):
        ma, va = render_filtered(scene, rfilter, n_test, rng)
        mb, vb = render_filtered(scene, rfilter, n_ref, rng)
        for label, corr in (("corrected", pixel_correlation(rfilter)), ("independent", None)):
            mean = compare_means(ma, va, n_test, mb, vb, n_ref, alpha=0.05, max_var_ratio=4,
                                 options=MeanTestOptions(pixel_correlation=corr))
            var = compare_variances(va, n_test, vb, n_ref, alpha=0.05,
                                    options=VarianceTestOptions(pixel_correlation=corr))
            for name, p in (("mean", mean.p_value), ("mean tiles", mean.scale_p_values["8px"]),
                            ("variance", var.p_value), ("variance global", var.global_p),
                            ("variance tiles", var.tile_p)):
                rows.setdefault((label, name), []).append(p)
    print(f"{kind}: {size}x{size} px, {n_test} vs {n_ref} spp, rejections at alpha "
          f"{' | '.join(map(str, LEVELS))}")
    for (label, name), p in rows.items():
        print(f"  {label:12s} {name:16s} {_rate(p)}")


def convergence(kind: str, seeds: int, size: int, n_ref: int) -> None:
    """False rejections of the convergence law through the harness's convergence_test."""
    rfilter = ReconstructionFilter.make(kind)
    scene = make_scene(size, size, seed=3, p_range=(0.1, 0.6))
    ref_mean, ref_var = render_filtered(scene, rfilter, n_ref, np.random.default_rng(99))
    reference = SimpleNamespace(mean=ref_mean, var=ref_var, n=n_ref,
                                metadata={"rfilter": filter_metadata(rfilter)})
    p_values, slopes = [], []
    for seed in range(seeds):
        def render(_scene, _integrator, _params, spp, render_seed, processes=None, seed=seed):
            rng = np.random.default_rng([seed, render_seed])
            return render_filtered(scene, rfilter, spp, rng)[0], None
        law, _ = convergence_test("sim", "sim", {}, reference, 0.05, None, render,
                                  LadderPlan((1, 4, 16, 64), 2))
        p_values.append(law.p_value)
        slopes.append(law.slope)
    print(f"{kind}: convergence, ladder {convergence_ladder(reference, (1, 4, 16, 64))},"
          f" rejections {_rate(p_values)}, median slope {np.median(slopes):.4f}")


def main(argv=None) -> None:
    """Measure the filtered-film tests' false-rejection rates (command line)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("what", choices=("tests", "convergence"))
    parser.add_argument("--filters", nargs="+", default=["box", "tent", "gaussian"])
    parser.add_argument("--seeds", type=int, default=400)
    parser.add_argument("--size", type=int, default=32)
    parser.add_argument("--spp", type=int, default=8, help="test side (tests)")
    parser.add_argument("--ref-spp", type=int, default=None,
                        help="reference (default 64 for tests, 2048 for convergence)")
    args = parser.parse_args(argv)
    for kind in args.filters:
        if args.what == "tests":
            tests(kind, args.seeds, args.size, args.spp, args.ref_spp or 64)
        else:
            convergence(kind, args.seeds, args.size, args.ref_spp or 2048)


if __name__ == "__main__":
    main()
