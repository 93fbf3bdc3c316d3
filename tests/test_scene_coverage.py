"""experiments/scene_coverage.py: every class of file, the blocking feature, the share, the JSON."""
from __future__ import annotations

import json

import pytest

from experiments import scene_coverage
from mitsuba_refs.cli.options import DEFAULT_TOLERANCE

SENSOR = ('<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/>'
          '<integer name="height" value="6"/><rfilter type="box"/></film></sensor>')


def scene(body: str = "", version: str = "3.0.0") -> str:
    return f'<scene version="{version}">\n{SENSOR}\n{body}\n</scene>\n'


@pytest.fixture
def folder(tmp_path):
    files = {
        "ok.xml": scene('<shape type="sphere"/>'),
        "old.xml": scene('<shape type="sphere"><transform name="toWorld"><translate x="1"/>'
                         '</transform></shape>', version="0.6.0"),
        "hair.xml": scene('<shape type="sphere"><bsdf type="hair"/></shape>'),
        "hair2.xml": scene('<shape type="cube"><bsdf type="hair"/></shape>'),
        "prop.xml": scene('<shape type="sphere"><float name="radiuss" value="1"/></shape>'),
        "main.xml": scene('<include filename="parts/part.xml"/>'),
        "parts/part.xml": '<scene version="3.0.0"><shape type="sphere"/></scene>',
        "shape-only.xml": '<shape type="sphere"/>\n',
        "pol.xml": scene('<shape type="sphere"><bsdf type="polarizer"/></shape>'),
        "mesh.xml": scene('<shape type="ply"><string name="filename" value="gone.ply"/></shape>'),
        "broken.xml": "<scene version='3.0.0'>\n<shape>\n</scene>\n",
        "media.xml": scene('<integrator type="direct"/><shape type="sphere"><bsdf type="null"/>'
                           '</shape>'),
    }
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    return tmp_path


WANT = {"ok.xml": "loads", "old.xml": "loads", "main.xml": "loads", "hair.xml": "blocked",
        "hair2.xml": "blocked", "prop.xml": "blocked", "parts/part.xml": "fragment",
        "shape-only.xml": "fragment", "pol.xml": "polarized", "mesh.xml": "assets missing",
        "broken.xml": "malformed", "media.xml": "blocked"}


