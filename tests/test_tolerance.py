"""Verdicts that decide (``--tolerance``): AGREES within +-T %, DISAGREES or INCONCLUSIVE,
rendered in doubling rounds until decided (mitsuba_refs.stats.sequential, .equivalence,
mitsuba_refs.verdicts.rounds)."""
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mitsuba_refs.cli.options import EXIT_INCONCLUSIVE
from mitsuba_refs.reference.render import Reference
from mitsuba_refs.report.html import summary_table
from mitsuba_refs.report.junit import junit_tree
from mitsuba_refs.stats.equivalence import AGREES, DISAGREES, UNDECIDED, decide_tolerance, samples_to_decide
from mitsuba_refs.stats.sequential import alpha_per_look, look_totals, merge_moments
from mitsuba_refs.verdicts.compare import compare
from mitsuba_refs.verdicts.rounds import extended, reference_dominates
from mitsuba_refs.verdicts.scenes import render_ours
from tests.budget import ALPHA

ROOT = Path(__file__).resolve().parent.parent
SCALED = ROOT / "tests" / "external" / "mitsuba_scaled_renderer.py"
#: A cheap comparison: the committed 64x64 cornell-box reference, no convergence ladder.
QUICK = {"convergence": False, "bounces": False, "alpha": ALPHA}


class Scaled:
    """Our ``path`` with its image times ``factor``: a renderer ``factor - 1`` too bright."""

    def __init__(self, factor):
        self.factor = factor
        self.spp = []

    def __call__(self, scene, integrator, params, spp, seed, **keywords):
        self.spp.append(spp)
        mean, variance = render_ours(scene, integrator, params, spp, seed, **keywords)
        return mean * self.factor, variance * self.factor ** 2


def test_looks_double_up_to_the_budget():
    assert look_totals(64) == (4, 8, 16, 32, 64)
    assert look_totals(1000) == (62, 124, 248, 496, 992, 1000)
    assert look_totals(3) == (3,)
    assert alpha_per_look(1e-3, 5) == pytest.approx(2e-4)
    with pytest.raises(ValueError, match="max_spp"):
        look_totals(0)


def test_merged_rounds_are_the_moments_of_all_their_samples():
    samples = np.random.default_rng(3).exponential(size=(4, 5, 3, 24))
    first, second = samples[..., :8], samples[..., 8:]
    mean, variance = merge_moments(first.mean(-1), first.var(-1, ddof=1), 8,
                                   second.mean(-1), second.var(-1, ddof=1), 16)
    np.testing.assert_allclose(mean, samples.mean(-1))
    np.testing.assert_allclose(variance, samples.var(-1, ddof=1))


def _noiseless(factor, tolerance):
    image = np.full((16, 16, 3), 0.5)
    zero = np.zeros_like(image)
    return decide_tolerance((image * factor, zero, 64), (image, zero, 4096), tolerance=tolerance,
                            alpha=1e-3)


def test_noiseless_images_are_decided_by_the_tolerance_alone():
    assert _noiseless(1.0, 0.02).outcome == AGREES
    assert _noiseless(1.03, 0.05).outcome == AGREES
    assert _noiseless(1.03, 0.01).outcome == DISAGREES
    assert _noiseless(0.9, 0.05).outcome == DISAGREES
    assert _noiseless(0.9, 0.05).beyond_tiles == 4


def test_reference_noise_that_hides_the_tolerance_is_named():
    rng = np.random.default_rng(5)
    image = np.full((16, 16, 3), 0.5)
    reference_var = np.full_like(image, 400.0)          # a very noisy reference
    decision = decide_tolerance((image, np.full_like(image, 1.0), 64),
                                (image + rng.normal(0, 0.3, image.shape), reference_var, 4096),
                                tolerance=0.01, alpha=1e-3)
    assert decision.outcome == UNDECIDED
    spp, limited = samples_to_decide(decision, 64, 1e-3)
    assert limited and math.isinf(spp)


def test_a_reference_extended_by_a_piece_is_the_pooled_reference():
    rng = np.random.default_rng(11)
    samples = rng.exponential(size=(3, 4, 3, 12))
    first, second = samples[..., :4], samples[..., 4:]
    reference = Reference(first.mean(-1), first.var(-1, ddof=1), 4, {"key": "k"})
    piece = Reference(second.mean(-1), second.var(-1, ddof=1), 8, {})
    pooled = extended(reference, piece)
    assert pooled.n == 12 and pooled.metadata["key"] == "k"
    np.testing.assert_allclose(pooled.var, samples.var(-1, ddof=1))


def test_a_reference_is_extended_when_its_noise_dominates():
    image = np.full((16, 16, 3), 0.5)
    quiet, loud = np.full_like(image, 1e-4), np.full_like(image, 4.0)
    test = (image, np.full_like(image, 1.0), 4096)
    assert reference_dominates(decide_tolerance(test, (image, loud, 4096), tolerance=0.01,
                                                alpha=1e-3))
    assert not reference_dominates(decide_tolerance(test, (image, quiet, 4096), tolerance=0.01,
                                                    alpha=1e-3))


@pytest.mark.statistical(assertions=1)
def test_an_unbiased_renderer_agrees_within_two_percent():
    result = compare("cornell-box", "path", tolerance=2, spp=512, **QUICK)
    assert result.outcome == "AGREES", result.report()
    assert result.agree and "within \u00b12%" in result.report()
    assert max(abs(x) for x in result.rounds.decision.interval) < 0.02


