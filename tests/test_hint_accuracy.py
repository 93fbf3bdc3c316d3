"""Hints that do not mislead (autograder/hints/accuracy.py, docs/autograder.md "Hint accuracy").

The measurement grades every bug-zoo and hint mutant (minutes of CPU); these tests re-explain
the evidence it recorded for a subset (tests/data/hint_evidence: the mistakes whose hints used
to name a wrong cause, and others of each rule) with today's rules, and assert that no hint
names a cause other than the mutant's true one, and that a right hint stays right. Cheap: no
student process, no render (the sweep references are the committed ones).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from autograder import grading
from autograder.hints import accuracy, evidence_io
from autograder.hints.explain import Evidence, explain
from mitsuba_refs.stats.mean import compare_means
from mitsuba_refs.stats.variance import compare_variances
from mitsuba_refs.verdicts.compare import Comparison
from mitsuba_refs.verdicts.explain import Hint

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
    evidence, record = evidence_io.read(EVIDENCE, name)
    found = explain(evidence)
    verdict, causes = accuracy.classify(found, record["cause"])
    assert verdict in ("right", "evidence-only"), (verdict, causes, [str(h) for h in found])
    assert verdict == record["verdict"], (verdict, record["verdict"], [str(h) for h in found])


def test_classification():
    right = Hint("x", ("roulette", "depth_cut"))
    assert accuracy.classify([right, Hint("numbers")], "depth_cut") == \
        ("right", ["depth_cut", "roulette"])
    assert accuracy.classify([right, Hint("y", ("mis_weights",))], "depth_cut")[0] == "wrong"
    assert accuracy.classify([Hint("numbers only")], "roulette") == ("evidence-only", [])
    assert accuracy.classify(["a plain string"], "roulette")[0] == "untagged"


def test_committed_measurement_has_no_wrong_cause():
    """docs/data/hint_accuracy.json, written by python -m autograder.hints.accuracy: every
    mutant was graded, detected, and no hint named a wrong (or an untagged) cause."""
    report = json.loads((ROOT / "docs" / "data" / "hint_accuracy.json").read_text())
    assert report["summary"]["all"]["wrong"] == 0
    assert report["summary"]["all"]["untagged"] == 0
    assert report["summary"]["all"]["not detected"] == 0
    graded = {(r["mutant"], r["check"]) for r in report["rows"]}
    assert graded == {(n, c) for n, _, _, c, _ in accuracy.cases()}
    assert report["summary"]["hint_mutants"]["checks"] >= 12


# ----------------------------------------------------------------------------------------
# The measurement's cache: full evidence as data only (evidence_io.dump / load)

def _same(a, b) -> bool:
    """Whether two evidence trees are equal: same types (a NumPy scalar comes back as the Python
    number it holds), arrays bit for bit, NaN equal NaN."""
    a, b = (x.item() if isinstance(x, np.generic) else x for x in (a, b))
    if type(a) is not type(b):
        return False
    if isinstance(a, np.ndarray):
        return a.dtype == b.dtype and a.shape == b.shape and \
            np.array_equal(a, b, equal_nan=a.dtype.kind in "fc")
    if isinstance(a, float):
        return a == b or (np.isnan(a) and np.isnan(b))
    if isinstance(a, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, dict):
        return list(a) == list(b) and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, Hint):
        return str(a) == str(b) and a.causes == b.causes
    if hasattr(a, "__dict__") and not isinstance(a, grading.Check):
        return _same(vars(a), vars(b))
    return a == b


def _real_evidence() -> Evidence:
    """Evidence built of the real result classes a graded check produces."""
    rng = np.random.default_rng(7)
    ref = rng.uniform(0.2, 1.0, (32, 32, 3))
    test = ref * 1.1 + rng.normal(0, 0.01, ref.shape)
    var = np.full(ref.shape, 0.04)
    mean = compare_means(test, var, 64, ref, var, 256, alpha=1e-3)
    variance = compare_variances(var * 1.3, 64, var, 256, alpha=1e-3)
    comparison = Comparison(scene="cornell-box", integrator="path", params={"max_depth": 5},
                            spp=64, mean=mean, variance=variance, bounce=(2, None),
                            hints=[Hint("image x1.10", ("diffuse_pi",))],
                            arrays={"test_mean": test})
    check = grading.CHECKS[0]
    earlier = grading.CheckResult(check=check, comparison=comparison, parts=[
        grading.Part("mean", 0.0, 5.0, False, f"p = {float('nan')}")])
    return Evidence(check=check, comparison=comparison, history={check.id: earlier},
                    sweep={2: (mean, test.astype(np.float32), ref)},
                    independence=float("inf"), probe=(3, 4096),
                    images={"mean": test, "n": np.int64(64), "flags": np.array([True])},
                    incomplete="")


def test_full_evidence_round_trips_exactly(tmp_path):
    evidence = _real_evidence()
    evidence_io.dump(evidence, tmp_path, "case", {"mutant": "m", "score": 0.0})
    again, entry = evidence_io.load(tmp_path, "case")
    assert entry == {"mutant": "m", "score": 0.0}
    assert _same(again, evidence)
    assert again.check is evidence.check                       # restored by its id
    assert again.history[evidence.check.id].passed is False    # properties of the real class
    assert again.comparison.agree == evidence.comparison.agree
    assert again.images["n"] == 64 and type(again.images["n"]) is int
    evidence_io.dump(None, tmp_path, "none", {})
    assert evidence_io.load(tmp_path, "none") == (None, {})


@pytest.mark.parametrize("name", CASES[:4])
def test_full_evidence_explains_alike(tmp_path, name):
    """The committed cases, through dump and load, give the same hints, causes and all."""
    evidence, _ = evidence_io.read(EVIDENCE, name)
    evidence_io.dump(evidence, tmp_path, name)
    again, _ = evidence_io.load(tmp_path, name)
    assert [(str(h), h.causes) for h in explain(again)] == \
        [(str(h), h.causes) for h in explain(evidence)]


def test_full_evidence_runs_no_code(tmp_path):
    """What the cache holds is data: other objects are refused when writing, and a file that
    names another class or holds a pickled array is refused when reading."""
    class Stranger:
        pass
    with pytest.raises(TypeError, match="Stranger"):
        evidence_io.dump({"x": Stranger()}, tmp_path, "bad")
    with pytest.raises(TypeError, match="objects"):
        evidence_io.dump(np.array([Stranger()], dtype=object), tmp_path, "bad")
    evidence_io.dump(_real_evidence(), tmp_path, "case")
    (tmp_path / "forged.json").write_text(json.dumps(
        {"evidence": {"object": "Popen", "fields": {"args": ["true"]}}}))
    np.savez(tmp_path / "forged.npz")
    with pytest.raises(KeyError, match="Popen"):
        evidence_io.load(tmp_path, "forged")
    (tmp_path / "forged.json").write_text(json.dumps({"evidence": {"array": "a0"}}))
    np.savez(tmp_path / "forged.npz", a0=np.array([print], dtype=object))
    with pytest.raises(ValueError, match="allow_pickle"):
        evidence_io.load(tmp_path, "forged")


def test_a_dark_image_missing_its_noise_says_so_and_names_no_cause():
    """test_texturedprincipled1_path at 64 spp: 0.948x the reference with 0.26x its per-sample
    variance (the same estimator). The hint states it (by chance or always), names no cause;
    a uniformly darker image (variance ratio^2), a brighter one or another estimator get none."""
    from types import SimpleNamespace

    from mitsuba_refs.verdicts.explain import missing_noise
    reference = np.full((8, 8, 3), 2.0)

    def comparison(share, same=True):
        return SimpleNamespace(compares_variance=same,
                               arrays={"test_variance": share * reference,
                                       "reference_variance": reference})
    hint = missing_noise(comparison(0.26), 0.948)
    assert hint is not None and hint.causes == ()
    assert "0.948x" in hint and "0.26x" in hint and "by chance" in hint
    assert missing_noise(comparison(0.948 ** 2), 0.948) is None
    assert missing_noise(comparison(0.26, same=False), 0.948) is None
    assert missing_noise(comparison(0.26), 1.05) is None
    assert missing_noise(SimpleNamespace(compares_variance=True), 0.9) is None
