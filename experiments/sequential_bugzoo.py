"""Samples and seconds to a decision on the bug zoo: today's fixed budget against the rounds.

Every mutant of tests/bugzoo whose check is ``<integrator>-cornell-box`` is compared with
Mitsuba on cornell-box (64x64, the committed references) twice: today's fixed-budget test at
``--spp`` (equal means, alpha 1e-3), and ``--tolerance`` with ``--max-spp`` = that spp (the
rounds: 1/16 of it, doubling). Only the mean verdict runs (no convergence, no bounces).

    python -m experiments.sequential_bugzoo --spp 64 --tolerance 2

Writes docs/data/sequential_bugzoo.json.
"""
from __future__ import annotations

import argparse
import importlib
import json
import sys
import time
from pathlib import Path

import numpy as np

from mitsuba_refs.verdicts.compare import compare

from .bench import cpu_name

ROOT = Path(__file__).resolve().parent.parent
ZOO = ROOT / "tests" / "bugzoo"


def cornell_mutants():
    """(name, integrator instance) of every mutant checked on cornell-box."""
    sys.path.insert(0, str(ZOO))
    found = []
    for path in sorted(ZOO.glob("[a-z]*.py")):
        module = importlib.import_module(path.stem)
        check = getattr(module, "CHECK", "")
        if not check.endswith("-cornell-box"):
            continue
        integrator = check.split("-cornell-box")[0]
        found.append((path.stem, integrator, module.INTEGRATORS[integrator]()))
    return found


def judge(integrator, settings):
    """One comparison's outcome, the mean render's spp (all rounds) and its seconds."""
    start = time.perf_counter()
    result = compare("cornell-box", integrator, convergence=False, bounces=False, processes=1,
                     **settings)
    spp = sum(run.get("spp", 0) for run in result.runs if run.get("purpose") == "mean")
    return {"outcome": result.outcome, "spp": int(spp or result.spp),
            "seconds": round(time.perf_counter() - start, 2),
            "rel_bias": float(getattr(result.mean, "rel_bias", float("nan")))}


def main():
    """Compare every cornell-box mutant both ways; write the JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument("--tolerance", type=float, default=2.0)
    parser.add_argument("--alpha", type=float, default=1e-3)
    parser.add_argument("--json", default=str(ROOT / "docs" / "data" / "sequential_bugzoo.json"))
    args = parser.parse_args()
    rows = []
    for name, integrator_name, integrator in cornell_mutants():
        today = judge(integrator, {"spp": args.spp, "alpha": args.alpha})
        rounds = judge(integrator, {"spp": args.spp, "alpha": args.alpha,
                                    "tolerance": args.tolerance})
        rows.append({"mutant": name, "integrator": integrator_name, "today": today,
                     "rounds": rounds})
        print(json.dumps(rows[-1]), flush=True)
    caught = [r for r in rows if r["today"]["outcome"] == "DISAGREES"]
    summary = {
        "mutants": len(rows), "today_detects": len(caught),
        "rounds_disagrees": sum(r["rounds"]["outcome"] == "DISAGREES" for r in rows),
        "median_spp_ratio_caught": float(np.median([r["rounds"]["spp"] / r["today"]["spp"]
                                                    for r in caught])) if caught else None,
        "median_seconds_ratio_caught": float(np.median([r["rounds"]["seconds"] / r["today"]["seconds"]
                                                        for r in caught])) if caught else None}
    data = {"spp": args.spp, "tolerance_percent": args.tolerance, "alpha": args.alpha,
            "cpu": cpu_name(), "summary": summary, "mutants": rows}
    Path(args.json).write_text(json.dumps(data, indent=1) + "\n")
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
