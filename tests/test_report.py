"""Machine-readable results and the reports (mitsuba_refs.report), from real comparisons.

Two comparisons of the Cornell box at 64 spp with a short convergence ladder, against the
committed references (no Mitsuba needed): the correct ``path`` and the same render 5 %
too bright (mean and variance disagree, the bounces are localised). Their verdicts are
not what is tested here: every assertion compares a report with the Comparison it came
from, so none is a statistical assertion of the suite's budget (tests/budget.py).
"""
from __future__ import annotations

import argparse
import base64
import contextlib
import dataclasses
import io
import json
import math
import re
import xml.etree.ElementTree as ET
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from mitsuba_refs.cli.main import main
from mitsuba_refs.report import encoding
from mitsuba_refs.report.html import write_html
from mitsuba_refs.report.junit import write_junit
from mitsuba_refs.report.outputs import write_outputs
from mitsuba_refs.report.results import RESULTS_SCHEMA, SCHEMA, comparison_record, load_results, write_json
from mitsuba_refs.report.wording import mean_line, mean_region, percent, verdict_line
from mitsuba_refs.verdicts.compare import compare
from mitsuba_refs.verdicts.scenes import render_ours
from pathtracer.io.exr import read_mean_variance

SETTINGS = {"spp": 64, "convergence": True, "ladder": (1, 4, 16), "replicas": 2, "processes": 1}
BRIGHTER = 1.05


def render_too_bright(*args, **kwargs):
    """Our correct render, 5 % too bright (its per-sample variance scaled to match)."""
    mean, variance = render_ours(*args, **kwargs)
    return mean * BRIGHTER, variance * BRIGHTER ** 2


@pytest.fixture(scope="module")
def agreeing():
    return compare("cornell-box", "path", **SETTINGS)


@pytest.fixture(scope="module")
def disagreeing(tmp_path_factory):
    return compare("cornell-box", "path", render=render_too_bright,
                   out_dir=tmp_path_factory.mktemp("pictures"), **SETTINGS)


@pytest.fixture(scope="module")
def written(agreeing, disagreeing, tmp_path_factory):
    """Both comparisons in one results file: (path, the records write_json returned)."""
    path = tmp_path_factory.mktemp("results") / "results.json"
    return path, write_json([agreeing, disagreeing], path)


# ----------------------------------------------------------------------------------
# JSON records


def test_record_holds_the_comparisons_values(agreeing, tmp_path):
    record = comparison_record(agreeing, tmp_path)
    json.dumps(record, allow_nan=False)                       # strict JSON as it is
    assert record["schema"] == SCHEMA
    for key in ("scene", "renderer", "integrator", "spp", "agree", "rendered"):
        assert record[key] == getattr(agreeing, key)
    assert record["params"] == agreeing.params
    assert record["reference"] == {"key": agreeing.reference_key, "integrator": "path",
                                   "width": 64, "height": 64}
    assert record["alpha"] == agreeing.mean.alpha
    mean = record["verdicts"]["mean"]
    assert mean["status"] == ("agree" if agreeing.mean.agree else "disagree")
    assert mean["p_value"] == agreeing.mean.p_value and mean["line"] == mean_line(agreeing)
    assert mean["line"].startswith(verdict_line(agreeing.mean))
    assert mean["detectable_bias"]["bias"] == agreeing.detectable.bias
    assert mean["rel_bias"] == agreeing.mean.rel_bias
    assert mean["rel_bias_ci"] == list(agreeing.mean.rel_bias_ci)
    assert mean["component_p_values"] == agreeing.mean.scale_p_values
    assert mean["n_significant"] == agreeing.mean.n_significant
    assert np.array_equal(encoding.to_array(mean["z_tiles"]), agreeing.mean.z_tiles)
    variance = record["verdicts"]["variance"]
    assert variance["applicable"] and variance["compared"]
    assert variance["ratio"] == agreeing.variance.ratio
    assert variance["ratio_ci"] == list(agreeing.variance.ratio_ci)
    assert variance["p_value"] == agreeing.variance.p_value
    convergence = record["verdicts"]["convergence"]
    law = agreeing.convergence
    assert (convergence["slope"], convergence["slope_ci"]) == (law.slope, list(law.slope_ci))
    assert (convergence["ratio"], convergence["p_value"]) == (law.ratio, law.p_value)
    assert convergence["ladder"] == [1, 4, 16]
    assert convergence["mse_mean"] == pytest.approx([level.mean() for level in agreeing.convergence_mse])
    assert record["verdicts"]["bounces"]["status"] == ("not compared" if agreeing.mean.agree else "disagree")
    assert record["hints"] == agreeing.hints and record["notes"] == agreeing.notes
    assert record["renders"] == len(agreeing.runs) == len(record["runs"])
    assert {run["purpose"] for run in record["runs"]} == {"mean", "convergence"}
    assert record["render_seconds"] == pytest.approx(sum(run["seconds"] for run in agreeing.runs))
    assert record["seconds"] == agreeing.seconds and record["cpu_seconds"] is None


