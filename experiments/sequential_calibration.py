"""Calibration and efficiency of the three-outcome mean verdict in rounds (``--tolerance``).

Each run renders the test side in the rounds of ``look_totals(max_spp)`` all the way to the
budget and judges every look at every level of ``--levels``; the sequential verdict at a level
is then its first decided look (the stopping rule depends on nothing else, so this is the
verdict ``compare --tolerance`` gives, with every level from one set of renders). The same
final images give today's fixed-budget test (equal means at ``max_spp``) for comparison.

* ``sim``: synthetic heavy-tailed radiance (a sample is ``mu / q`` with probability ``q``, else
  0: relative per-sample sd 2 at q = 0.2), a fresh 4096-spp reference per run;
* ``real``: our ``path`` on cornell-box against Mitsuba's ``path`` reference (one reference,
  built once), the test side's images scaled by ``1 + bias`` (a renderer that much too bright).

    python -m experiments.sequential_calibration sim --runs 1000
    python -m experiments.sequential_calibration real --runs 200 --resolution 32x32

Writes docs/data/sequential_<mode>.json: per scenario (bias), per run, per level the outcome,
the spp and seconds of the decision, and today's verdict at ``max_spp``.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from mitsuba_refs.reference.cache import get_reference
from mitsuba_refs.stats import clopper_pearson, compare_variances
from mitsuba_refs.stats.equivalence import UNDECIDED, decide_tolerance
from mitsuba_refs.stats.mean import VARIANCE_BOUND, MeanTestOptions, compare_means
from mitsuba_refs.stats.sequential import alpha_per_look, look_totals, merge_moments
from mitsuba_refs.stats.variance import TooFewTiles
from mitsuba_refs.verdicts.scenes import default_params, render_ours

from .bench import cpu_name

ROOT = Path(__file__).resolve().parent.parent
LEVELS = (0.05, 0.01, 1e-3)
OPTIONS = MeanTestOptions(same_estimator=True)


class Synthetic:
    """Heavy-tailed radiance: per pixel ``mu / q`` with probability ``q``, else 0."""

    def __init__(self, size=32, q=0.2, seed=0):
        rng = np.random.default_rng(seed)
        self.mu = 0.2 + 0.8 * rng.random((size, size, 1)) * np.ones((1, 1, 3))
        self.q = q

    def render(self, spp, rng, factor=1.0):
        hits = rng.binomial(spp, self.q, size=self.mu.shape[:2])[..., None] * np.ones((1, 1, 3))
        value = self.mu / self.q * factor
        mean = value * hits / spp
        variance = value ** 2 * hits * (spp - hits) / (spp * max(spp - 1, 1))
        return mean, variance


def judge_run(render, reference, totals, tolerance, levels, factor):
    """One run: every look at every level, and today's fixed-budget test at the last total.

    ``render(n, index)`` returns the round's mean, variance and render seconds; a look's
    seconds are the rounds' render seconds so far (the judging is left out, as it judges
    every level)."""
    mean = variance = None
    spp, seconds, looks = 0, 0.0, []
    for index, total in enumerate(totals):
        m, v, round_seconds = render(total - spp, index)
        m, v = m * factor, v * factor ** 2
        mean, variance = (m, v) if mean is None else merge_moments(mean, variance, spp, m, v,
                                                                   total - spp)
        spp, seconds = total, seconds + round_seconds
        outcomes = {}
        for level in levels:
            decision = decide_tolerance((mean, variance, spp), reference, tolerance=tolerance,
                                        alpha=alpha_per_look(level, len(totals)),
                                        max_var_ratio=VARIANCE_BOUND, options=OPTIONS)
            outcomes[str(level)] = decision.outcome
        looks.append({"spp": spp, "seconds": seconds, "outcomes": outcomes,
                      "variance_p": variance_p(mean, variance, spp, reference)})
    today = {str(level): bool(compare_means(mean, variance, spp, *reference, alpha=level,
                                            max_var_ratio=VARIANCE_BOUND, options=OPTIONS).agree)
             for level in levels}
    verdicts = {}
    for level in levels:
        first = next((look for look in looks if look["outcomes"][str(level)] != UNDECIDED), looks[-1])
        verdicts[str(level)] = {"outcome": first["outcomes"][str(level)], "spp": first["spp"],
                                "seconds": round(first["seconds"], 4),
                                "variance_agrees": first["variance_p"] > level}
    return {"verdicts": verdicts, "today_agrees": today,
            "today_seconds": round(looks[-1]["seconds"], 4)}


def variance_p(mean, variance, spp, reference) -> float:
    """The variance verdict's p at a look (compare judges it on the look that stopped); 1 when
    the image has too few noisy tiles to test (compare then skips it)."""
    try:
        return float(compare_variances(variance, spp, reference[1], reference[2], alpha=0.05,
                                       mean_a=mean, mean_b=reference[0]).p_value)
    except TooFewTiles:
        return 1.0


def summary(runs, levels, bias, tolerance):
    """Rates with Clopper-Pearson 95 % intervals, median spp to a decision."""
    out = {}
    for level in levels:
        key = str(level)
        outcomes = [run["verdicts"][key]["outcome"] for run in runs]
        n = len(outcomes)
        row = {}
        for name in ("agrees", "disagrees", "undecided"):
            k = outcomes.count(name)
            row[name] = {"count": k, "rate": k / n, "ci95": clopper_pearson(k, n)}
        today_k = sum(not run["today_agrees"][key] for run in runs)
        row["today_disagrees"] = {"count": today_k, "rate": today_k / n}
        # compare's outcome: DISAGREES also when the variance verdict fails at the stopping look
        combined = sum(run["verdicts"][key]["outcome"] == "disagrees"
                       or not run["verdicts"][key]["variance_agrees"] for run in runs)
        row["disagrees_with_variance"] = {"count": combined, "rate": combined / n,
                                          "ci95": clopper_pearson(combined, n)}
        decided = [run["verdicts"][key]["spp"] for run in runs
                   if run["verdicts"][key]["outcome"] != "undecided"]
        row["median_spp_decided"] = float(np.median(decided)) if decided else None
        row["median_spp_all"] = float(np.median([run["verdicts"][key]["spp"] for run in runs]))
        row["median_seconds_all"] = float(np.median([run["verdicts"][key]["seconds"] for run in runs]))
        row["today_median_seconds"] = float(np.median([run["today_seconds"] for run in runs]))
        out[key] = row
    return {"bias": bias, "tolerance": tolerance, "levels": out}


def simulate(args):
    """The synthetic runs of every scenario (``args.biases``)."""
    model = Synthetic(args.size)
    totals = look_totals(args.max_spp)
    scenarios = {}
    for bias in args.biases:
        runs = []
        for run in range(args.runs):
            rng = np.random.default_rng([args.seed, run, int(round(bias * 1e4)) % 2 ** 31])
            reference = (*model.render(4096, rng), 4096)
            runs.append(judge_run(lambda n, _i: (*model.render(n, rng), 0.0), reference, totals,
                                  args.tolerance, LEVELS, 1.0 + bias))
        scenarios[f"{bias:+g}"] = {"summary": summary(runs, LEVELS, bias, args.tolerance),
                                   "runs": runs}
        print(json.dumps(scenarios[f"{bias:+g}"]["summary"])[:600], flush=True)
    return {"model": f"{args.size}x{args.size}, heavy-tailed: mu/q with probability q=0.2",
            "max_spp": args.max_spp, "looks": list(totals), "scenarios": scenarios}


def real(args):
    """Our ``path`` against Mitsuba's reference, every scenario (``args.biases``)."""
    params = default_params(args.scene)
    resolution = tuple(int(x) for x in args.resolution.split("x"))
    ref = get_reference(args.scene, params, "path", resolution=resolution)
    reference = (ref.mean, ref.var, ref.n)
    totals = look_totals(args.max_spp)
    rendered = {}    # (run, round) -> mean, variance, seconds: every bias scales the same renders
    scenarios = {}
    for bias in args.biases:
        runs = []
        for run in range(args.runs):
            def render(n, index, run=run):
                if (run, index) not in rendered:
                    start = time.perf_counter()
                    seed = 50_000 + 1000 * run + 100 * index
                    images = render_ours(args.scene, "path", params, n, seed, processes=1,
                                         resolution=resolution)
                    rendered[run, index] = (*images, time.perf_counter() - start)
                return rendered[run, index]
            runs.append(judge_run(render, reference, totals, args.tolerance, LEVELS, 1.0 + bias))
        scenarios[f"{bias:+g}"] = {"summary": summary(runs, LEVELS, bias, args.tolerance),
                                   "runs": runs}
        print(json.dumps(scenarios[f"{bias:+g}"]["summary"])[:600], flush=True)
    return {"scene": args.scene, "resolution": args.resolution, "integrator": "path",
            "reference_spp": int(np.max(ref.n)), "max_spp": args.max_spp,
            "looks": list(totals), "scenarios": scenarios}


def main(argv=None):
    """Run ``sim`` or ``real``; write the JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mode", choices=("sim", "real"))
    parser.add_argument("--runs", type=int, default=1000)
    parser.add_argument("--tolerance", type=float, default=0.02, help="relative (0.02: 2 %%)")
    parser.add_argument("--biases", type=lambda t: [float(x) for x in t.split(",")],
                        default=[0.0, 0.02, -0.02, 0.2])
    parser.add_argument("--max-spp", type=int, default=256)
    parser.add_argument("--size", type=int, default=32)
    parser.add_argument("--scene", default="cornell-box")
    parser.add_argument("--resolution", default="32x32")
    parser.add_argument("--seed", type=int, default=20261205)
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)
    start = time.perf_counter()
    data = simulate(args) if args.mode == "sim" else real(args)
    data.update(runs=args.runs, tolerance=args.tolerance, levels=list(LEVELS), cpu=cpu_name(),
                seconds=round(time.perf_counter() - start, 1))
    path = Path(args.json or ROOT / "docs" / "data" / f"sequential_{args.mode}.json")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=1) + "\n")
    print(f"wrote {path} ({data['seconds']} s on {data['cpu']})")


if __name__ == "__main__":
    main()
