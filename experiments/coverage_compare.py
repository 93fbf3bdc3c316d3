"""One ``mitsuba-refs compare`` of the coverage run (``experiments/scene_coverage.py --compare``)
and its record: verdict, outcome, the spp and rounds of the mean's decision, seconds.

The compare is run as a process (here, or on a Dask worker) with ``--json`` into a temporary
folder; the record takes what the verdict lines do not say plainly from that file (the spp of
the last look, the number of rounds, what stopped them, the spp an undecided mean would need).
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

#: compare's exit codes (mitsuba_refs.cli.compare), as the record's verdict.
VERDICTS = {0: "agrees", 1: "disagrees", 2: "refused", 3: "inconclusive"}
#: The options of the rounds (``--tolerance``), in the order they are given to compare.
ROUND_OPTIONS = (("tolerance", "--tolerance"), ("max_spp", "--max-spp"),
                 ("max_seconds", "--max-seconds"))


def compare_command(path: str, integrator: str, resolution: str, convergence: bool,
                    rounds: dict | None = None) -> list[str]:
    """The command line of ``mitsuba-refs compare`` on ``path``: ``rounds`` (``tolerance``,
    ``max_spp``, ``max_seconds``; None values left out) adds the options of the rounds."""
    exe = shutil.which("mitsuba-refs")
    command = ([exe] if exe else [sys.executable, "-m", "mitsuba_refs.cli.main"]) + [
        "compare", path, "--integrator", integrator, "--resolution", resolution]
    command += [] if convergence else ["--no-convergence"]
    for key, option in ROUND_OPTIONS:
        if (rounds or {}).get(key) is not None:
            command += [option, str(rounds[key])]
    return command


def decision_of(results_json: str) -> dict:
    """From compare's ``--json`` file: ``outcome``, ``spp`` (of the mean render, with rounds the
    last look's), ``rounds`` (looks judged; 1 without ``--tolerance``), ``stopped_by``,
    ``interval`` (the last look's of the relative bias; None without ``--tolerance``),
    ``spp_needed`` (undecided: the spp that would decide, None if none would),
    ``reference_limited`` (undecided for the reference's own noise), ``reference_pieces``,
    ``render_seconds`` (:func:`render_seconds`) and the status of each verdict. Empty when
    the file is missing or unreadable (a refused scene writes none)."""
    try:
        with open(results_json) as f:
            record = json.load(f)["results"][0]
    except (OSError, ValueError, KeyError, IndexError):
        return {}
    verdicts = record.get("verdicts", {})
    rounds = (verdicts.get("mean") or {}).get("rounds") or {}
    looks = rounds.get("looks") or []
    return {"outcome": record.get("outcome"),
            "spp": looks[-1]["spp"] if looks else record.get("spp"),
            "rounds": len(looks) if looks else 1,
            "stopped_by": rounds.get("stopped_by"),
            "interval": rounds.get("interval"),
            "spp_needed": rounds.get("spp_needed"),
            "reference_limited": rounds.get("reference_limited", False),
            "reference_pieces": rounds.get("reference_pieces", 1),
            "render_seconds": render_seconds(record.get("runs") or []),
            "statuses": {name: (entry or {}).get("status") for name, entry in verdicts.items()
                         if name != "bounces"}}


def render_seconds(runs: list) -> dict:
    """Seconds of the test side's renders by purpose (the mean-and-variance renders, the
    convergence ladder, ...), from compare's ``runs``: where a compare's time goes beside
    the fixed cost of starting, loading the scene and reading the reference."""
    by_purpose: dict[str, float] = {}
    for run in runs:
        if isinstance(run, dict) and isinstance(run.get("seconds"), (int, float)):
            purpose = str(run.get("purpose", "other"))
            by_purpose[purpose] = round(by_purpose.get(purpose, 0.0) + run["seconds"], 2)
    return by_purpose


def summary_line(text: str) -> str:
    """The verdict line of compare's output (the one naming Mitsuba), else its last line."""
    lines = text.strip().splitlines()
    return next((line for line in lines if "Mitsuba" in line and "on " in line),
                lines[-1] if lines else "").strip()


def compare_file(path: str, integrator: str, resolution: str, convergence: bool,
                 timeout: float, rounds: dict | None = None) -> dict:
    """The record of ``mitsuba-refs compare`` on ``path`` (run as a process here, or on a
    cluster's worker): ``verdict`` (by exit code; 3 is ``inconclusive``), its ``summary``
    line, ``integrator``, ``convergence``, ``tolerance`` and ``max_spp`` (None without
    ``rounds``), what :func:`decision_of` reads from compare's JSON, and ``seconds``."""
    rounds = rounds or {}
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="coverage-compare-") as folder:
        results_json = os.path.join(folder, "results.json")
        command = compare_command(path, integrator, resolution, convergence, rounds)
        command += ["--json", results_json, "--out", os.path.join(folder, "pictures")]
        try:
            out = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
            verdict = VERDICTS.get(out.returncode, f"exit code {out.returncode}")
            summary = summary_line(out.stdout + out.stderr)
        except subprocess.TimeoutExpired:
            verdict, summary = "timed out", f"no verdict within {timeout:g} s"
        decision = decision_of(results_json)
    return {"verdict": verdict, "summary": summary, "integrator": integrator,
            "convergence": convergence, "tolerance": rounds.get("tolerance"),
            "max_spp": rounds.get("max_spp"), **decision,
            "seconds": round(time.perf_counter() - start, 1)}
