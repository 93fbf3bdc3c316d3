"""Power of the graded mean parts: the smallest global bias each check detects.

``python -m autograder.power [--assignment NAME]`` prints, for every check of the assignment
(:data:`autograder.grading.ASSIGNMENTS`, whatever it holds when run), the smallest relative bias
``b`` such that an image ``(1+b)`` times the truth fails the check's mean part with probability
>= 0.95 at the assignment's per-part level (:func:`autograder.grading.alpha_of`):

1. analytically, from the committed reference's per-pixel mean and variance and the test's
   statistic (:func:`mitsuba_refs.stats.detectable_bias`: the whole-image component of the
   mean test, the reference's own noise included; an upper bound on the detectable bias);
2. confirmed by injection: :func:`injected_power` draws a reference and a test render around
   the reference image at the real per-pixel variances (4096 and ``check.spp`` samples),
   multiplies the test by ``1+b`` and runs the grader's :func:`compare_means` on them;
3. the gross-error bound: the observed image-mean deviation that fails the mean part whatever
   the submission's own variance (:func:`mitsuba_refs.stats.detectable.gross_error_bound`);
4. optionally (``--renders K``) on real renders of the reference solution at ``check.spp``,
   scaled by ``1+b`` and compared with the committed reference (K seeds; slow).

A light tracer's check (``mitsuba_refs.verdicts.estimators.SPLATTING``) has no whole-image components:
its pixels are correlated across the image (docs/statistics.md, section 8), so the tiles
decide alone, with their own variance and with the bounded one. Its analytic bound is
:func:`mitsuba_refs.stats.detectable.tile_detectable_bias` (each tile's best channel,
Bonferroni over the two components, tiles and channels), its injection runs ``compare_means``
without the image components, and its gross-error bound is the tiles'
(:func:`mitsuba_refs.stats.detectable.tile_gross_error_bound`).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import dataclass

import numpy as np

from mitsuba_refs.reference.cache import get_reference
from mitsuba_refs.stats import VARIANCE_BOUND, compare_means
from mitsuba_refs.stats.detectable import (
    detectable_bias,
    gross_error_bound,
    tile_detectable_bias,
    tile_gross_error_bound,
)
from mitsuba_refs.stats.replicas import replica_moments
from mitsuba_refs.verdicts.estimators import SPLATTING, reference_integrator
from mitsuba_refs.verdicts.scenes import render_ours

from . import grading
from .replicas import scored_render

#: The bias every integrator check must detect (probability >= POWER at its per-part level).
TARGET_BIAS = 0.015
POWER = 0.95


def reference_of(check):
    """The committed reference a check compares with (no rendering): at the check's own
    parameters (:func:`autograder.grading.check_params`: film size, max_depth and rr_depth
    if set)."""
    return get_reference(check.scene, grading.check_params(check),
                         reference_integrator(check.integrator), render=False)


def splats(check) -> bool:
    """Whether ``check`` grades an integrator that splats (its mean test has tiles only)."""
    return check.integrator in SPLATTING


@dataclass(frozen=True)
class Injection:
    """How :func:`injected_power` simulates renders and tests them.

    Attributes
    ----------
    alpha : float  level of the mean test
    seeds : int  simulated renders
    seed : int  seed of the generator (results are deterministic)
    max_var_ratio : float or None  as the grader passes it (same estimator)
    image_components : bool  as the grader passes it (False for a light tracer)
    replicas : int, optional  the test's variance from this many replicas
    """

    alpha: float
    seeds: int
    seed: int = 0
    max_var_ratio: float | None = VARIANCE_BOUND
    image_components: bool = True
    replicas: int | None = None


def injected_power(b: float, ref_mean, ref_var, ref_n, n_test, injection: Injection) -> float:
    """Fraction of ``injection.seeds`` simulated renders ``(1+b)`` times the truth that the mean
    test rejects.

    The committed reference image is taken as the truth ``T``.  Each seed draws a reference
    ``T + e_b`` and a test ``(1+b)(T + e_a)`` with per-pixel normal errors of variance
    ``v/ref_n`` and ``v/n_test`` (``v`` the reference's per-sample variances; one standard
    normal per pixel shared by the channels, as one path carries all three) and runs
    :func:`compare_means` exactly as the grader does. With ``injection.replicas`` = K the test
    is K such renders of ``n_test / K`` samples and its variance their spread, as the grader
    measures it (:mod:`autograder.replicas`); otherwise the test's variance is the true one.

    Parameters
    ----------
    b : float  relative bias
    ref_mean, ref_var : array (H, W, 3)  reference mean and per-sample variance
    ref_n, n_test : int  samples per pixel of the reference and of the test
    injection : Injection  the simulation and the mean test's settings
    """
    rng = np.random.default_rng(injection.seed)
    truth = np.asarray(ref_mean, dtype=np.float64)
    v = np.maximum(np.asarray(ref_var, dtype=np.float64), 0.0)
    sd_ref = np.sqrt(v / ref_n)
    h, w = truth.shape[:2]
    rejected = 0
    for _ in range(injection.seeds):
        reference = truth + sd_ref * rng.standard_normal((h, w, 1))
        test, test_var = _simulated_test(rng, truth, v, n_test, b, injection.replicas)
        result = compare_means(test, test_var, n_test, reference, v, ref_n,
                               alpha=injection.alpha, max_var_ratio=injection.max_var_ratio,
                               image_components=injection.image_components)
        rejected += not result.agree
    return rejected / injection.seeds


def _simulated_test(rng, truth, v, n_test, b, replicas):
    """A simulated test render ``(1+b)(T + e)`` and its per-sample variance: the true one, or
    the spread of ``replicas`` simulated replicas of ``n_test / replicas`` samples."""
    h, w = truth.shape[:2]
    if not replicas:
        return ((1.0 + b) * (truth + np.sqrt(v / n_test) * rng.standard_normal((h, w, 1))),
                v * (1.0 + b) ** 2)
    per_replica = n_test // replicas
    stack = (1.0 + b) * (truth + np.sqrt(v / per_replica)
                         * rng.standard_normal((replicas, h, w, 1)))
    return replica_moments(stack, per_replica)


def rendered_power(check, b: float, renders: int, *, alpha: float, seed: int = 70_000) -> float:
    """Fraction of ``renders`` real renders of the reference solution at ``check.spp`` (as the
    grader renders them: replicas, :func:`autograder.grading.scored_replicas`), multiplied by
    ``1+b``, whose mean part fails against the committed reference."""
    reference = reference_of(check)
    count = grading.scored_replicas(check)

    def render(scene, integrator, params, spp, render_seed):
        return render_ours(scene, integrator, params, spp, render_seed, processes=1)
    rejected = 0
    for k in range(renders):
        if count:
            scored = scored_render(render, check.scene, check.integrator,
                                   grading.check_params(check), check.spp, seed + k,
                                   replicas=count)
            mean, var = scored.mean, scored.variance
        else:
            mean, var = render(check.scene, check.integrator, grading.check_params(check),
                               check.spp, seed + k)
        result = compare_means(mean * (1 + b), var * (1 + b) ** 2, check.spp, reference.mean,
                               reference.var, reference.n, alpha=alpha,
                               max_var_ratio=VARIANCE_BOUND, image_components=not splats(check))
        rejected += not result.agree
    return rejected / renders


def power_table(checks=None, *, alpha: float | None = None, seeds: int = 200,
                renders: int = 0) -> list[dict]:
    """One row per check: spp, analytic detectable bias (both signs), injected power there.

    ``alpha``: the per-part level (default: each check's own, :func:`autograder.grading.alpha_of`).
    """
    checks = grading.CHECKS if checks is None else checks
    rows = []
    for i, check in enumerate(checks):
        if not any(name == "mean" for name, _ in check.parts):
            continue
        ref = reference_of(check)
        level = alpha or grading.alpha_of(check)
        tiles_only = splats(check)
        row = {"check": check.id, "spp": check.spp, "alpha": level, "tiles_only": tiles_only}
        bound = tile_detectable_bias if tiles_only else detectable_bias
        for sign, key in ((1, "brighter"), (-1, "darker")):
            b = bound(ref.mean, ref.var, ref.n, check.spp, alpha=level, power=POWER, sign=sign)
            row[f"bias_{key}"] = b
            injection = Injection(alpha=level, seeds=seeds, seed=1000 * i + (sign > 0),
                                  image_components=not tiles_only,
                                  replicas=grading.scored_replicas(check))
            row[f"injected_power_{key}"] = injected_power(sign * b, ref.mean, ref.var, ref.n,
                                                          check.spp, injection)
            if renders:
                row[f"rendered_power_{key}"] = rendered_power(check, sign * b, renders,
                                                              alpha=level)
        row["detectable_bias"] = max(row["bias_brighter"], row["bias_darker"])
        row["reference_floor"] = bound(ref.mean, ref.var, ref.n, 1e15, alpha=level, power=POWER)
        gross = tile_gross_error_bound if tiles_only else gross_error_bound
        row["gross_error_bound"] = gross(ref.mean, ref.var, ref.n, check.spp, alpha=level,
                                         max_var_ratio=VARIANCE_BOUND)
        rows.append(row)
    return rows


def format_table(rows) -> str:
    """Markdown table of :func:`power_table` rows."""
    lines = ["| check | spp | detectable bias (+ / -) | injected power there (+ / -) | "
             "with infinite spp | always rejected, any variance |", "|---|---|---|---|---|---|"]
    for r in rows:
        extra = ""
        if "rendered_power_brighter" in r:
            extra = (f" (renders: {100 * r['rendered_power_brighter']:.0f} % / "
                     f"{100 * r['rendered_power_darker']:.0f} %)")
        lines.append(f"| {r['check']} | {r['spp']} | {100 * r['bias_brighter']:.2f} % / "
                     f"{100 * r['bias_darker']:.2f} % | {100 * r['injected_power_brighter']:.1f} % / "
                     f"{100 * r['injected_power_darker']:.1f} %{extra} | "
                     f"{100 * r['reference_floor']:.2f} % | "
                     f"{100 * r['gross_error_bound']:.1f} %" + (" (tiles)" if r.get("tiles_only")
                                                                 else "") + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    """Print each check's smallest detectable bias at the grader's level (command line); exit code."""
    parser = argparse.ArgumentParser(prog="python -m autograder.power", description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=200, help="injected renders per check and sign")
    parser.add_argument("--renders", type=int, default=0,
                        help="also real renders of the reference solution per check and sign (slow)")
    parser.add_argument("--alpha", type=float, default=None,
                        help="per-part level (default: the assignment's, grading.alpha_of)")
    parser.add_argument("--assignment", choices=list(grading.ASSIGNMENTS),
                        default=grading.DEFAULT_ASSIGNMENT, help="the assignment (default: %(default)s)")
    parser.add_argument("--checks", nargs="*", help="check ids (default: all of the assignment)")
    parser.add_argument("--json", help="also write the rows here")
    args = parser.parse_args(argv)
    checks = ([grading.CHECKS_BY_ID[c] for c in args.checks] if args.checks
              else grading.checks_of(args.assignment))
    start = time.perf_counter()
    rows = power_table(checks, alpha=args.alpha, seeds=args.seeds, renders=args.renders)
    alpha = rows[0]["alpha"] if rows else grading.ALPHA
    print(f"mean part, per-part alpha {alpha:.3g}, power {POWER}, target {100 * TARGET_BIAS:g} %")
    print(format_table(rows))
    over = [r["check"] for r in rows if r["detectable_bias"] > TARGET_BIAS and not r["check"] == "camera"]
    print(f"({time.perf_counter() - start:.0f} s) "
          + (f"above the target: {', '.join(over)}" if over else "every check meets the target"))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)
    return 1 if any(math.isinf(r["detectable_bias"]) for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
