"""experiments/sequential_coverage.py: the four compares' options, the table's counts and ratios."""
from __future__ import annotations

import json

from experiments import sequential_coverage


def record(verdict: str, seconds: float, spp: int, tolerance=None, **extra) -> dict:
    return {"verdict": verdict, "seconds": seconds, "spp": spp, "tolerance": tolerance,
            "integrator": "path", "render_seconds": {"mean": seconds / 2}, **extra}


def raw_runs() -> dict:
    """Two files, two repetitions; b.xml's rounds stay undecided without convergence."""
    runs = []
    for repetition, slower in ((1, 1.0), (2, 1.5)):
        for file, rounds_nc in (("x/a.xml", record("agrees", 2 * slower, 32, 2.0)),
                                ("b.xml", record("inconclusive", 6 * slower, 256, 2.0,
                                                 interval=[-0.01, 0.025], spp_needed=700.0))):
            passes = {"today": record("agrees", 10 * slower, 64),
                      "rounds": record("agrees", 8 * slower, 64, 2.0),
                      "today-nc": record("agrees", 4 * slower, 64), "rounds-nc": rounds_nc}
            runs += [{"repetition": repetition, "file": file, "pass": name, "record": r}
                     for name, r in passes.items()]
    return {"runs": runs}


def test_pass_options_are_the_coverage_runs_own():
    assert sequential_coverage.pass_options("today", 2.0, 256) == []
    assert sequential_coverage.pass_options("rounds-nc", 2.0, 256) == [
        "--no-convergence", "--tolerance", "2.0", "--max-spp", "256"]


def test_table_counts_decisions_and_takes_median_seconds(tmp_path, capsys):
    path = tmp_path / "raw.json"
    path.write_text(json.dumps(raw_runs()))
    assert sequential_coverage.main(["--table", str(path)]) == 0
    text = capsys.readouterr().out
    # a.xml: rounds without convergence agree at 32 spp in a median 2.5 s against today's 5.0.
    assert "| a.xml | path | agrees, 12.5 | agrees at 64, 10.0 | agrees, 5.0 | agrees at 32, 2.5 |" in text
    assert "without convergence: rounds decided 1 of 2 files" in text
    assert "with convergence: rounds decided 2 of 2 files" in text
    assert "with and without convergence: no" in text      # b.xml's differ here
    # Per-file ratios without convergence: 2.5/5 and 7.5/5: median 1.0.
    assert "median per-file ratio 1.00" in text.split("without convergence")[1]
    assert "- b.xml: interval [-1.00 %, +2.50 %] at 256 spp; about --max-spp 1024 would decide" in text


def test_measuring_needs_its_paths(capsys):
    assert sequential_coverage.main(["somewhere"]) == 2
    assert "measuring needs resume, files, work, out" in capsys.readouterr().err