def test_classes_features_and_share(folder, capsys, tmp_path):
    out = tmp_path / "coverage.json"
    assert scene_coverage.main([str(folder), "--no-mitsuba", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    got = {f["file"]: f["cls"] for f in data["files"]}
    assert got == WANT
    features = data["features"]
    assert features['<bsdf type="hair">: unsupported BSDF'] == 2
    assert features['<shape type="sphere"> property "radiuss"'] == 1
    assert features['<bsdf type="null">: integrator \'direct\' does not render a null BSDF'] == 1
    assert data["considered"] == 7 and data["share"] == pytest.approx(3 / 7)
    assert data["mitsuba_checked"] is False
    missing = next(f for f in data["files"] if f["file"] == "mesh.xml")["missing"]
    assert missing == ["gone.ply"]
    table = capsys.readouterr().out
    assert "| blocked | 4 |" in table and "The tracer loads 3 of the 7 files" in table


def test_mitsuba_refusals_are_their_own_class(folder, tmp_path, mi):
    (folder / "unknown.xml").write_text(scene('<shape type="no_such_shape"/>'))
    out = tmp_path / "coverage.json"
    assert scene_coverage.main([str(folder), "--json", str(out), "--jobs", "1"]) == 0
    data = json.loads(out.read_text())
    files = {f["file"]: f for f in data["files"]}
    assert data["mitsuba_checked"] is True
    assert files["unknown.xml"]["cls"] == "refused by Mitsuba"
    assert "no_such_shape" in files["unknown.xml"]["mitsuba"]
    assert files["hair.xml"]["cls"] == "blocked" and files["hair.xml"]["mitsuba"] == "loads"
    assert files["ok.xml"]["cls"] == "loads" and files["old.xml"]["cls"] == "loads"


def test_resume_keeps_classes_and_verdicts_and_loads_blocked_files_again(folder, tmp_path,
                                                                        monkeypatch):
    """A campaign goes on where it stopped: classes and compare verdicts of the earlier JSON
    are kept (a file it classed is not loaded again), its blocked files are re-tried, and
    --compare-only picks the files compared; each compare uses the file's integrator, chosen
    again (the earlier run's may predate an estimator the tracer has learnt since)."""
    out = tmp_path / "coverage.json"
    assert scene_coverage.main([str(folder), "--no-mitsuba", "--json", str(out)]) == 0
    earlier = json.loads(out.read_text())
    for entry in earlier["files"]:
        if entry["file"] == "ok.xml":
            entry["compare"] = {"verdict": "agrees", "summary": "kept", "seconds": 1.0}
        if entry["file"] == "old.xml":
            entry["feature"] = "marked by the earlier run"    # kept: not loaded again
        if entry["file"] == "main.xml":
            entry["integrator"] = "volpath"     # stale: the integrator is chosen again
    out.write_text(json.dumps(earlier))
    (folder / "hair2.xml").write_text(scene('<shape type="cube"/>'))   # its blocker removed
    compared = []

    def fake_run(command, **kwargs):
        compared.append(command)
        return type("Done", (), {"returncode": 0, "stdout": "path on x: AGREES with Mitsuba",
                                 "stderr": ""})()
    monkeypatch.setattr(scene_coverage.subprocess, "run", fake_run)
    again = tmp_path / "again.json"
    assert scene_coverage.main([str(folder), "--no-mitsuba", "--json", str(again), "--compare",
                                "--resume", str(out), "--compare-only", "hair*", "main.xml",
                                "--no-convergence"]) == 0
    files = {f["file"]: f for f in json.loads(again.read_text())["files"]}
    assert files["hair2.xml"]["cls"] == "loads" and files["hair.xml"]["cls"] == "blocked"
    assert files["old.xml"]["feature"] == "marked by the earlier run"
    assert files["ok.xml"]["compare"]["summary"] == "kept"
    assert [c[c.index("compare") + 1] for c in compared] == [str(folder / "hair2.xml"),
                                                            str(folder / "main.xml")]
    assert all(c[c.index("--integrator") + 1] == "path" and "--no-convergence" in c
               and "--tolerance" not in c for c in compared)
    assert files["main.xml"]["compare"]["verdict"] == "agrees"
    assert files["main.xml"]["compare"]["convergence"] is False
    assert not files["old.xml"]["compare"]
    by_plugin = json.loads(again.read_text())["verdicts_by_plugin"]   # includes spliced in
    assert by_plugin["shape:cube"] == {"agrees": 1} and by_plugin["shape:sphere"] == {"agrees": 2}
    assert by_plugin["rfilter:box"] == {"agrees": 3}


def results_file(outcome: str, spp: int, looks: list[int] | None, spp_needed=None) -> dict:
    """What compare's --json writes, as much of it as the coverage record reads."""
    mean = {"status": outcome.lower()}
    if looks is not None:
        mean["rounds"] = {"looks": [{"spp": n} for n in looks], "stopped_by": "spp",
                          "interval": [-0.01, 0.03],
                          "spp_needed": spp_needed, "reference_pieces": 1}
    return {"results": [{"outcome": outcome, "spp": spp,
                         "verdicts": {"mean": mean, "variance": {"status": "agree"},
                                      "convergence": {"status": "not compared"}}}]}


def fake_compare(monkeypatch, returncode: int, results: dict | None):
    """Replace the compare process: record its command, write ``results`` where --json says."""
    commands = []

    def fake_run(command, **kwargs):
        commands.append(command)
        if results is not None:
            with open(command[command.index("--json") + 1], "w") as f:
                json.dump(results, f)
        return type("Done", (), {"returncode": returncode, "stderr": "",
                                 "stdout": "path on x: INCONCLUSIVE within +-2% vs Mitsuba"})()
    monkeypatch.setattr(scene_coverage.subprocess, "run", fake_run)
    return commands


def test_tolerance_options_reach_compare_and_exit_3_is_inconclusive(folder, tmp_path,
                                                                    monkeypatch, capsys):
    """--tolerance, --max-spp and --max-seconds are given to every compare; exit code 3 is
    recorded as inconclusive, with the spp of the last look, the rounds judged and the spp
    that the line says would decide, read from compare's --json; the table prints them."""
    commands = fake_compare(monkeypatch, 3, results_file("INCONCLUSIVE", 256,
                                                         [16, 32, 64, 128, 256], 1024.0))
    out = tmp_path / "coverage.json"
    assert scene_coverage.main([str(folder), "--no-mitsuba", "--json", str(out), "--compare",
                                "--compare-only", "ok.xml", "--tolerance", "2", "--max-spp",
                                "256", "--max-seconds", "30"]) == 0
    [command] = commands
    given = {option: command[command.index(option) + 1]
             for option in ("--tolerance", "--max-spp", "--max-seconds")}
    assert {k: float(v) for k, v in given.items()} == {"--tolerance": 2, "--max-spp": 256,
                                                       "--max-seconds": 30}
    assert "--no-convergence" not in command
    record = {f["file"]: f for f in json.loads(out.read_text())["files"]}["ok.xml"]["compare"]
    assert record["verdict"] == "inconclusive" and record["outcome"] == "INCONCLUSIVE"
    assert (record["spp"], record["rounds"], record["spp_needed"]) == (256, 5, 1024.0)
    assert record["tolerance"] == 2 and record["max_spp"] == 256
    assert record["stopped_by"] == "spp" and record["interval"] == [-0.01, 0.03]
    assert record["statuses"]["variance"] == "agree"
    assert "- ok.xml: inconclusive (+-2 %) at 256 spp, 5 rounds" in capsys.readouterr().out


def test_bare_tolerance_is_compares_default_and_fixed_budget_is_one_round(folder, tmp_path,
                                                                         monkeypatch):
    """A bare --tolerance gives compare its default percentage; without --tolerance the
    record says the fixed budget's spp in one round (compare's own --json)."""
    commands = fake_compare(monkeypatch, 0, results_file("AGREES", 64, None))
    out = tmp_path / "coverage.json"
    assert scene_coverage.main([str(folder), "--no-mitsuba", "--json", str(out), "--compare",
                                "--compare-only", "ok.xml", "old.xml"]) == 0
    record = {f["file"]: f for f in json.loads(out.read_text())["files"]}["ok.xml"]["compare"]
    assert record["verdict"] == "agrees" and (record["spp"], record["rounds"]) == (64, 1)
    assert record["tolerance"] is None and all("--tolerance" not in c for c in commands)
    commands.clear()
    assert scene_coverage.main([str(folder), "--no-mitsuba", "--compare", "--compare-only",
                                "ok.xml", "--tolerance"]) == 0
    assert float(commands[0][commands[0].index("--tolerance") + 1]) == DEFAULT_TOLERANCE


def test_a_refused_compare_writes_no_results_and_is_recorded_as_refused(folder, tmp_path,
                                                                       monkeypatch):
    fake_compare(monkeypatch, 2, None)
    out = tmp_path / "coverage.json"
    assert scene_coverage.main([str(folder), "--no-mitsuba", "--json", str(out), "--compare",
                                "--compare-only", "ok.xml", "--tolerance", "2"]) == 0
    record = {f["file"]: f for f in json.loads(out.read_text())["files"]}["ok.xml"]["compare"]
    assert record["verdict"] == "refused" and "spp" not in record


def test_round_budget_without_tolerance_is_refused_before_loading(folder, capsys):
    assert scene_coverage.main([str(folder), "--no-mitsuba", "--compare", "--max-spp", "256"]) == 2
    assert "--max-spp and --max-seconds go with --tolerance" in capsys.readouterr().err


def test_not_a_folder(tmp_path, capsys):
    assert scene_coverage.main([str(tmp_path / "nothere")]) == 2
    assert "is not a folder" in capsys.readouterr().err
