"""``--json FILE``, ``--junit FILE`` and ``--html DIR`` of the commands that compare.

A command adds the options with :func:`add_output_options`, refuses unwritable paths with
:func:`check_output_options` before it renders anything, and writes what was asked with
:func:`write_outputs` once it has its comparisons. ``--html`` without ``--json`` also
writes ``DIR/results.json`` and the images beside it, so that the folder holds everything
``mitsuba-refs report`` needs to draw the page again.
"""
from __future__ import annotations

from pathlib import Path

from ..errors import RefsInputError
from ..preflight import check_output_file, check_output_folder

__all__ = ["add_output_options", "check_output_options", "write_outputs", "write_reports"]


def add_output_options(parser):
    """Add ``--json``, ``--junit`` and ``--html`` to an argparse ``parser``; return their group."""
    group = parser.add_argument_group("machine-readable results and reports")
    group.add_argument("--json", metavar="FILE", default=None,
                       help="write the results (schema mitsuba-refs/results/1: every verdict with its "
                            "p-value and intervals, hints, runs) and, beside FILE, the test and reference "
                            "images as EXR")
    group.add_argument("--junit", metavar="FILE", default=None,
                       help="write JUnit XML: one test case per verdict (<scene>::<renderer>::mean ...), "
                            "a failure for each disagreeing verdict")
    group.add_argument("--html", metavar="DIR", default=None,
                       help="write DIR/index.html, a self-contained page (images embedded); without "
                            "--json also DIR/results.json and its images")
    return group


def check_output_options(args) -> None:
    """Refuse, in one line, an output path of :func:`add_output_options` that cannot be written."""
    json_file, junit_file = getattr(args, "json", None), getattr(args, "junit", None)
    html_dir = getattr(args, "html", None)
    if json_file:
        check_output_file(json_file, "--json")
    if junit_file:
        check_output_file(junit_file, "--junit")
    if html_dir:
        check_output_folder(html_dir, "--html")
    if json_file and junit_file and Path(json_file).resolve() == Path(junit_file).resolve():
        raise RefsInputError(f"--json and --junit name the same file, {json_file}")


def write_reports(records: list, junit=None, html=None) -> list[str]:
    """Write the JUnit XML and the HTML page of ``records``; the lines saying what was written."""
    from .html import write_html  # the writers and their pictures load when there is one to write
    from .junit import write_junit
    lines = []
    if junit:
        path = write_junit(records, junit)
        failed = sum(entry.get("status") in ("disagree", "inconclusive") for record in records
                     for entry in record["verdicts"].values())
        lines.append(f"junit: {path} ({len(records)} comparison{'s' if len(records) != 1 else ''}, "
                     f"{failed} failed verdict{'s' if failed != 1 else ''})")
    if html:
        lines.append(f"report: {write_html(records, html)}")
    return lines


def write_outputs(args, results: list, *, alpha: float | None = None, budget: dict | None = None) -> list[str]:
    """Write what ``args.json``, ``args.junit`` and ``args.html`` ask for, of ``results``.

    Parameters
    ----------
    args : argparse.Namespace
        With the attributes of :func:`add_output_options` (a missing one counts as not given).
    results : list of Comparison
    alpha, budget
        Stored in the results file (:func:`mitsuba_refs.report.results.write_json`).

    Returns
    -------
    list of str
        One line per file written (none when no option was given).
    """
    json_file, junit_file = getattr(args, "json", None), getattr(args, "junit", None)
    html_dir = getattr(args, "html", None)
    if not (json_file or junit_file or html_dir):
        return []
    from .results import comparison_record, write_json  # the writers load when there is one to write
    lines = []
    if json_file or html_dir:
        json_path = Path(json_file) if json_file else Path(html_dir) / "results.json"
        records = write_json(results, json_path, alpha=alpha, budget=budget)
        images = sum(2 for record in records if record.get("images"))
        lines.append(f"results: {json_path} ({len(records)} comparison{'s' if len(records) != 1 else ''}, "
                     f"{images} EXR images beside it)")
    else:
        records = [comparison_record(result, None) for result in results]
    return lines + write_reports(records, junit=junit_file, html=html_dir)
