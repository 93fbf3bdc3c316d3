"""How often does the grader take points from a correct submission? Measured.

Grades an implementation (default: the reference solution) again and again with every
render seed shifted, and reports

* the submissions that lost any point, with an exact (Clopper-Pearson) 95 % interval:
  the whole-submission false-failure rate, designed to be at most ``SUBMISSION_ALPHA``;
* every scored part's p-value: under a correct implementation they are uniform, so the
  counts below 0.05 and 0.01 and a Kolmogorov-Smirnov test against uniform check the
  calibration far more finely than the rare failures themselves.

    python -m autograder.calibrate --seeds 100 --out out/grading-calibration.json
    python -m autograder.calibrate --pool A.jsonl B.jsonl --out pooled.json

The second form grades nothing: it pools sweeps that graded different checks at the same
repetitions (e.g. a re-run of the checks that changed) into whole submissions.

A seed costs one graded submission (about 140 s of CPU for the path-tracing assignment).
Each finished seed is appended to ``OUT.jsonl`` at once; running the command again resumes
from there (``--fresh`` restarts). The sweep measures the statistics, not the machine:
``--time-scale`` multiplies every time limit, so that a sweep on a loaded machine does not
count a slow render as a lost point (the time limits' margin is measured apart,
docs/autograder.md "Time and memory").
"""
from __future__ import annotations

import argparse
import json
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from pathlib import Path

import numpy as np
from scipy import stats

from mitsuba_refs.stats import clopper_pearson

from . import grading

#: Seed shift between repetitions: far beyond any seed one grading uses.
SEED_STRIDE = 10_000_000


def part_p_values(result) -> dict:
    """{part: p-value} of one check's scored parts (absent where the test did not run)."""
    comparison = result.comparison
    if comparison is None:
        return {}
    found = {"mean": comparison.mean.p_value}
    if comparison.variance is not None:
        found["variance"] = comparison.variance.policy_p     # the scored one-sided policy
    if comparison.convergence is not None:
        found["convergence"] = comparison.convergence.p_value
    scored = {name for name, _ in result.check.parts}
    return {part: float(p) for part, p in found.items() if part in scored}


def seed_record(k: int, results: list, seconds: float) -> dict:
    """One repetition as a JSON line: did it lose points, its part p-values, its time."""
    lost = {r.check.id: r.max_score - r.score for r in results if r.score < r.max_score}
    return {
        "seed": k,
        "lost_points": bool(lost),
        "lost": lost,
        "p_values": {f"{r.check.id}/{part}": p
                     for r in results for part, p in part_p_values(r).items()},
        "seconds": round(seconds, 2),
    }


def summarise(records: list, part_alpha: float = grading.ALPHA) -> dict:
    """The report of :func:`main` from the :func:`seed_record` of every repetition, with the
    assignment's per-part level ``part_alpha``."""
    lost = sum(record["lost_points"] for record in records)
    p = np.array([v for record in records for v in record["p_values"].values()])
    low, high = clopper_pearson(lost, len(records))
    return {
        "submissions": len(records),
        "lost_points": lost,
        "false_failure_rate": lost / len(records),
        "false_failure_ci95": [low, high],
        "designed_rate": grading.SUBMISSION_ALPHA,
        "part_alpha": part_alpha,
        "part_p_values": len(p),
        "below_0.05": int((p <= 0.05).sum()),
        "below_0.01": int((p <= 0.01).sum()),
        "below_part_alpha": int((p <= part_alpha).sum()),
        "min_p": float(p.min()) if p.size else None,
        "ks_uniform_p": float(stats.kstest(p, "uniform").pvalue) if p.size else None,
        "seconds_per_submission": (float(np.median(seconds)) if (seconds := [
            r["seconds"] for r in records if r["seconds"] is not None]) else None),
    }


def read_records(path: Path, impl: str, checks: list) -> list:
    """Repetitions already logged in ``path`` for the same implementation and checks."""
    if not path.exists():
        return []
    records = []
    for line in path.read_text().splitlines():
        record = json.loads(line)
        if record.get("impl") == impl and record.get("checks") == checks:
            records.append(record)
    return records


def pool_records(logs, impl: str, check_ids: list) -> list:
    """Whole-submission records pooled from sweeps over parts of the checks.

    Render seeds depend only on the check and the repetition number, so the records of two
    sweeps at the same repetition ``k`` are the parts of one graded submission. Each log
    (``OUT.jsonl`` of earlier sweeps of ``impl``) contributes the checks it graded; a later log
    supersedes an earlier one for the checks both graded (e.g. after a check was changed).
    A repetition counts only where every check of ``check_ids`` was graded.
    """
    by_seed = {}
    for log in logs:
        for line in Path(log).read_text().splitlines():
            record = json.loads(line)
            if record.get("impl") != impl:
                continue
            merged = by_seed.setdefault(record["seed"], {})
            for check in record["checks"]:
                merged[check] = (record["lost"].get(check, 0.0),
                                 {key: p for key, p in record["p_values"].items()
                                  if key.split("/")[0] == check}, record["seconds"])
    pooled = []
    for seed, checks in sorted(by_seed.items()):
        if not set(check_ids) <= set(checks):
            continue
        lost = {c: checks[c][0] for c in check_ids if checks[c][0] > 0}
        pooled.append({"seed": seed, "lost_points": bool(lost), "lost": lost,
                       "p_values": {k: p for c in check_ids for k, p in checks[c][1].items()},
                       "seconds": None, "impl": impl, "checks": check_ids})
    return pooled


