"""Samples and seconds to a decision on the users' scenes: today's fixed-budget compare against
``--tolerance`` rounds, file by file, back to back (issue 42's measurement).

    python -m experiments.sequential_coverage DIR --resume COVERAGE.json --files LIST
        --work FOLDER [--repeat N] [--tolerance 2] [--max-spp 256] --out RAW.json
    python -m experiments.sequential_coverage --table RAW.json

``LIST`` holds one file of ``DIR`` a line (a path relative to ``DIR``, as the coverage run's
JSON names it). For each repetition and each file, four compares run one after the other,
each as ``python -m experiments.scene_coverage DIR --compare --compare-only FILE --resume ...``
(the coverage run's own command, so its classes are kept and nothing is loaded again):
``today`` (fixed 64 spp, convergence test included), ``rounds`` (``--tolerance T --max-spp
N``), and both again with ``--no-convergence``. ``COVERAGE.json`` is an earlier coverage run
whose compare records were removed (otherwise ``--resume`` keeps them and compares nothing).
Every compare record goes into ``RAW.json``; ``--table`` prints the Markdown table of
docs/statistics.md section 9 from it (median seconds over the repetitions).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys

from mitsuba_refs.report.wording import max_spp_to_give

from .bench import cpu_name

#: The four compares of a file: name -> scene_coverage options (fixed 64 spp is compare's default).
PASSES = {"today": [], "rounds": ["ROUNDS"], "today-nc": ["--no-convergence"],
          "rounds-nc": ["--no-convergence", "ROUNDS"]}


def pass_options(name: str, tolerance: float, max_spp: int) -> list[str]:
    """scene_coverage's options for the compare ``name`` of :data:`PASSES`."""
    rounds = ["--tolerance", str(tolerance), "--max-spp", str(max_spp)]
    return [part for option in PASSES[name] for part in (rounds if option == "ROUNDS" else [option])]


def run_pass(folder: str, file: str, name: str, repetition: int, args) -> dict:
    """One compare of ``file`` in repetition ``repetition`` through scene_coverage; its
    compare record."""
    state = os.path.join(args.work, f"{repetition}-{name}.json")
    command = [sys.executable, "-m", "experiments.scene_coverage", folder, "--no-mitsuba",
               "--quiet", "--compare", "--compare-only", file,
               "--resume", state if os.path.exists(state) else args.resume, "--json", state + ".new",
               "--compare-timeout", str(args.compare_timeout),
               *pass_options(name, args.tolerance, args.max_spp)]
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    os.replace(state + ".new", state)
    return record_of(state, file)


def record_of(state: str, file: str) -> dict:
    """The compare record of ``file`` in a coverage run's JSON ``state``."""
    with open(state) as f:
        return next(entry["compare"] for entry in json.load(f)["files"] if entry["file"] == file)


def measure(args) -> dict:
    """Every repetition's four compares of every file, written to ``args.out`` as they come."""
    with open(args.files) as f:
        files = [line.split()[0] for line in f if line.strip()]
    os.makedirs(args.work, exist_ok=True)
    raw = {"folder": args.folder, "tolerance": args.tolerance, "max_spp": args.max_spp,
           "cpu": args.cpu or cpu_name(), "runs": []}
    for repetition in range(1, args.repeat + 1):
        for file in files:
            for name in PASSES:
                record = run_pass(args.folder, file, name, repetition, args)
                raw["runs"].append({"repetition": repetition, "file": file, "pass": name,
                                    "record": record})
                print(f"{repetition} {name} {file}: {record['verdict']} {record.get('spp')} spp "
                      f"{record['seconds']} s", file=sys.stderr, flush=True)
                with open(args.out, "w") as f:
                    json.dump(raw, f, indent=1)
    return raw


def outcome(record: dict) -> str:
    """The record's verdict, with the spp where the rounds stopped."""
    if record.get("tolerance") is None:
        return record["verdict"]
    return f"{record['verdict']} at {record.get('spp')}"


def median_seconds(records: list[dict], key=lambda record: record["seconds"]) -> float:
    """The median over the repetitions of ``key`` (the whole compare's seconds by default)."""
    return statistics.median(key(record) for record in records)


def mean_seconds(record: dict) -> float:
    """The seconds of the test side's mean-and-variance renders (every round's)."""
    return record.get("render_seconds", {}).get("mean", 0.0)


def by_file(raw: dict) -> dict:
    """file -> pass -> the records of the repetitions, in the order of the run (files with
    all four compares)."""
    table: dict = {}
    for run in raw["runs"]:
        table.setdefault(run["file"], {}).setdefault(run["pass"], []).append(run["record"])
    # A run still going (or stopped) may hold a file without all its compares: left out.
    return {file: passes for file, passes in table.items() if set(passes) == set(PASSES)}


def undecided_note(file: str, record: dict) -> str:
    """What a compare left INCONCLUSIVE says would decide (compare's own verdict line)."""
    low, high = (100 * x for x in record.get("interval") or (float("nan"),) * 2)
    if record.get("reference_limited"):
        cure = "the reference's own noise keeps it undecided: a longer reference would decide"
    elif record.get("spp_needed"):
        cure = f"about --max-spp {max_spp_to_give(record['spp_needed'])} would decide"
    else:
        cure = "the observed bias sits at the tolerance"
    return f"- {os.path.basename(file)}: interval [{low:+.2f} %, {high:+.2f} %] at {record['spp']} spp; {cure}"