def test_record_saves_the_images_it_was_judged_on(agreeing, tmp_path):
    record = comparison_record(agreeing, tmp_path)
    assert record["images"] == {"test": "cornell-box-path-test.exr",
                                "reference": "cornell-box-path-reference.exr"}
    for side in ("test", "reference"):
        mean, variance, header = read_mean_variance(tmp_path / record["images"][side])
        assert header["role"] == side
        expected = agreeing.arrays[f"{side}_mean"], agreeing.arrays[f"{side}_variance"]
        assert np.array_equal(mean, np.float32(expected[0]))
        assert np.array_equal(variance, np.float32(expected[1]))


def test_record_without_a_folder_writes_no_images(agreeing):
    record = comparison_record(agreeing, None)
    assert record["images"] is None


def test_record_of_an_external_renderer_without_images(agreeing, tmp_path):
    # what `check` gives: runs of a command with their CPU time, notes, no arrays kept
    runs = [{"seed": seed, "spp": 64, "seconds": 2.0, "cpu_seconds": 3.5, "command": "./smallpt --seed",
             "exit_code": 0} for seed in (1, 2)]
    external = dataclasses.replace(agreeing, renderer="smallpt", command="./smallpt --seed {seed}",
                                   runs=runs, arrays={}, pictures={},
                                   notes=["the variance of one run was not given"])
    record = comparison_record(external, tmp_path)
    assert record["images"] is None and record["renderer"] == "smallpt"
    assert record["command"] == "./smallpt --seed {seed}"
    assert (record["renders"], record["render_seconds"], record["cpu_seconds"]) == (2, 4.0, 7.0)
    assert record["runs"] == runs and record["notes"] == external.notes
    text = write_html([record], tmp_path / "html").read_text(encoding="utf-8")
    assert "the comparison was written without them" in text
    assert "renderer: smallpt (./smallpt --seed {seed})" in text
    ET.parse(write_junit([record], tmp_path / "junit.xml"))


def test_disagreeing_record_lists_exactly_the_significant_tiles(disagreeing, tmp_path):
    record = comparison_record(disagreeing, tmp_path)
    mean = record["verdicts"]["mean"]
    assert mean["status"] == "disagree" and math.isfinite(mean["critical_z"])
    z = disagreeing.mean.z_tiles
    for row, col, channel, value in mean["significant_tiles"]:
        assert value == z[row, col, channel] and abs(value) > mean["critical_z"]
    assert len({(r, c) for r, c, _, _ in mean["significant_tiles"]}) == disagreeing.mean.n_significant > 0
    assert mean["worst_region"] == mean_region(disagreeing.mean)
    bounces = record["verdicts"]["bounces"]
    assert bounces["first_diverging_depth"] == disagreeing.bounce[0]
    assert bounces["line"] == disagreeing.bounce[1]
    assert [(d["max_depth"], d["p_value"]) for d in bounces["depths"]] == [
        (depth, result.p_value) for depth, result in sorted(disagreeing.bounce_results.items())]
    assert {run["purpose"] for run in record["runs"]} == {"mean", "convergence", "bounces"}
    # the pictures compare() wrote, relative to the results file's folder
    assert set(record["pictures"]) == set(disagreeing.pictures)
    for name, path in record["pictures"].items():
        assert (tmp_path / path).resolve() == Path(disagreeing.pictures[name]).resolve()


