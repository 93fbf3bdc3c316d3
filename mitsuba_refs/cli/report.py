"""``mitsuba-refs report RESULTS.json... [--html DIR] [--junit FILE]``: the reports of results files.

Reads the files that ``--json`` wrote (with the images beside them) and writes the HTML
page and/or the JUnit XML of all their comparisons together. Exit status 0 when written,
2 for a missing or malformed results file or an unwritable output (one line on stderr),
130 when interrupted; whether the comparisons agreed is in the reports, not the status.
"""
from __future__ import annotations

from ..errors import RefsInputError
from ..report.outputs import check_output_options, write_reports

__all__ = ["add_report", "run_report"]


def add_report(subparsers):
    """Add the ``report`` subcommand to ``subparsers``; return its handler."""
    p = subparsers.add_parser(
        "report", help="HTML page and JUnit XML of results files written by --json",
        description="Read results files written by `mitsuba-refs compare --json` (schema "
                    "mitsuba-refs/results/1, with the EXR images beside them) and write a "
                    "self-contained HTML page (--html DIR: DIR/index.html, every image embedded) "
                    "and/or JUnit XML (--junit FILE) of all their comparisons. Exit code: 0 "
                    "written, 2 bad input (one line on stderr), 130 interrupted.")
    p.add_argument("results", nargs="+", metavar="RESULTS.json", help="results files (--json's)")
    p.add_argument("--html", metavar="DIR", default=None, help="write DIR/index.html")
    p.add_argument("--junit", metavar="FILE", default=None, help="write JUnit XML to FILE")
    return run_report


def run_report(args) -> int:
    """Handler of ``report``; input errors propagate to :func:`mitsuba_refs.cli.main.main`
    (one line, exit status 2)."""
    if not (args.html or args.junit):
        raise RefsInputError("nothing to write: give --html DIR and/or --junit FILE")
    check_output_options(args)
    from ..report.results import load_results  # the reader (and SciPy, of the verdicts) loads inside main
    records = [record for path in args.results for record in load_results(path)]
    for line in write_reports(records, junit=args.junit, html=args.html):
        print(line)
    agree = sum(bool(record["agree"]) for record in records)
    print(f"{len(records)} comparison{'s' if len(records) != 1 else ''} from {len(args.results)} "
          f"file{'s' if len(args.results) != 1 else ''}: {agree} agree, {len(records) - agree} disagree")
    return 0