def main(argv=None) -> int:
    """Grade the implementation ``--seeds`` times and report how often it lost points; exit code."""
    parser = argparse.ArgumentParser(prog="python -m autograder.calibrate", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--impl", default="autograder.solution", help="implementation to grade")
    parser.add_argument("--solution-runtime", action="store_true",
                        help="the implementation builds on the reference solution (correct "
                             "alternatives in tests/alternatives)")
    parser.add_argument("--seeds", type=int, default=40, help="repetitions (default: %(default)s)")
    parser.add_argument("--first-seed", type=int, default=1,
                        help="number of the first repetition (default: %(default)s): sweeps with "
                             "disjoint ranges can be pooled")
    parser.add_argument("--assignment", choices=list(grading.ASSIGNMENTS),
                        default=grading.DEFAULT_ASSIGNMENT,
                        help="the assignment graded (default: %(default)s)")
    parser.add_argument("--checks", nargs="+", choices=sorted(grading.CHECKS_BY_ID),
                        help="grade only these checks of the assignment (default: all)")
    parser.add_argument("--workers", type=int, default=1, help="submissions graded at once")
    parser.add_argument("--time-scale", type=float, default=grading.TIME_SCALE,
                        help="multiply every time limit (default: AUTOGRADER_TIME_SCALE or 1)")
    parser.add_argument("--out", type=Path, default=Path("out/grading-calibration.json"))
    parser.add_argument("--fresh", action="store_true",
                        help="ignore the repetitions already logged beside --out")
    parser.add_argument("--pool", nargs="+", type=Path, metavar="LOG",
                        help="grade nothing: pool the OUT.jsonl logs of earlier sweeps (each over "
                             "some of the checks, at the same repetitions) into whole submissions")
    args = parser.parse_args(argv)
    if args.seeds < 1 or args.workers < 1 or args.first_seed < 1 or not args.time_scale > 0:
        parser.error("--seeds, --first-seed and --workers must be >= 1, --time-scale > 0")
    checks = grading.checks_of(args.assignment)
    if args.checks:
        others = sorted(set(args.checks) - {c.id for c in checks})
        if others:
            parser.error(f"--checks {' '.join(others)}: not in the assignment {args.assignment}")
        checks = [grading.CHECKS_BY_ID[c] for c in args.checks]
    check_ids = [c.id for c in checks]
    part_alpha = grading.alpha_of(checks[0])
    if args.pool:
        missing = [str(log) for log in args.pool if not log.is_file()]
        if missing:
            parser.error(f"--pool: no such log: {', '.join(missing)}")
        records = pool_records(args.pool, args.impl, check_ids)
        if not records:
            parser.error("--pool: no repetition of these logs covers every check")
        return _report(summarise(records, part_alpha), args, check_ids, part_alpha)

    # Every finished repetition is appended at once, so a long sweep can be stopped and resumed.
    log_path = args.out.with_suffix(".jsonl")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    if args.fresh:
        log_path.unlink(missing_ok=True)
    records = read_records(log_path, args.impl, check_ids)
    done = {record["seed"] for record in records}
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    todo = [k for k in seeds if k not in done]
    print(f"{len(done)} repetitions already in {log_path}; grading {len(todo)} more", flush=True)

    def grade_one(k):
        started = time.perf_counter()
        results = grading.grade(args.impl, checks, seed_offset=SEED_STRIDE * k,
                                trusted=args.solution_runtime, time_scale=args.time_scale)
        return seed_record(k, results, time.perf_counter() - started)

    with ThreadPoolExecutor(args.workers) as pool, log_path.open("a") as log:
        for future in as_completed([pool.submit(grade_one, k) for k in todo]):
            record = dict(future.result(), impl=args.impl, checks=check_ids)
            log.write(json.dumps(record) + "\n")
            log.flush()
            records.append(record)
            lost = sum(r["lost_points"] for r in records)
            print(f"seed {record['seed']}: {record['seconds']:.0f} s, "
                  f"{'lost ' + str(record['lost']) if record['lost_points'] else 'full marks'}; "
                  f"{lost}/{len(records)} lost so far", flush=True)

    return _report(summarise([r for r in records if r["seed"] in seeds], part_alpha), args,
                   check_ids, part_alpha)


def _report(report: dict, args, check_ids: list, part_alpha: float) -> int:
    report.update(impl=args.impl, checks=check_ids)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(report, indent=2))
    low, high = report["false_failure_ci95"]
    print(f"{report['lost_points']}/{report['submissions']} correct submissions lost points "
          f"(95 % CI [{low:.1%}, {high:.1%}]; designed <= {grading.SUBMISSION_ALPHA:g})")
    print(f"{report['part_p_values']} part p-values: {report['below_0.05']} <= 0.05, "
          f"{report['below_0.01']} <= 0.01, {report['below_part_alpha']} <= the part level "
          f"{part_alpha:.2g}, min {report['min_p']:.2g}, "
          f"KS vs uniform p = {report['ks_uniform_p']:.2f}")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