def test_results_file_round_trip(written, agreeing, disagreeing):
    path, records = written
    document = json.loads(path.read_text())
    assert document["schema"] == RESULTS_SCHEMA and document["alpha"] == agreeing.mean.alpha
    assert document["agree"] == (agreeing.agree and disagreeing.agree)
    assert load_results(path) == records
    assert [record["source"] for record in records] == [str(path)] * 2
    assert [r["agree"] for r in records] == [agreeing.agree, disagreeing.agree]
    # two comparisons of one scene and integrator: their images do not overwrite each other
    assert records[0]["images"]["test"] != records[1]["images"]["test"]
    assert all((path.parent / name).is_file() for r in records for name in r["images"].values())


def test_json_numbers_stay_strict_and_come_back():
    values = np.array([1.5, math.inf, -math.inf, math.nan])
    written = encoding.plain({"v": values, "n": np.int64(3), "t": (1, 2), "b": np.bool_(True)})
    assert written == {"v": [1.5, "inf", "-inf", None], "n": 3, "t": [1, 2], "b": True}
    json.dumps(written, allow_nan=False)
    back = encoding.to_array(written["v"])
    assert back[:3].tolist() == [1.5, math.inf, -math.inf] and math.isnan(back[3])


# ----------------------------------------------------------------------------------
# JUnit

#: Jenkins' junit-10.xsd (xUnit plugin): the attributes each element may have, those it
#: must have, and the children it may hold; GitLab and GitHub's reporters read the same.
JUNIT_SCHEMA = {
    "testsuites": ({"name", "time", "tests", "failures", "errors"}, set(), {"testsuite"}),
    "testsuite": ({"name", "tests", "failures", "errors", "group", "time", "skipped", "timestamp",
                   "hostname", "id", "package", "file", "log", "url"},
                  {"name", "tests", "failures", "errors"},
                  {"testsuite", "properties", "testcase", "system-out", "system-err"}),
    "properties": (set(), set(), {"property"}),
    "property": ({"name", "value"}, {"name", "value"}, set()),
    "testcase": ({"name", "time", "classname", "group"}, {"name"},
                 {"skipped", "error", "failure", "system-out", "system-err"}),
    "failure": ({"type", "message"}, set(), set()),
    "skipped": ({"type", "message"}, set(), set()),
}
TIME = r"^[0-9]*(\.[0-9]*)?$"


def assert_junit_schema(element):
    allowed, required, children = JUNIT_SCHEMA[element.tag]
    assert set(element.attrib) <= allowed, (element.tag, set(element.attrib) - allowed)
    assert required <= set(element.attrib), (element.tag, required - set(element.attrib))
    if "time" in element.attrib:
        assert re.match(TIME, element.get("time")), element.get("time")
    for child in element:
        assert child.tag in children, (element.tag, child.tag)
        assert_junit_schema(child)


def test_junit_fails_exactly_the_failed_verdicts(written, tmp_path):
    _, records = written
    path = write_junit(records, tmp_path / "junit.xml")
    root = ET.parse(path).getroot()
    assert_junit_schema(root)
    suites = root.findall("testsuite")
    assert [s.get("name") for s in suites] == [f"{r['scene']}::{r['renderer']}" for r in records]
    for suite, record in zip(suites, records):
        cases = suite.findall("testcase")
        assert [c.get("name") for c in cases] == [f"{suite.get('name')}::{v}"
                                                  for v in ("mean", "variance", "convergence", "bounces")]
        failed = {c.get("name").rsplit("::", 1)[1] for c in cases if c.find("failure") is not None}
        skipped = {c.get("name").rsplit("::", 1)[1] for c in cases if c.find("skipped") is not None}
        verdicts = record["verdicts"]
        assert failed == {name for name, entry in verdicts.items() if entry["status"] == "disagree"}
        assert skipped == {name for name, entry in verdicts.items() if entry["status"] == "not compared"}
        assert int(suite.get("failures")) == len(failed) and int(suite.get("skipped")) == len(skipped)
        assert sum(float(c.get("time")) for c in cases) == pytest.approx(float(suite.get("time")), abs=0.01)
        for case in cases:
            failure = case.find("failure")
            if failure is not None:
                entry = verdicts[case.get("name").rsplit("::", 1)[1]]
                assert failure.get("message") == entry["line"]
                assert all(f"likely cause: {hint}" in failure.text for hint in record["hints"])
                assert all(Path(p).name in failure.text for p in record["pictures"].values())
    assert int(root.get("failures")) == sum(int(s.get("failures")) for s in suites) > 0


