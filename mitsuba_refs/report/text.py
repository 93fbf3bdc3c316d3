"""The short texts the reports print: p-values, intervals, a record's name and its pictures, and
the lines of a comparison (``Comparison.report()``) with what both sides rendered."""
from __future__ import annotations

import math

from .encoding import to_float
from .results import record_path
from .wording import convergence_verdict, mean_line, percent, status_text, variance_verdict

__all__ = ["interval_text", "detectable_text", "suite_name", "picture_lines", "closing_lines",
           "run_summary", "comparison_report", "rendered_settings"]


def _pair(values, as_percent: bool = False, digits: int = 3) -> str:
    low, high = (to_float(v) for v in values)
    if as_percent:
        return f"[{percent(low, signed=True, minus='-')}, {percent(high, signed=True, minus='-')}]"
    return f"[{low:.{digits}f}, {high:.{digits}f}]"


def interval_text(name: str, entry: dict) -> str:
    """The interval(s) of a verdict entry in words ("" when it has none)."""
    if entry.get("status") == "not compared":
        return ""
    if name == "mean":
        level = to_float(entry.get("ci_level", 0.95))
        text = (f"relative bias {percent(to_float(entry['rel_bias']), signed=True, minus='-')} "
                f"{_pair(entry['rel_bias_ci'], as_percent=True)} ({100 * level:.0f}% CI)")
        return text + detectable_text(entry.get("detectable_bias"))
    if name == "variance":
        return f"variance ratio {to_float(entry['ratio']):.3f} {_pair(entry['ratio_ci'])}"
    if name == "convergence":
        # The RMSE's exponent, half the recorded MSE slope (report.wording.rmse_rate).
        half = [to_float(v) / 2 for v in entry["slope_ci"]]
        return (f"RMSE as N^{to_float(entry['slope']) / 2:.3f} {_pair(half)}; "
                f"RMSE(N)/RMSE(4N) {to_float(entry['ratio']):.2f} {_pair(entry['ratio_ci'], digits=2)}")
    if name == "bounces":
        depth = entry.get("first_diverging_depth")
        return "every depth agrees" if depth is None else f"first diverging max_depth = {depth}"
    return ""


def detectable_text(bound) -> str:
    """``"; detects ±2.4% (95%)"``: what a mean entry's test could see ("" when not recorded)."""
    if not isinstance(bound, dict):
        return ""
    bias = to_float(bound.get("bias"))
    if not math.isfinite(bias):
        return "; detects no global bias (black reference)"
    weak = " (weak)" if bound.get("weak") else ""
    return f"; detects ±{100 * bias:.1f}% ({100 * to_float(bound.get('power', 0.95)):.0f}%){weak}"


def suite_name(record: dict) -> str:
    """``<scene>::<renderer>``: the name of a record in JUnit and in the summary table."""
    return f"{record['scene']}::{record['renderer']}"


def picture_lines(record: dict) -> list[str]:
    """``picture (name): path`` per diagnostic picture, each path as it is from here."""
    return [f"picture ({name}): {record_path(record, path)}"
            for name, path in (record.get("pictures") or {}).items()]


def run_summary(record: dict) -> str:
    """How many renders, their total and per-run seconds, and the comparison's seconds."""
    runs = [run for run in record.get("runs") or [] if isinstance(run, dict)]
    seconds = [to_float(run.get("seconds")) for run in runs]
    seconds = [s for s in seconds if math.isfinite(s)]
    total = to_float(record.get("seconds"))
    text = f"{len(runs)} render{'s' if len(runs) != 1 else ''}"
    if seconds:
        text += (f", {sum(seconds):.1f} s rendering (per run {min(seconds):.2f}–{max(seconds):.2f} s, "
                 f"mean {sum(seconds) / len(seconds):.2f} s)")
    cpu = record.get("cpu_seconds")
    if cpu is not None:
        text += f", {to_float(cpu):.1f} CPU-s"
    if math.isfinite(total):
        text += f"; the whole comparison {total:.1f} s"
    return text


def comparison_report(result) -> str:
    """A few lines a student can read: the text of a
    :class:`~mitsuba_refs.verdicts.compare.Comparison` (its ``report()``)."""
    lines = [f"{result.integrator} on {result.scene} ({result.spp} spp): {status_text(result)}",
             f"  mean:        {mean_line(result)}"]
    if result.rendered:
        lines.insert(1, f"  rendered:    {result.rendered}")
    if result.variance is not None:
        lines.append(f"  variance:    {variance_verdict(result.variance)}")
    elif result.variance_skipped or not result.compares_variance:
        lines.append(f"  variance:    {result.variance_not_applicable()}")
    else:
        lines.append("  variance:    not compared (both images are noiseless)")
    if result.convergence is not None:
        lines.append(f"  convergence: {convergence_verdict(result.convergence)}")
    if result.bounce is not None:
        lines.append(f"  bounces:     {result.bounce[1]}")
    lines += closing_lines(result.hints, result.pictures, result.seconds, result.notes)
    return "\n".join(lines)


def closing_lines(hints, pictures: dict, seconds: float, notes=()) -> list[str]:
    """The last lines of a verdict text, comparison's and grader's alike: the likely causes,
    the notes, the diagnostic pictures and the seconds it took."""
    return ([f"  likely cause: {hint}" for hint in hints]
            + [f"  note:        {note}" for note in notes]
            + [f"  picture ({name}): {path}" for name, path in pictures.items()]
            + [f"  ({seconds:.1f} s)"])


def rendered_settings(metadata: dict) -> str:
    """What both sides rendered, from the reference's metadata: film size and light transport
    (Mitsuba's defaults, which are also ours, where the file and the overrides set nothing)."""
    nested = metadata.get("mitsuba_integrator", {})
    transport = {"max_depth": -1, "rr_depth": 5, "hide_emitters": False}
    transport.update({k: v for k, v in nested.items() if k in transport})
    if nested.get("type") == "direct":
        transport = {k: v for k, v in transport.items() if k == "hide_emitters"}
    text = ", ".join(f"{k}={str(v).lower() if isinstance(v, bool) else v}"
                     for k, v in transport.items())
    return f"{metadata.get('width')}x{metadata.get('height')} on both sides; {text}"
