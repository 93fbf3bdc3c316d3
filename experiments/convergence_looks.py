"""The convergence verdict with two looks (``--tolerance``) against today's one look.

With a tolerance, compare's convergence test looks after half its top-level replicas and
after all of them, each look at alpha / 2, and stops at the first look that rejects the law
(:func:`mitsuba_refs.verdicts.convergence.convergence_test`, ``early_stop``). This measures,
on the same seeds both ways, how often a correct renderer fails (calibration) and, for a
renderer whose every sample is ``1 + bias`` times too bright (a bias floor), how often each
fails and how many renders each made.

* ``sim``: the skewed simulated scene (:mod:`mitsuba_refs.stats.simulate`, 32x32), one
  16384-spp reference shared by the runs, no rendering;
* ``real``: our ``path`` on cornell-box against Mitsuba's committed-size reference.

    python -m experiments.convergence_looks sim --runs 1000
    python -m experiments.convergence_looks real --runs 100 --resolution 16x16

Writes docs/data/convergence_looks_<mode>.json (per scenario and level: failures with 95 %
intervals, the runs stopped at the first look, the median renders and seconds both ways).
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from mitsuba_refs.reference.cache import get_reference
from mitsuba_refs.stats import clopper_pearson
from mitsuba_refs.stats.simulate import make_scene, render_means, render_stats
from mitsuba_refs.verdicts.convergence import CONVERGENCE_LADDER, CONVERGENCE_REPLICAS, LadderPlan, convergence_test
from mitsuba_refs.verdicts.scenes import default_params, render_ours

from .bench import cpu_name

ROOT = Path(__file__).resolve().parent.parent
LEVELS = (0.05, 0.01, 1e-3)


class CountingRender:
    """A ``render`` hook that counts its calls and their render seconds; ``timed_mean(spp,
    seed)`` returns the mean image and the seconds its render took (renders may be reused
    across the two ways and the levels: their seconds are counted each time)."""

    def __init__(self, timed_mean):
        self.timed_mean, self.calls, self.seconds = timed_mean, 0, 0.0

    def __call__(self, _scene, _integrator, _params, spp, seed, processes=None):
        mean, seconds = self.timed_mean(spp, seed)
        self.calls += 1
        self.seconds += seconds
        return mean, None


def reused(render_mean):
    """``timed_mean`` of ``render_mean(spp, seed)``, each (spp, seed) rendered once."""
    made = {}

    def timed_mean(spp, seed):
        if (spp, seed) not in made:
            start = time.perf_counter()
            made[spp, seed] = (render_mean(spp, seed), time.perf_counter() - start)
        return made[spp, seed]
    return timed_mean


def judge(timed_mean, reference, level: float) -> dict:
    """One run at one level both ways: passed, renders and seconds, and the early stop."""
    out = {}
    for way, early in (("one_look", False), ("two_looks", True)):
        render = CountingRender(timed_mean)
        law, _ = convergence_test("scene", "path", {}, reference, level, 1, render,
                                  LadderPlan(early_stop=early))
        out[way] = {"passed": bool(law.passed), "renders": render.calls,
                    "seconds": round(render.seconds, 4), "stopped_early": bool(law.stopped_early),
                    "floor": bool(law.floor_detected)}
    return out


def summary(runs, levels) -> dict:
    """Failures with exact 95 % intervals, early stops, median renders and seconds."""
    rows = {}
    for level in levels:
        row = {}
        for way in ("one_look", "two_looks"):
            records = [run[str(level)][way] for run in runs]
            failed = sum(not r["passed"] for r in records)
            row[way] = {"failed": failed, "rate": failed / len(records),
                        "ci95": clopper_pearson(failed, len(records)),
                        "stopped_early": sum(r["stopped_early"] for r in records),
                        "median_renders": float(np.median([r["renders"] for r in records])),
                        "median_seconds": float(np.median([r["seconds"] for r in records]))}
        rows[str(level)] = row
    return rows


def simulated(args) -> dict:
    """Every scenario on the simulated scene."""
    scene = make_scene(32, 32, seed=3, p_range=(0.1, 0.6))
    ref_mean, ref_var = (a[0] for a in render_stats(scene, 16384, 1, np.random.default_rng(99)))
    reference = SimpleNamespace(mean=ref_mean, var=ref_var, n=16384, metadata={})
    scenarios = {}
    for bias in args.biases:
        runs = []
        for run in range(args.runs):
            def render_mean(spp, seed, run=run, bias=bias):
                rng = np.random.default_rng([args.seed, run, seed])
                return render_means(scene, spp, 1, rng, scale=1.0 + bias)[0]
            timed_mean = reused(render_mean)
            runs.append({str(level): judge(timed_mean, reference, level) for level in LEVELS})
        scenarios[f"{bias:+g}"] = {"summary": summary(runs, LEVELS), "runs": runs}
        print(f"{bias:+g}", json.dumps(scenarios[f"{bias:+g}"]["summary"])[:400], flush=True)
    return {"model": "skewed simulated scene 32x32, reference 16384 spp", "scenarios": scenarios}


def real(args) -> dict:
    """Every scenario with our ``path`` on ``args.scene`` (one set of renders per run)."""
    params = default_params(args.scene)
    resolution = tuple(int(x) for x in args.resolution.split("x"))
    reference = get_reference(args.scene, params, "path", resolution=resolution)
    scenarios = {}
    for bias in args.biases:
        runs = []
        for run in range(args.runs):
            def render_mean(spp, seed, run=run, bias=bias):
                mean, _ = render_ours(args.scene, "path", params, spp, 7_000_000 * (run + 1) + seed,
                                      processes=1, resolution=resolution)
                return mean * (1.0 + bias)
            timed_mean = reused(render_mean)
            runs.append({str(level): judge(timed_mean, reference, level) for level in args.levels})
        scenarios[f"{bias:+g}"] = {"summary": summary(runs, args.levels), "runs": runs}
        print(f"{bias:+g}", json.dumps(scenarios[f"{bias:+g}"]["summary"])[:400], flush=True)
    return {"scene": args.scene, "resolution": args.resolution, "integrator": "path",
            "scenarios": scenarios}


def main(argv=None) -> None:
    """Run ``sim`` or ``real``; write the JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mode", choices=("sim", "real"))
    parser.add_argument("--runs", type=int, default=1000)
    parser.add_argument("--biases", type=lambda t: [float(x) for x in t.split(",")],
                        default=[0.0, 0.05, 0.1, 0.2])
    parser.add_argument("--levels", type=lambda t: [float(x) for x in t.split(",")],
                        default=[0.05], help="real: the levels judged (on the same renders)")
    parser.add_argument("--scene", default="cornell-box")
    parser.add_argument("--resolution", default="16x16")
    parser.add_argument("--seed", type=int, default=20261205)
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)
    start = time.perf_counter()
    data = simulated(args) if args.mode == "sim" else real(args)
    data.update(ladder=list(CONVERGENCE_LADDER), replicas=CONVERGENCE_REPLICAS, runs=args.runs,
                cpu=cpu_name(), seconds=round(time.perf_counter() - start, 1))
    path = Path(args.json or ROOT / "docs" / "data" / f"convergence_looks_{args.mode}.json")
    path.write_text(json.dumps(data, indent=1) + "\n")
    print(f"wrote {path} ({data['seconds']} s on {data['cpu']})")


if __name__ == "__main__":
    main()