def test_junit_escapes_markup_and_drops_what_xml_cannot_hold(disagreeing, tmp_path):
    record = comparison_record(disagreeing, None)
    record["notes"] = ['a <b> & "c" \x1b[31m red']
    record["scene"] = "scene <&>.xml"
    root = ET.parse(write_junit([record], tmp_path / "junit.xml")).getroot()
    suite = root.find("testsuite")
    assert suite.get("name").startswith("scene <&>.xml::")
    failure = root.find(".//failure")
    assert 'note: a <b> & "c" \ufffd[31m red' in failure.text


# ----------------------------------------------------------------------------------
# HTML


class PageParts(HTMLParser):
    """The attributes of every tag of a page, and its text."""

    def __init__(self):
        super().__init__()
        self.tags, self.text = [], []

    def handle_starttag(self, tag, attrs):
        self.tags.append((tag, dict(attrs)))

    def handle_data(self, data):
        self.text.append(data)


def parse_page(path) -> PageParts:
    parts = PageParts()
    parts.feed(Path(path).read_text(encoding="utf-8"))
    return parts


@pytest.fixture(scope="module")
def reported(agreeing, disagreeing, tmp_path_factory):
    """``mitsuba-refs report`` on two results files: (its folder, exit status, stdout)."""
    folder = tmp_path_factory.mktemp("report")
    first, second = folder / "a" / "first.json", folder / "b" / "second.json"
    write_json([agreeing], first)
    write_json([disagreeing], second)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        status = main(["report", str(first), str(second), "--html", str(folder / "html"),
                       "--junit", str(folder / "junit.xml")])
    return folder, status, out.getvalue()


def test_html_page_is_self_contained(reported):
    folder, _, _ = reported
    page = folder / "html" / "index.html"
    text = page.read_text(encoding="utf-8")
    assert "http://" not in text and "https://" not in text
    parts = parse_page(page)
    images = [attrs for tag, attrs in parts.tags if tag == "img"]
    # per comparison: test, reference, z-map, relative difference, variance ratio, convergence
    assert len(images) == 12
    for image in images:
        assert image["src"].startswith("data:image/png;base64,")
        assert base64.b64decode(image["src"].split(",", 1)[1])[:8] == b"\x89PNG\r\n\x1a\n"
    for tag, attrs in parts.tags:
        assert tag not in ("link", "iframe", "object", "embed")
        for name in ("src", "href"):
            value = attrs.get(name)
            assert value is None or value.startswith(("data:", "#")), (tag, name, value)
        if tag == "script":
            assert "src" not in attrs


def test_html_says_when_the_images_are_missing(disagreeing, tmp_path):
    path = tmp_path / "results.json"
    records = write_json([disagreeing], path)
    (tmp_path / records[0]["images"]["test"]).unlink()
    text = write_html(records, tmp_path / "html").read_text(encoding="utf-8")
    assert "no such file" in text and records[0]["images"]["test"] in text
    images = [attrs for tag, attrs in parse_page(tmp_path / "html" / "index.html").tags if tag == "img"]
    assert len(images) == 3          # z-map, variance ratio, convergence: drawn from the record


def test_compare_html_alone_keeps_its_results_beside_the_page(agreeing, tmp_path):
    args = argparse.Namespace(json=None, junit=None, html=str(tmp_path / "html"))
    lines = write_outputs(args, [agreeing])
    assert [line.split(":")[0] for line in lines] == ["results", "report"]
    records = load_results(tmp_path / "html" / "results.json")
    assert records[0]["images"] and (tmp_path / "html" / records[0]["images"]["test"]).is_file()


# ----------------------------------------------------------------------------------
# Command line


