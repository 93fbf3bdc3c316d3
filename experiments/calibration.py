"""Calibration of the verdicts on real renders: how often a correct tracer is rejected.

Renders the correct integrator with many independent seeds, applies the mean,
variance and convergence tests at a nominal alpha, and reports the rejection
rates with exact (Clopper-Pearson) 95 % intervals. A calibrated test rejects
at about alpha. Writes JSON next to the printed table.

    python -m experiments.calibration --scene cornell-box --integrator path --seeds 40
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from mitsuba_refs.reference.cache import get_reference
from mitsuba_refs.stats import clopper_pearson, compare_means, compare_variances
from mitsuba_refs.verdicts.convergence import CONVERGENCE_REPLICAS, check_convergence
from mitsuba_refs.verdicts.estimators import SAME_ESTIMATOR, reference_integrator
from mitsuba_refs.verdicts.scenes import default_params, render_ours
from pathtracer.core.progress import Progress


def main(argv=None) -> int:
    """Measure the verdicts' false-rejection rates on real renders (command line); exit code."""
    parser = argparse.ArgumentParser(prog="python -m experiments.calibration", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scene", default="cornell-box")
    parser.add_argument("--integrator", default="path")
    parser.add_argument("--seeds", type=int, default=40, help="independent repetitions")
    parser.add_argument("--spp", type=int, default=8, help="spp of the mean/variance renders")
    parser.add_argument("--alpha", type=float, default=0.05, help="nominal level")
    parser.add_argument("--ladder", default="1,4,16", help="convergence spp ladder")
    parser.add_argument("--no-convergence", action="store_true")
    parser.add_argument("--out", default="out/calibration", help="folder for the JSON")
    args = parser.parse_args(argv)

    params = default_params(args.scene)
    reference = get_reference(args.scene, params, reference_integrator(args.integrator))
    ladder = tuple(int(v) for v in args.ladder.split(","))
    counts = {"mean": 0, "variance": 0, "convergence": 0}
    progress = Progress(args.seeds, "calibration", "seeds")
    for k in range(args.seeds):
        mean, var = render_ours(args.scene, args.integrator, params, args.spp, 70_000 + k)
        counts["mean"] += not compare_means(mean, var, args.spp, reference.mean, reference.var,
                                            reference.n, alpha=args.alpha).agree
        if args.integrator in SAME_ESTIMATOR:
            counts["variance"] += not compare_variances(var, args.spp, reference.var, reference.n,
                                                        alpha=args.alpha).agree
        if not args.no_convergence:
            seeded = _seed_offset(render_ours, 1_000_000 * (k + 1))
            law, _ = check_convergence(args.scene, args.integrator, params, alpha=args.alpha,
                                       ladder=ladder, replicas=CONVERGENCE_REPLICAS, render=seeded)
            counts["convergence"] += not law.passed
        progress.advance()
    progress.close()
    report = {"scene": args.scene, "integrator": args.integrator, "seeds": args.seeds,
              "spp": args.spp, "alpha": args.alpha, "ladder": ladder, "rejections": {}}
    print(f"{args.integrator} on {args.scene}, {args.seeds} seeds, nominal alpha {args.alpha}")
    for test, k in counts.items():
        if test == "variance" and args.integrator not in SAME_ESTIMATOR:
            continue
        if test == "convergence" and args.no_convergence:
            continue
        low, high = clopper_pearson(k, args.seeds)
        report["rejections"][test] = {"count": k, "rate": k / args.seeds, "ci95": [low, high]}
        print(f"  {test:12s} {k:4d}/{args.seeds} = {k / args.seeds:6.1%}  95% CI [{low:.1%}, {high:.1%}]")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"calibration-{args.scene}-{args.integrator}.json"
    path.write_text(json.dumps(report, indent=2))
    print(f"wrote {path}")
    return 0


def _seed_offset(render, offset):
    """A render function whose seeds are shifted, so every repetition is independent."""
    def shifted(scene, integrator, params, spp, seed, **kwargs):
        return render(scene, integrator, params, spp, seed + offset, **kwargs)
    return shifted


if __name__ == "__main__":
    raise SystemExit(main())
