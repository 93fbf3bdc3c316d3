"""Results as one self-contained static HTML page: ``out_dir/index.html``.

No server, no network: the styles and the one script are inline, every image is a PNG
``data:`` URI (:mod:`.figures`) drawn from the EXR images the records name, and a
Content-Security-Policy forbids loading anything else. Per comparison: test and reference
at the same exposure, the tile z-map with the significant tiles outlined, the relative
difference, the variance ratio map (when compared), the convergence plot (when run), the
verdict table with p-values and intervals, the likely causes, notes and a summary of the
renders. With several comparisons a summary table (scene x renderer, one column per
verdict) comes first and links to each.

The inline script sets ``document.body.dataset.imagesLoaded`` to ``"N/M"`` (images that
loaded, of all) once the page has loaded, and ``dataset.errors`` to the messages of any
script error (empty when none): a headless browser reads both from the DOM.
"""
from __future__ import annotations

import html
import math
import re
from collections import defaultdict
from pathlib import Path

from pathtracer.io.exr import read_mean_variance
from pathtracer.io.output import atomic_path

from ..errors import one_line
from . import figures
from .encoding import to_array, to_float
from .results import record_path
from .text import interval_text, picture_lines, run_summary, suite_name
from .verdicts import VERDICTS
from .wording import format_p, percent

__all__ = ["write_html", "page"]

#: Nothing but inline styles and scripts and data: images (the page fetches nothing).
CONTENT_POLICY = "default-src 'none'; img-src data:; style-src 'unsafe-inline'; script-src 'unsafe-inline'"

STYLE = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 1.5em; color: #222;
       background: #fff; max-width: 1400px; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; margin-top: 2em; border-top: 1px solid #ccc; padding-top: 1em; }