def test_report_command_on_two_results_files(reported):
    folder, status, out = reported
    assert status == 0
    assert "2 comparisons from 2 files" in out and "index.html" in out and "junit.xml" in out
    page = folder / "html" / "index.html"
    parts = parse_page(page)
    summary = page.read_text(encoding="utf-8").split('<table class="summary">', 1)[1].split("</table>", 1)[0]
    assert summary.count("<tr>") == 3                   # the header and one row per comparison
    links = [attrs["href"][1:] for tag, attrs in parts.tags if tag == "a"]
    sections = [attrs["id"] for tag, attrs in parts.tags if tag == "section"]
    assert links == sections and len(sections) == 2
    assert len(ET.parse(folder / "junit.xml").getroot().findall("testsuite")) == 2


def _bad_inputs(tmp_path):
    not_json = tmp_path / "notes.json"
    not_json.write_text("{ not json")
    other = tmp_path / "other.json"
    other.write_text(json.dumps({"schema": "something/else"}))
    bad_record = tmp_path / "bad_record.json"
    bad_record.write_text(json.dumps({"schema": RESULTS_SCHEMA, "results": [{"schema": "x"}]}))
    a_file = tmp_path / "a_file"
    a_file.write_text("")
    return {
        "missing file": ([str(tmp_path / "missing.json"), "--html", str(tmp_path / "h")], "no such file"),
        "not JSON": ([str(not_json), "--html", str(tmp_path / "h")], "not JSON"),
        "other schema": ([str(other), "--html", str(tmp_path / "h")], "not a mitsuba-refs results file"),
        "bad record": ([str(bad_record), "--junit", str(tmp_path / "j.xml")], "result 1 has schema"),
        "a folder": ([str(tmp_path), "--html", str(tmp_path / "h")], "is a folder"),
        "nothing to write": ([str(other)], "nothing to write"),
        "html is a file": ([str(other), "--html", str(a_file)], "is a file"),
        "junit under a file": ([str(other), "--junit", str(a_file / "j.xml")], "is a file"),
    }


@pytest.mark.parametrize("case", ["missing file", "not JSON", "other schema", "bad record", "a folder",
                                  "nothing to write", "html is a file", "junit under a file"])
def test_report_command_refuses_bad_input_in_one_line(case, tmp_path, capsys):
    arguments, words = _bad_inputs(tmp_path)[case]
    status = main(["report", *arguments])
    err = capsys.readouterr().err
    assert status == 2
    assert err.count("\n") == 1 and err.startswith("mitsuba-refs report: error: ") and words in err
    assert not (tmp_path / "h").exists() and not (tmp_path / "j.xml").exists()


@pytest.mark.parametrize("option", ["--json", "--junit", "--html"])
def test_compare_refuses_an_unwritable_output_before_rendering(option, tmp_path, capsys, monkeypatch):
    a_file = tmp_path / "a_file"
    a_file.write_text("")
    monkeypatch.setattr("mitsuba_refs.verdicts.compare.compare", lambda *a, **k: pytest.fail("rendered"))
    target = a_file if option == "--html" else a_file / "out.file"
    status = main(["compare", "cornell-box", "--out", str(tmp_path / "pics"), option, str(target)])
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1 and option in err and "is a file" in err


def test_compare_writes_what_its_options_ask_for(disagreeing, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("mitsuba_refs.verdicts.compare.compare", lambda *a, **k: disagreeing)
    status = main(["compare", "cornell-box", "--out", str(tmp_path / "pics"),
                   "--json", str(tmp_path / "r.json"), "--junit", str(tmp_path / "j.xml"),
                   "--html", str(tmp_path / "html")])
    out = capsys.readouterr().out
    assert status == 1
    assert f"results: {tmp_path / 'r.json'}" in out and f"junit: {tmp_path / 'j.xml'}" in out
    assert f"report: {tmp_path / 'html' / 'index.html'}" in out
    assert load_results(tmp_path / "r.json")[0]["agree"] is False
    assert ET.parse(tmp_path / "j.xml").getroot().find(".//failure") is not None


@pytest.mark.parametrize("fraction, text", [(-0.013, "\u22121.3%"), (-0.0004, "\u22120.04%"),
                                            (-0.0, "+0.0%"), (2e-5, "+0.002%"), (0.1234, "+12.3%")])
def test_a_signed_percent_has_the_digits_it_needs(fraction, text):
    """An interval bound near 0 keeps a significant digit: never "[-1.3 %, -0.0 %]"."""
    assert percent(fraction, signed=True) == text
