"""How often the autograder's hints name the right cause: the bug zoo and the hint mutants.

Every mutant of ``tests/bugzoo`` and ``tests/hint_mutants`` has one known mistake. Each is
graded (trusted, as the zoo's tests do) on the checks it is meant to break, and the hints of
every failed check are classified against the mutant's true cause:

``right``          a hint names the true cause (alone or among the alternatives it lists) and
                   no hint names only other causes;
``wrong``          some hint names causes, none of them the true one;
``evidence-only``  no hint names a cause: they state the evidence (which bounce, which
                   region or channel, by what ratio).

Hints carry the causes they name (:class:`mitsuba_refs.verdicts.explain.Hint`), so the classification
reads no prose. Usage::

    python -m autograder.hints.accuracy --out docs/data/hint_accuracy.json
    python -m autograder.hints.accuracy --reuse --out ...   # explain the recorded evidence again

The evidence of each graded check (sweep, probes, ratios) is kept in ``--cache`` (JSON and
``.npz`` at full precision, :func:`autograder.hints.evidence_io.dump`; data only, so a cache a
mutant could have written never runs code; not committed), so that ``--reuse`` measures
changed rules without rendering again.
"""
from __future__ import annotations

import argparse
import ast
import json
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from .. import grading
from ..isolation.process import Limits
from . import evidence_io
from .explain import explain

ROOT = Path(__file__).resolve().parents[2]
FOLDERS = (ROOT / "tests" / "bugzoo", ROOT / "tests" / "hint_mutants")
DEFAULT_CACHE = ROOT / "out" / "hint-evidence"
#: The true cause of each bug-zoo mutant (the hint mutants state theirs as ``CAUSE``).
ZOO_CAUSES = {
    "backface_normals": "backface_normals",
    "depth_cut": "depth_cut",
    "depth_off_by_one": "depth_off_by_one",
    "double_emission": "double_emission",
    "eta_inverted": "glass_eta",
    "extra_inv_pi": "diffuse_pi",
    "free_flight_density_at_surface": "free_flight_pdf",
    "light_choice_by_power": "light_choice_pdf",
    "light_choice_without_n": "light_choice_pdf",
    "light_importance_no_cos3": "camera_importance",
    "light_pdf_no_cosine": "light_pdf_cosine",
    "light_pdf_no_distance": "light_pdf_distance",
    "light_radiance_bsdf": "adjoint_bsdf",
    "light_splat_flipped_rows": "splat_pixel",
    "mirrored_camera": "camera_orientation",
    "mis_weights": "mis_weights",
    "missing_cosine": "bsdf_sampling_weight",
    "missing_pdf": "bsdf_sampling_weight",
    "no_emission_after_specular": "specular_emission",
    "no_first_hit_emission": "visible_emission",
    "null_boundary_keeps_medium": "null_boundary",
    "phase_pdf_not_cancelled": "phase_pdf",
    "pixel_centre_camera": "camera_film_sample",
    "reused_random_numbers": "random_reuse",
    "roulette_without_division": "roulette",
    "schlick_fresnel": "glass_fresnel",
    "shadow_no_transmittance": "shadow_transmittance",
    "shadow_self_intersection": "self_intersection",
    "two_sided_emitter": "one_sided_emitter",
    "uniform_hemisphere": "importance_sampling",
    "uniform_with_cosine_pdf": "bsdf_sampling_weight",
    "wrong_fov_axis": "camera_fov",
}


def constants(path) -> dict:
    """A mutant's literal module-level constants (BUG, CHECK(S), CAUSE), read without running it."""
    found = {}
    for node in ast.parse(Path(path).read_text()).body:
        if isinstance(node, ast.Assign) and len(node.targets) == 1 \
                and isinstance(node.targets[0], ast.Name) and node.targets[0].id.isupper():
            try:
                found[node.targets[0].id] = ast.literal_eval(node.value)
            except ValueError:
                pass
    return found


def cases(only=()) -> list:
    """(mutant, folder, path, check id, true cause) of every mutant and check to grade."""
    out = []
    for folder in FOLDERS:
        for path in sorted(folder.glob("[a-z]*.py")):
            c = constants(path)
            cause = c.get("CAUSE", ZOO_CAUSES.get(path.stem))
            if cause is None:
                raise SystemExit(f"{path}: no CAUSE and not in ZOO_CAUSES")
            for check in c.get("CHECKS", (c.get("CHECK"),)):
                if not only or path.stem in only:
                    out.append((path.stem, folder.name, str(path), check, cause))
    return out


def record(case, cache: Path, scale: float = 6.0) -> dict:
    """Grade one mutant on one check; keep its evidence in ``cache``; return the record."""
    name, folder, path, check_id, cause = case
    check = grading.CHECKS_BY_ID[check_id]
    limits = Limits(check.seconds * scale, grading.MEMORY_MB, grading.OUTPUT_BYTES)
    seen = []

    def keeping(evidence):
        """:func:`explain`, keeping the evidence run_check gives it (one per failed check)."""
        seen.append(evidence)
        return explain(evidence)
    result = grading.run_check(check, path, limits=limits, trusted=True, explain=keeping)
    entry = dict(mutant=name, folder=folder, check=check_id, cause=cause,
                 score=result.score, max_score=result.max_score,
                 failure=result.failure or "", seconds=round(result.seconds, 1))
    evidence_io.dump(seen[-1] if seen else None, cache, f"{name}--{check_id}", entry)
    return entry