h3 { font-size: 1em; margin-bottom: 0.3em; }
table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.5em; text-align: left; vertical-align: top; }
th { background: #f3f3f3; }
.agree { color: #17692a; font-weight: 600; } .disagree { color: #b0161b; font-weight: 600; }
.inconclusive { color: #8a5a00; font-weight: 600; }
.not-compared { color: #777; }
.figures { display: flex; flex-wrap: wrap; gap: 1em; align-items: flex-start; }
figure { margin: 0; } figcaption { font-size: 0.8em; color: #444; max-width: 360px; }
img.render { width: 256px; image-rendering: pixelated; border: 1px solid #ccc; }
img.plot { max-width: 380px; }
.meta, .missing { font-size: 0.9em; color: #444; } .missing { color: #b0161b; }
code { font-size: 0.9em; }
"""

#: Records script errors from the start; counts the loaded images once everything has loaded.
SCRIPT = """
(function () {
  var errors = [];
  function show() { if (document.body) { document.body.dataset.errors = errors.join(" | "); } }
  window.onerror = function (message, source, line) {
    errors.push(String(message) + " (line " + line + ")");
    show();
  };
  window.addEventListener("load", function () {
    var images = Array.prototype.slice.call(document.images);
    var loaded = images.filter(function (image) { return image.complete && image.naturalWidth > 0; });
    document.body.dataset.imagesLoaded = loaded.length + "/" + images.length;
    show();
  });
})();
"""


def _e(text) -> str:
    return html.escape(str(text), quote=True)


def _status_cell(entry: dict | None, with_p: bool = True) -> str:
    if entry is None:
        return '<td class="not-compared">–</td>'
    status = entry.get("status", "")
    css = status.replace(" ", "-")
    p = f" (p={format_p(entry.get('p_value'))})" if with_p and status != "not compared" else ""
    return f'<td class="{css}">{_e(status)}{_e(p)}</td>'


def anchors(records: list) -> list[str]:
    """One unique ``id`` per record: ``c<number>-<scene>-<integrator>``."""
    return [f"c{number}-" + re.sub(r"[^A-Za-z0-9_-]+", "-", f"{Path(str(r['scene'])).stem}-{r['integrator']}")
            for number, r in enumerate(records, start=1)]


def _overall(record: dict) -> str:
    """agree, disagree or inconclusive (records without ``outcome`` predate the tolerance)."""
    outcome = record.get("outcome") or ("AGREES" if record["agree"] else "DISAGREES")
    return {"AGREES": "agree", "DISAGREES": "disagree"}.get(outcome, "inconclusive")


def summary_table(records: list, ids: list) -> str:
    """The scene x renderer table, one column per verdict, each row linking to its section."""
    head = "".join(f"<th>{name}</th>" for name in VERDICTS)
    rows = []
    for record, anchor in zip(records, ids):
        overall = _overall(record)
        shown = f"{overall} (weak)" if record.get("weak") else overall
        cells = "".join(_status_cell(record["verdicts"].get(name)) for name in VERDICTS)
        rows.append(f'<tr><td><a href="#{anchor}">{_e(record["scene"])}</a></td><td>{_e(record["renderer"])}</td>'
                    f'<td>{_e(record["spp"])}</td><td class="{overall}">{shown}</td>{cells}</tr>')
    return ("<table class=\"summary\"><tr><th>scene</th><th>renderer</th><th>spp</th><th>overall</th>"
            f"{head}</tr>\n" + "\n".join(rows) + "\n</table>")


def _load_images(record: dict):
    """``({"test": (mean, variance), "reference": ...}, None)``, or ``(None, why not)``."""
    images = record.get("images")
    if not images:
        return None, "no images: the comparison was written without them"
    loaded = {}
    for side in ("test", "reference"):
        path = record_path(record, images.get(side, ""))
        if not path.is_file():
            return None, f"{path}: no such file (the images are saved beside the results file)"
        try:
            mean, variance, _ = read_mean_variance(path)
        except (OSError, ValueError, RuntimeError) as error:
            return None, f"{path}: cannot be read ({one_line(error)})"
        loaded[side] = (mean, variance)
    return loaded, None


def _figure(uri: str, caption: str, css: str) -> str:
    return (f'<figure><img class="{css}" src="{uri}" alt="{_e(caption)}">'
            f"<figcaption>{_e(caption)}</figcaption></figure>")


def record_figures(record: dict) -> tuple[list[str], str | None]:
    """The ``<figure>`` elements of one record, and why the images are missing (or None)."""
    verdicts = record["verdicts"]
    mean = verdicts["mean"]
    images, missing = _load_images(record)
    out = []
    if images is not None:
        test, reference = images["test"][0], images["reference"][0]
        scale = figures.reference_exposure(reference)
        exposure = f"exposure ×{scale:.3g}: the reference's 99th-percentile luminance is white"
        out.append(_figure(figures.image_uri(test, scale), f"test: {record['renderer']} ({exposure})", "render"))
        out.append(_figure(figures.image_uri(reference, scale),
                           f"reference: Mitsuba {record['reference'].get('integrator', '')} (same exposure)",
                           "render"))
    cells = [(int(tile[0]), int(tile[1])) for tile in mean.get("significant_tiles") or []]
    critical = mean.get("critical_z")
    out.append(_figure(figures.zmap_uri(to_array(mean["z_tiles"]), cells, int(mean["tile"]),
                                        None if critical is None else to_float(critical)),
                       f"tile z-map: red test brighter, blue darker; {mean['n_significant']} significant tiles",
                       "plot"))
    if images is not None:
        out.append(_figure(figures.relative_difference_uri(test, reference),
                           "relative difference test/reference − 1 (luminance, per pixel)", "plot"))
    variance = verdicts.get("variance") or {}
    if variance.get("compared"):
        out.append(_figure(figures.variance_ratio_uri(to_array(variance["tile_log_ratio"]), int(variance["tile"])),
                           f"variance ratio per tile: {interval_text('variance', variance)}", "plot"))
    convergence = verdicts.get("convergence") or {}
    if convergence.get("compared") and convergence.get("mse_mean"):
        out.append(_figure(figures.convergence_uri(
            convergence["ladder"], to_array(convergence["mse_mean"]), to_array(convergence.get("mse_se")),
            to_float(convergence["slope"]),
            tuple(to_float(v) for v in convergence["slope_ci"])),
            f"convergence: {interval_text('convergence', convergence)}", "plot"))
    return out, missing


def verdict_table(record: dict) -> str:
    """Verdict, result, p-value (alpha), interval and the verdict line, one row per verdict."""
    rows = []
    for name in VERDICTS:
        entry = record["verdicts"].get(name)
        if entry is None:
            continue
        alpha = entry.get("alpha")
        p = "–" if entry.get("p_value") is None else (
            f"{format_p(entry['p_value'])}" + (f" (α = {to_float(alpha):g})" if alpha is not None else ""))
        rows.append(f"<tr><td>{name}</td>{_status_cell(entry, with_p=False)}<td>{_e(p)}</td>"
                    f"<td>{_e(interval_text(name, entry))}</td><td>{_e(entry.get('line', ''))}</td></tr>")
    return ("<table class=\"verdicts\"><tr><th>verdict</th><th>result</th><th>p-value</th>"
            "<th>interval</th><th>line</th></tr>\n" + "\n".join(rows) + "\n</table>")


def _list(title: str, items: list) -> str:
    if not items:
        return ""
    entries = "".join(f"<li>{_e(item)}</li>" for item in items)
    return f"<h3>{_e(title)}</h3><ul>{entries}</ul>"


def runs_table(record: dict) -> str:
    """The renders by purpose: how many, their sample counts and seconds."""
    groups = defaultdict(list)
    for run in record.get("runs") or []:
        if isinstance(run, dict):
            groups[str(run.get("purpose", "render"))].append(run)
    if not groups:
        return ""
    rows = []
    for purpose, runs in groups.items():
        seconds = [s for s in (to_float(run.get("seconds")) for run in runs) if math.isfinite(s)]
        spp = sorted({run.get("spp") for run in runs if run.get("spp") is not None},
                     key=lambda n: (not isinstance(n, (int, float)), n if isinstance(n, (int, float)) else str(n)))
        timing = (f"<td>{sum(seconds):.2f}</td><td>{sum(seconds) / len(seconds):.3f}</td>" if seconds
                  else "<td>–</td><td>–</td>")
        rows.append(f"<tr><td>{_e(purpose)}</td><td>{len(runs)}</td><td>{_e(', '.join(map(str, spp)))}</td>"
                    f"{timing}</tr>")
    return ("<table class=\"runs\"><tr><th>purpose</th><th>renders</th><th>spp</th><th>seconds</th>"
            "<th>per render</th></tr>" + "".join(rows) + "</table>")


def record_section(record: dict, anchor: str) -> str:
    """The section of one comparison."""
    overall = _overall(record)
    word = f"{overall.upper()}S with Mitsuba" if overall != "inconclusive" else "INCONCLUSIVE with Mitsuba"
    if record.get("tolerance_percent") is not None:
        tolerance = f"\u00b1{to_float(record['tolerance_percent']):g}%"
        word += f" within {tolerance}" if overall == "agree" else f" (tolerance {tolerance})"
    bound = record["verdicts"].get("mean", {}).get("detectable_bias") or {}
    if record.get("weak") and bound:
        word += f", weakly (could not see less than {percent(to_float(bound['bias']))})"
    reference = record.get("reference") or {}
    size = (f"{reference.get('width')}x{reference.get('height')}" if reference.get("width") else "size unknown")
    command = f" ({record['command']})" if record.get("command") else ""
    meta = (f"renderer: {record['renderer']}{command}; {record['spp']} spp; "
            f"rendered: {record.get('rendered') or '–'}; "
            f"reference: Mitsuba {reference.get('integrator') or '–'}, {size}, key "
            f"{str(reference.get('key') or '–')[:16]}; results file: {record.get('source', '–')}")
    shown, missing = record_figures(record)
    parts = [f'<section id="{anchor}">',
             f'<h2>{_e(record["integrator"])} on {_e(record["scene"])}: <span class="{overall}">{word}</span></h2>',
             f'<p class="meta">{_e(meta)}</p>']
    if missing:
        parts.append(f'<p class="missing">images not shown: {_e(missing)}</p>')
    parts.append('<div class="figures">' + "".join(shown) + "</div>")
    parts.append(verdict_table(record))
    parts.append(_list("Likely cause" + ("s" if len(record.get("hints") or []) > 1 else ""),
                       record.get("hints") or []))
    parts.append(_list("Notes", record.get("notes") or []))
    parts.append(f"<h3>Runs</h3><p>{_e(run_summary(record))}</p>" + runs_table(record))
    parts.append(_list("Diagnostic pictures (files)", picture_lines(record)))
    parts.append("</section>")
    return "\n".join(part for part in parts if part)


def page(records: list) -> str:
    """The whole HTML document of ``records``."""
    ids = anchors(records)
    agree = sum(bool(record["agree"]) for record in records)
    title = suite_name(records[0]) if len(records) == 1 else f"{len(records)} comparisons"
    body = [f"<h1>mitsuba-refs report: {_e(title)}</h1>",
            f"<p class=\"meta\">{agree} of {len(records)} comparisons agree with Mitsuba 3.</p>"]
    if len(records) > 1:
        body.append(summary_table(records, ids))
    body += [record_section(record, anchor) for record, anchor in zip(records, ids)]
    return ("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
            f"<meta http-equiv=\"Content-Security-Policy\" content=\"{CONTENT_POLICY}\">\n"
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
            f"<title>mitsuba-refs report: {_e(title)}</title>\n<style>{STYLE}</style>\n"
            f"<script>{SCRIPT}</script>\n</head>\n<body>\n" + "\n".join(body) + "\n</body>\n</html>\n")


def write_html(records: list, out_dir) -> Path:
    """Write ``out_dir/index.html`` (the folder is created; the file written atomically)."""
    folder = Path(out_dir)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "index.html"
    text = page(records)
    with atomic_path(path) as temporary:
        temporary.write_text(text, encoding="utf-8")
    return path
