"""Results as JUnit XML, the test report format GitLab, Jenkins and GitHub's test views read.

One ``<testsuite>`` per comparison, named ``<scene>::<renderer>``, and in it one
``<testcase>`` per verdict, named ``<scene>::<renderer>::<verdict>`` (mean, variance,
convergence, bounces). A disagreeing verdict has a ``<failure>`` (message: the verdict
line; text: the line, p-value and interval, likely causes, pictures, notes; type
``disagree``, or ``inconclusive`` for a mean the budget left undecided), a verdict
that was not compared ``<skipped>`` with the reason. Elements and attributes are those of
Jenkins' schema (junit-10.xsd of the xUnit plugin), which the others read too:
``testsuites`` (name, tests, failures, errors, time), ``testsuite`` (name, tests,
failures, errors, skipped, time; ``properties`` first), ``testcase`` (name, classname,
time), ``property`` (name, value), ``failure`` and ``skipped`` (message, type). Times are
seconds: a verdict's renders (the records' ``runs`` by ``purpose``), the rest of the
comparison's time on the mean.
"""
from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

from pathtracer.io.output import atomic_path

from .encoding import to_float
from .text import interval_text, picture_lines, suite_name
from .verdicts import VERDICTS
from .wording import format_p

__all__ = ["write_junit", "junit_tree"]

#: Characters XML 1.0 cannot hold, even escaped (control characters other than tab and newlines).
#: Entry statuses that are a ``<failure>`` (its ``type``): a disagreement, and a mean that the
#: budget left undecided (``--tolerance``; exit status 3).
FAILING = ("disagree", "inconclusive")
_NOT_XML = re.compile("[^\t\n\r\u0020-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")


def _clean(text) -> str:
    """``text`` with the characters XML 1.0 forbids replaced by U+FFFD (ElementTree escapes
    ``<``, ``&`` and quotes itself, but writes a control character as it is)."""
    return _NOT_XML.sub("\ufffd", str(text))


def _seconds(value) -> str:
    seconds = to_float(value)
    return f"{max(seconds, 0.0) if math.isfinite(seconds) else 0.0:.3f}"


def verdict_seconds(record: dict) -> dict:
    """Seconds per verdict: the renders whose ``purpose`` names it (convergence, bounces),
    the rest of the comparison (the mean render, statistics, the reference) on the mean;
    the variance comes from the mean's render."""
    spent = {name: 0.0 for name in VERDICTS}
    for run in record.get("runs") or []:
        if isinstance(run, dict) and run.get("purpose") in ("convergence", "bounces"):
            seconds = to_float(run.get("seconds"))
            spent[run["purpose"]] += seconds if math.isfinite(seconds) else 0.0
    total = to_float(record.get("seconds"))
    total = total if math.isfinite(total) else sum(spent.values())
    spent["mean"] = max(total - spent["convergence"] - spent["bounces"], 0.0)
    return spent


def _bias(mean: dict) -> str:
    """The mean test's detectable global bias (a fraction), "" when not recorded."""
    bound = mean.get("detectable_bias") if isinstance(mean, dict) else None
    return "" if not isinstance(bound, dict) else str(bound.get("bias"))


def _failure_text(record: dict, name: str, entry: dict) -> str:
    alpha = entry.get("alpha")
    level = f" (alpha {to_float(alpha):g})" if alpha is not None else ""
    lines = [f"{name}: {entry.get('line', '')}", f"p-value {format_p(entry.get('p_value'))}{level}"]
    interval = interval_text(name, entry)
    if interval:
        lines.append(interval)
    lines += [f"likely cause: {hint}" for hint in record.get("hints") or []]
    lines += picture_lines(record)
    lines += [f"note: {note}" for note in record.get("notes") or []]
    return "\n".join(lines)


def _suite(record: dict) -> ET.Element:
    name = _clean(suite_name(record))
    verdicts = record["verdicts"]
    entries = [(verdict, verdicts[verdict]) for verdict in VERDICTS if verdict in verdicts]
    failures = sum(entry.get("status") in FAILING for _, entry in entries)
    skipped = sum(entry.get("status") == "not compared" for _, entry in entries)
    times = verdict_seconds(record)
    suite = ET.Element("testsuite", {
        "name": name, "tests": str(len(entries)), "failures": str(failures), "errors": "0",
        "skipped": str(skipped), "time": _seconds(sum(times[verdict] for verdict, _ in entries))})
    properties = ET.SubElement(suite, "properties")
    reference = record.get("reference") or {}
    for key, value in (("scene", record["scene"]), ("renderer", record["renderer"]),
                       ("integrator", record["integrator"]), ("spp", record["spp"]),
                       ("rendered", record.get("rendered", "")),
                       ("mean.detectable_bias", _bias(verdicts.get("mean", {}))),
                       ("weak", str(bool(record.get("weak"))).lower()),
                       ("outcome", record.get("outcome") or ("AGREES" if record["agree"] else "DISAGREES")),
                       ("tolerance_percent", "" if record.get("tolerance_percent") is None
                        else f"{to_float(record['tolerance_percent']):g}"),
                       ("reference.key", reference.get("key", "")),
                       ("reference.integrator", reference.get("integrator", "")),
                       ("results", record.get("source", ""))):
        ET.SubElement(properties, "property", {"name": key, "value": _clean(value)})
    for verdict, entry in entries:
        case = ET.SubElement(suite, "testcase", {"name": f"{name}::{verdict}", "classname": name,
                                                 "time": _seconds(times[verdict])})
        if entry.get("status") in FAILING:     # an undecided mean fails CI, as its exit status 3
            failure = ET.SubElement(case, "failure", {"message": _clean(entry.get("line", "")),
                                                      "type": entry["status"]})
            failure.text = _clean(_failure_text(record, verdict, entry))
        elif entry.get("status") == "not compared":
            ET.SubElement(case, "skipped", {"message": _clean(entry.get("reason", "not compared"))})
    return suite


def junit_tree(records: list) -> ET.ElementTree:
    """The ``<testsuites>`` document of ``records`` (dicts of schema ``mitsuba-refs/result/1``)."""
    suites = [_suite(record) for record in records]
    root = ET.Element("testsuites", {"name": "mitsuba-refs"})
    for attribute in ("tests", "failures", "errors"):   # junit-10.xsd's testsuites has no "skipped"
        root.set(attribute, str(sum(int(suite.get(attribute)) for suite in suites)))
    root.set("time", f"{sum(float(suite.get('time')) for suite in suites):.3f}")
    root.extend(suites)
    tree = ET.ElementTree(root)
    ET.indent(tree)
    return tree


def write_junit(records: list, path) -> Path:
    """Write ``records`` as JUnit XML to ``path`` (UTF-8, atomically); return the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tree = junit_tree(records)
    with atomic_path(path) as temporary:
        tree.write(temporary, encoding="utf-8", xml_declaration=True)
    return path