@pytest.mark.statistical(assertions=2)
def test_three_percent_too_bright_disagrees_beyond_one_and_agrees_within_five():
    tight = compare("cornell-box", "path", tolerance=1, spp=512, render=Scaled(1.03), **QUICK)
    assert tight.outcome == "DISAGREES", tight.report()
    loose = compare("cornell-box", "path", tolerance=5, spp=512, render=Scaled(1.03), **QUICK)
    assert loose.outcome == "AGREES", loose.report()


@pytest.mark.statistical(assertions=1)
def test_twenty_percent_too_bright_is_told_in_the_first_round():
    render = Scaled(1.2)
    result = compare("cornell-box", "path", tolerance=2, spp=64, render=render, **QUICK)
    assert result.outcome == "DISAGREES", result.report()
    assert sum(render.spp) == 4 and len(result.rounds.looks) == 1     # 1/16 of 64 spp


@pytest.mark.statistical(assertions=1)
def test_an_unreachable_tolerance_with_a_small_budget_is_inconclusive():
    result = compare("cornell-box", "path", tolerance=0.1, spp=8, **QUICK)
    assert result.outcome == "INCONCLUSIVE" and not result.agree, result.report()
    assert result.rounds.stopped_by == "spp" and "would decide" in result.report()


def _check(factor, tolerance, max_spp, tmp_path):
    command = (f"{sys.executable} {SCALED} {{scene}} --spp {{spp}} --seed {{seed}} --max-depth "
               f"{{max_depth}} --width {{width}} --height {{height}} --factor {factor} --out {{out}}")
    out = tmp_path / f"check-{factor}-{tolerance}.json"
    run = subprocess.run([sys.executable, "-m", "mitsuba_refs.cli.main", "check", "cornell-box",
                          "--command", command, "--output-suffix", ".pfm", "--no-convergence",
                          "--bounces", "never", "--alpha", str(ALPHA), "--jobs", "2",
                          "--tolerance", str(tolerance), "--max-spp", str(max_spp),
                          "--out", str(tmp_path), "--json", str(out)],
                         cwd=ROOT, capture_output=True, text=True, timeout=600)
    record = json.loads(out.read_text())["results"][0] if out.exists() else {}
    return run.returncode, record, run.stdout + run.stderr[-2000:]


@pytest.mark.mitsuba
@pytest.mark.statistical(assertions=2)
def test_check_of_mitsuba_three_percent_too_bright_decides_by_the_tolerance(tmp_path):
    status, record, text = _check(1.03, 1, 1024, tmp_path)
    assert status == 1 and record["outcome"] == "DISAGREES", text
    status, record, text = _check(1.03, 5, 1024, tmp_path)
    assert status == 0 and record["outcome"] == "AGREES", text
    assert record["tolerance_percent"] == 5 and record["verdicts"]["mean"]["rounds"]["looks"]


@pytest.mark.mitsuba
@pytest.mark.statistical(assertions=1)
def test_check_of_mitsuba_itself_agrees_within_two_percent(tmp_path):
    status, record, text = _check(1.0, 2, 512, tmp_path)
    assert status == 0 and record["outcome"] == "AGREES", text
    low, high = record["verdicts"]["mean"]["rounds"]["interval"]
    assert -0.02 < low <= high < 0.02


@pytest.mark.mitsuba
@pytest.mark.statistical(assertions=1)
def test_check_of_mitsuba_twenty_percent_too_bright_is_told_in_the_first_round(tmp_path):
    status, record, text = _check(1.2, 2, 64, tmp_path)
    assert status == 1 and record["outcome"] == "DISAGREES", text
    looks = record["verdicts"]["mean"]["rounds"]["looks"]
    assert [look["spp"] for look in looks] == [4]      # 1/16 of 64 spp


@pytest.mark.mitsuba
@pytest.mark.statistical(assertions=1)
def test_check_with_an_unreachable_tolerance_exits_inconclusive(tmp_path):
    status, record, text = _check(1.0, 0.1, 8, tmp_path)
    assert status == EXIT_INCONCLUSIVE and record["outcome"] == "INCONCLUSIVE", text
    assert record["verdicts"]["mean"]["status"] == "inconclusive"
    failure = junit_tree([record]).getroot().find(".//failure")
    assert failure is not None and failure.get("type") == "inconclusive"
    assert 'class="inconclusive">inconclusive' in summary_table([record], ["a"])


def test_budget_options_need_a_tolerance():
    run = subprocess.run([sys.executable, "-m", "mitsuba_refs.cli.main", "compare", "cornell-box",
                          "--max-spp", "128"], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert run.returncode == 2 and "--tolerance" in run.stderr
    run = subprocess.run([sys.executable, "-m", "mitsuba_refs.cli.main", "compare", "cornell-box",
                          "--tolerance", "0"], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert run.returncode == 2 and "--tolerance" in run.stderr


def test_a_bare_tolerance_before_the_scene_says_where_it_goes():
    run = subprocess.run([sys.executable, "-m", "mitsuba_refs", "compare", "--tolerance",
                          "cornell-box"], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert run.returncode == 2 and "Traceback" not in run.stderr
    assert "a bare --tolerance goes after the scene, or write --tolerance 2 cornell-box" in run.stderr


def test_the_calibration_experiment_writes_rates_per_scenario_and_level(tmp_path):
    from experiments import sequential_calibration
    out = tmp_path / "sim.json"
    sequential_calibration.main(["sim", "--runs", "3", "--biases", "0,0.2", "--size", "16",
                                 "--max-spp", "64", "--json", str(out)])
    data = json.loads(out.read_text())
    strong = data["scenarios"]["+0.2"]["summary"]["levels"]["0.05"]
    assert strong["disagrees"]["count"] == 3 and strong["median_spp_all"] <= 16
    assert len(data["scenarios"]["+0"]["runs"]) == 3 and data["looks"] == [4, 8, 16, 32, 64]