def table(raw: dict) -> str:
    """Per file: each compare's outcome and median seconds; then the decided counts, the
    median ratio of seconds (rounds / today) with and without the convergence test, where
    the seconds go, and what would decide the undecided files."""
    files = by_file(raw)
    lines = ["| file | integrator | today: outcome, s | rounds: outcome at spp, s | "
             "today, no conv.: outcome, s | rounds, no conv.: outcome at spp, s |",
             "|---|---|---|---|---|---|"]
    for file, passes in files.items():
        cells = [f"{' / '.join(sorted({outcome(r) for r in passes[name]}))}, "
                 f"{median_seconds(passes[name]):.1f}" for name in PASSES]
        lines.append(f"| {os.path.basename(file)} | {passes['today'][0]['integrator']} | "
                     + " | ".join(cells) + " |")
    lines.append("")
    for suffix, label in (("", "with convergence"), ("-nc", "without convergence")):
        decided = sum(all(r["verdict"] in ("agrees", "disagrees") for r in p["rounds" + suffix])
                      for p in files.values())
        ratios = [median_seconds(p["rounds" + suffix]) / median_seconds(p["today" + suffix])
                  for p in files.values()]
        today = statistics.median(median_seconds(p["today" + suffix]) for p in files.values())
        rounds = statistics.median(median_seconds(p["rounds" + suffix]) for p in files.values())
        lines.append(f"- {label}: rounds decided {decided} of {len(files)} files; median "
                     f"seconds today {today:.1f}, rounds {rounds:.1f} (ratio of medians "
                     f"{rounds / today:.2f}); median per-file ratio {statistics.median(ratios):.2f}")
    lines += ["", "Median render seconds by purpose (the rest: start, scene, reference, verdicts):"]
    for name in PASSES:
        purposes = sorted({k for p in files.values() for r in p[name]
                           for k in r.get("render_seconds", {})})
        records = [r for p in files.values() for r in p[name]]
        parts = [f"{purpose} {median_seconds(records, lambda r: r.get('render_seconds', {}).get(purpose, 0.0)):.1f}"
                 for purpose in purposes]
        lines.append(f"- {name}: whole compare {median_seconds(records):.1f}; " + ", ".join(parts))
    mean_render = [median_seconds(p["rounds-nc"], mean_seconds) / median_seconds(p["today-nc"], mean_seconds)
                   for p in files.values()]
    lines.append(f"- the mean's own renders, rounds / today (no conv.): median per-file ratio "
                 f"{statistics.median(mean_render):.2f}")
    # The rounds' renders have fixed seeds: with or without the convergence test, in every
    # repetition, the mean sees the same images (checked here, not assumed).
    same = all(len({(r["verdict"], r.get("spp")) for name in ("rounds", "rounds-nc")
                    for r in p[name]}) == 1 for p in files.values())
    lines += ["", f"Rounds' outcome and spp the same in every repetition, with and without "
                  f"convergence: {'yes' if same else 'no'}. Undecided (last repetition):"]
    lines += [undecided_note(file, passes["rounds-nc"][-1]) for file, passes in files.items()
              if passes["rounds-nc"][-1]["verdict"] == "inconclusive"]
    return "\n".join(lines)


def build_parser() -> argparse.ArgumentParser:
    """The command line of the script."""
    p = argparse.ArgumentParser(prog="python -m experiments.sequential_coverage",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("folder", metavar="DIR", nargs="?", help="the coverage run's folder")
    p.add_argument("--table", metavar="RAW", help="print the table of an earlier run's RAW.json")
    p.add_argument("--resume", help="coverage run JSON without compare records")
    p.add_argument("--files", help="the files to compare, one a line (relative to DIR)")
    p.add_argument("--work", help="folder of the four coverage JSONs of each repetition")
    p.add_argument("--out", help="the raw runs' JSON")
    p.add_argument("--repeat", type=int, default=1, help="repetitions (default 1)")
    p.add_argument("--tolerance", type=float, default=2.0, help="--tolerance (default 2)")
    p.add_argument("--max-spp", type=int, default=256, help="--max-spp (default 256)")
    p.add_argument("--compare-timeout", type=float, default=900.0, help="seconds per compare")
    p.add_argument("--cpu", default="", help="the CPU, recorded in RAW.json (default: this "
                   "machine's)")
    return p


def main(argv=None) -> int:
    """Measure (or ``--table``: tabulate an earlier run); 2 when a path to measure is missing."""
    args = build_parser().parse_args(argv)
    if args.table:
        with open(args.table) as f:
            print(table(json.load(f)))
        return 0
    missing = [name for name in ("folder", "resume", "files", "work", "out") if not getattr(args, name)]
    if missing:
        print(f"error: measuring needs {', '.join(missing)} (or --table RAW)", file=sys.stderr)
        return 2
    print(table(measure(args)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