def explained(cache: Path, name: str, check_id: str) -> tuple:
    """The recorded entry and the hints today's rules give on its evidence."""
    evidence, stored = evidence_io.load(cache, f"{name}--{check_id}")
    return stored, (explain(evidence) if evidence is not None else [])


def classify(found: list, cause: str) -> tuple:
    """(verdict, named causes) of a failed check's hints against its true cause."""
    named = [tuple(getattr(h, "causes", ("untagged",))) for h in found]
    if any(c == ("untagged",) for c in named):
        return "untagged", sorted({x for c in named for x in c})
    naming = [c for c in named if c]
    if not naming:
        return "evidence-only", []
    causes = sorted({x for c in naming for x in c})
    if any(cause not in c for c in naming):
        return "wrong", causes
    return "right", causes


def measure(entries: list, cache: Path) -> dict:
    """Verdicts of the recorded checks under today's rules, and their counts per folder."""
    rows = []
    for entry in entries:
        if not (cache / f"{entry['mutant']}--{entry['check']}.json").exists():
            continue                                    # not graded (yet)
        stored, found = explained(cache, entry["mutant"], entry["check"])
        if stored["score"] >= stored["max_score"] and not stored["failure"]:
            verdict, causes = "not detected", []
        else:
            verdict, causes = classify(found, stored["cause"])
        rows.append(dict(stored, verdict=verdict, named=causes, hints=[str(h) for h in found]))
    total = len(rows)
    summary = {}
    for folder in sorted({r["folder"] for r in rows}) + ["all"]:
        sub = [r for r in rows if folder in ("all", r["folder"])]
        summary[folder] = {v: sum(r["verdict"] == v for r in sub)
                           for v in ("right", "wrong", "evidence-only", "untagged", "not detected")}
        summary[folder]["checks"] = len(sub)
    return dict(summary=summary, checks=total, rows=rows)


def table(report: dict) -> str:
    """The Markdown table of docs/autograder.md (one row per mutant and check)."""
    lines = ["| mutant | check | score | verdict | causes named | hint (first, excerpt) |",
             "|---|---|---|---|---|---|"]
    for r in report["rows"]:
        first = r["hints"][0] if r["hints"] else ""
        first = (first[:110] + " ...") if len(first) > 110 else first
        lines.append(f"| {r['mutant']} | {r['check']} | {r['score']:g}/{r['max_score']:g} | "
                     f"{r['verdict']} ({r['cause']}) | {', '.join(r['named']) or '-'} | "
                     f"{first.replace('|', '/')} |")
    return "\n".join(lines)


def write_compact(rows, cache: Path, folder: Path) -> None:
    """The evidence of ``rows`` in compact form (:mod:`autograder.hints.evidence_io`), with the
    verdict it got; each is read back and must name the same causes as the full evidence (its
    numbers may differ in the last digit: the images are float16)."""
    for row in rows:
        name = f"{row['mutant']}--{row['check']}"
        evidence, _ = evidence_io.load(cache, name)
        evidence_io.write(evidence, folder, name, mutant=row["mutant"], cause=row["cause"],
                          verdict=row["verdict"])
        again, _ = evidence_io.read(folder, name)
        if classify(explain(again), row["cause"]) != (row["verdict"], row["named"]):
            raise SystemExit(f"{name}: the compact evidence names other causes than the full one")


def main(argv=None) -> int:
    """Grade (or re-explain) the mutants and write the report."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, help="JSON report")
    parser.add_argument("--cache", type=Path, default=DEFAULT_CACHE)
    parser.add_argument("--reuse", action="store_true", help="explain the recorded evidence again")
    parser.add_argument("--only", nargs="*", default=(), help="mutant names")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--table", action="store_true", help="print the Markdown table")
    parser.add_argument("--compact", type=Path,
                        help="also write the recorded evidence of --only in compact form here "
                             "(autograder.hints.evidence_io; what the tests re-explain)")
    args = parser.parse_args(argv)
    todo = cases(args.only)
    entries = [dict(mutant=n, folder=f, check=c, cause=k) for n, f, _, c, k in todo]
    if not args.reuse:
        with ThreadPoolExecutor(args.jobs) as pool:
            for entry in pool.map(lambda case: record(case, args.cache), todo):
                print(f"graded {entry['mutant']} on {entry['check']}: {entry['score']:g}/"
                      f"{entry['max_score']:g} ({entry['seconds']} s)", flush=True)
    report = measure(entries, args.cache)
    for r in report["rows"]:
        print(f"{r['verdict']:>14}  {r['mutant']} / {r['check']} ({r['cause']}): "
              f"{', '.join(r['named']) or '-'}")
    print(json.dumps(report["summary"]))
    if args.table:
        print(table(report))
    if args.out:
        args.out.write_text(json.dumps(report, indent=1) + "\n")
    if args.compact:
        write_compact(report["rows"], args.cache, args.compact)
    return 0


if __name__ == "__main__":
    sys.exit(main())
