"""Hints that do not mislead (autograder/hint_accuracy.py, docs/autograder.md "Hint accuracy").

The measurement grades every bug-zoo and hint mutant (minutes of CPU); these tests re-explain
the evidence it recorded for a subset (tests/data/hint_evidence: the mistakes whose hints used
to name a wrong cause, and others of each rule) with today's rules, and assert that no hint
names a cause other than the mutant's true one, and that a right hint stays right. Cheap: no
student process, no render (the sweep references are the committed ones).
"""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from autograder import hint_accuracy, hint_evidence, hints
from mitsuba_refs.explain import Hint

ROOT = Path(__file__).resolve().parent.parent
EVIDENCE = ROOT / "tests" / "data" / "hint_evidence"
CASES = sorted(p.stem for p in EVIDENCE.glob("*.json"))
#: The issue's four realistic mistakes whose hints named a wrong cause.
ISSUE = ("visible_emitter_twice", "transmittance_distance_squared", "shadow_ray_no_offset",
         "bsdf_arguments_swapped")


def test_recorded_subset_covers_the_issue():
    mutants = {json.loads((EVIDENCE / f"{c}.json").read_text())["mutant"] for c in CASES}
    assert set(ISSUE) <= mutants and len(CASES) >= 8


@pytest.mark.parametrize("name", CASES)
def test_recorded_evidence_names_no_wrong_cause(name):
    evidence, record = hint_evidence.read(EVIDENCE, name)
    found = hints.explain(evidence)
    verdict, causes = hint_accuracy.classify(found, record["cause"])
    assert verdict in ("right", "evidence-only"), (verdict, causes, [str(h) for h in found])
    assert verdict == record["verdict"], (verdict, record["verdict"], [str(h) for h in found])


def test_classification():
    right = Hint("x", ("roulette", "depth_cut"))
    assert hint_accuracy.classify([right, Hint("numbers")], "depth_cut") == \
        ("right", ["depth_cut", "roulette"])
    assert hint_accuracy.classify([right, Hint("y", ("mis_weights",))], "depth_cut")[0] == "wrong"
    assert hint_accuracy.classify([Hint("numbers only")], "roulette") == ("evidence-only", [])
    assert hint_accuracy.classify(["a plain string"], "roulette")[0] == "untagged"


def test_committed_measurement_has_no_wrong_cause():
    """docs/data/hint_accuracy.json, written by python -m autograder.hint_accuracy: every
    mutant was graded, detected, and no hint named a wrong (or an untagged) cause."""
    report = json.loads((ROOT / "docs" / "data" / "hint_accuracy.json").read_text())
    assert report["summary"]["all"]["wrong"] == 0
    assert report["summary"]["all"]["untagged"] == 0
    assert report["summary"]["all"]["not detected"] == 0
    graded = {(r["mutant"], r["check"]) for r in report["rows"]}
    assert graded == {(n, c) for n, _, _, c, _ in hint_accuracy.cases()}
    assert report["summary"]["hint_mutants"]["checks"] >= 12
