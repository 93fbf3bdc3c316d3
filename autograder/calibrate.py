"""How often does the grader take points from a correct submission?

Grades an implementation (default: the reference solution) again and again with every
render seed shifted, and reports

* the submissions that lost any point, with an exact (Clopper-Pearson) 95 % interval:
  the whole-submission false-failure rate, designed to be at most ``SUBMISSION_ALPHA``;
* every scored part's p-value: under a correct implementation they are uniform, so the
  counts below 0.05 and 0.01 and a Kolmogorov-Smirnov test against uniform check the
  calibration far more finely than the rare failures themselves.

    python -m autograder.calibrate --seeds 40 --workers 2 --out out/grading-calibration.json

A seed costs one graded submission (about 24 s on one core).
"""
from __future__ import annotations

import argparse
import json
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
from scipy import stats

from experiments.calibration import clopper_pearson

from . import grading
from .isolation import start_fork_server

#: Seed shift between repetitions: far beyond any seed one grading uses.
SEED_STRIDE = 10_000_000


def part_p_values(result) -> dict:
    """{part: p-value} of one check's scored parts (absent where the test did not run)."""
    comparison = result.comparison
    if comparison is None:
        return {}
    found = {"mean": comparison.mean.p_value}
    if comparison.variance is not None:
        found["variance"] = comparison.variance.p_value
    if comparison.convergence is not None:
        found["convergence"] = comparison.convergence.p_value
    scored = {name for name, _ in result.check.parts}
    return {part: float(p) for part, p in found.items() if part in scored}


def summarise(submissions: list) -> dict:
    """The report of :func:`main` from one list of CheckResults per repetition."""
    lost = sum(any(r.score < r.max_score for r in results) for results in submissions)
    p_values = [p for results in submissions for r in results for p in part_p_values(r).values()]
    p = np.array(p_values)
    low, high = clopper_pearson(lost, len(submissions))
    return {
        "submissions": len(submissions),
        "lost_points": lost,
        "false_failure_rate": lost / len(submissions),
        "false_failure_ci95": [low, high],
        "designed_rate": grading.SUBMISSION_ALPHA,
        "part_p_values": len(p),
        "below_0.05": int((p <= 0.05).sum()),
        "below_0.01": int((p <= 0.01).sum()),
        "min_p": float(p.min()) if p.size else None,
        "ks_uniform_p": float(stats.kstest(p, "uniform").pvalue) if p.size else None,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m autograder.calibrate", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--impl", default="autograder.solution", help="implementation to grade")
    parser.add_argument("--seeds", type=int, default=40, help="repetitions (default: %(default)s)")
    parser.add_argument("--checks", nargs="+", choices=sorted(grading.CHECKS_BY_ID),
                        help="grade only these checks (default: all)")
    parser.add_argument("--workers", type=int, default=1, help="submissions graded at once")
    parser.add_argument("--out", type=Path, default=Path("out/grading-calibration.json"))
    args = parser.parse_args(argv)
    if args.seeds < 1 or args.workers < 1:
        parser.error("--seeds and --workers must be >= 1")
    checks = [grading.CHECKS_BY_ID[c] for c in args.checks] if args.checks else grading.CHECKS

    start_fork_server()
    with ThreadPoolExecutor(args.workers) as pool:
        submissions = list(pool.map(
            lambda k: grading.grade(args.impl, checks, seed_offset=SEED_STRIDE * k),
            range(1, args.seeds + 1)))
    report = summarise(submissions)
    report.update(impl=args.impl, checks=[c.id for c in checks])
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(report, indent=2))
    low, high = report["false_failure_ci95"]
    print(f"{report['lost_points']}/{report['submissions']} correct submissions lost points "
          f"(95 % CI [{low:.1%}, {high:.1%}]; designed <= {grading.SUBMISSION_ALPHA:g})")
    print(f"{report['part_p_values']} part p-values: {report['below_0.05']} <= 0.05, "
          f"{report['below_0.01']} <= 0.01, min {report['min_p']:.2g}, "
          f"KS vs uniform p = {report['ks_uniform_p']:.2f}")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
