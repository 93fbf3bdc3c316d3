"""Power of the graded mean parts (autograder.power, mitsuba_refs.stats.power).

The detectable bias is computed analytically from the committed references; the injection
check draws renders at the references' real per-pixel variances with fixed seeds.  Neither
depends on the tracer: the assertions are deterministic, their false-failure probabilities
(over the fixed seeds) are stated and below the suite's ALPHA (tests/budget.py).
"""
from __future__ import annotations

import math

import pytest
from scipy import stats as sps

from autograder import grading, power
from mitsuba_refs.stats import detectable_bias
from tests.budget import ALPHA

INTEGRATOR_CHECKS = [c for c in grading.CHECKS if not c.camera]
#: Checks whose 1.5 % needs more samples than the 3-minute submission budget allows
#: (docs/autograder.md, "Power": 1728-1920 spp), with the bias they are documented to detect.
OVER_BUDGET = {"path_bsdf-cornell-box": 0.029, "path_bsdf-glass": 0.030,
               "path_bsdf-lights": 0.027}


def test_power_table_covers_every_check():
    rows = power.power_table(seeds=4)
    assert [r["check"] for r in rows] == [c.id for c in grading.CHECKS
                                          if any(n == "mean" for n, _ in c.parts)]
    for row, check in zip(rows, grading.CHECKS):
        assert row["spp"] == check.spp and row["alpha"] == grading.ALPHA
        assert 0 < row["reference_floor"] < row["detectable_bias"] < 0.1
    text = power.format_table(rows)
    assert text.count("\n") == len(rows) + 1 and "path-cornell-box" in text


@pytest.mark.parametrize("check", grading.CHECKS, ids=[c.id for c in grading.CHECKS])
def test_injected_power_confirms_the_analytic_bound(check):
    """At the analytic bound the simulated grader detects the bias (both signs) in at least
    the lower ALPHA-quantile of Binomial(100, 0.95) (82) of 100 injected renders: if the bound
    holds (power >= 0.95), this fails with probability <= ALPHA."""
    ref = power.reference_of(check)
    need = int(sps.binom.ppf(ALPHA, 100, 0.95))
    for sign in (1, -1):
        b = detectable_bias(ref.mean, ref.var, ref.n, check.spp, alpha=grading.ALPHA, sign=sign)
        rate = power.injected_power(sign * b, ref.mean, ref.var, ref.n, check.spp,
                                    alpha=grading.ALPHA, seeds=100, seed=7 + (sign > 0))
        print(check.id, sign, f"b={b:.4f}", rate)
        assert round(rate * 100) >= need, (check.id, sign, b, rate)


@pytest.mark.parametrize("check", INTEGRATOR_CHECKS, ids=[c.id for c in INTEGRATOR_CHECKS])
def test_every_integrator_check_detects_a_bias_of_one_and_a_half_percent(check):
    """1.5 % for every integrator check but the BSDF-only ones, which detect what the docs
    say they do (and are not silently above it)."""
    ref = power.reference_of(check)
    worst = max(detectable_bias(ref.mean, ref.var, ref.n, check.spp, alpha=grading.ALPHA, sign=s)
                for s in (1, -1))
    target = OVER_BUDGET.get(check.id, power.TARGET_BIAS)
    assert worst <= target, f"{check.id}: {100 * worst:.2f} % at {check.spp} spp"


def test_a_bias_significant_at_1e_minus_4_does_not_pass():
    """The issue's case: +1.6 % measured by the grader with p = 1.5e-4 passed at the part
    level 4.8e-5.  At each check's spp a +1.6 % bias has a detection probability of at least
    0.95 (analytic bound) wherever the check meets the 1.5 % target."""
    for check in INTEGRATOR_CHECKS:
        if check.id in OVER_BUDGET:
            continue
        ref = power.reference_of(check)
        assert detectable_bias(ref.mean, ref.var, ref.n, check.spp, alpha=grading.ALPHA) < 0.016


def test_check_spp_defaults_to_the_old_constant():
    check = grading.Check("x", "path", "quad-light", (("mean", 1),), 10)
    assert check.spp == grading.SPP == 64
    assert all(c.spp >= grading.SPP and c.spp % 64 == 0 for c in grading.CHECKS)
    assert not math.isnan(grading.ALPHA)


@pytest.mark.parametrize("check", grading.LIGHT_CHECKS, ids=[c.id for c in grading.LIGHT_CHECKS])
def test_light_check_detects_a_bias_of_one_and_a_half_percent(check):
    """The light tracer's mean test has tiles only (its pixels are correlated across the image):
    its analytic bound (tile_detectable_bias, a lower bound on the power) meets the 1.5 %
    target, and at that bound at least the lower ALPHA-quantile of Binomial(50, 0.95) of 50
    injected renders per sign fail, as they do with probability >= 1 - ALPHA if it holds."""
    ref = power.reference_of(check)
    level = grading.alpha_of(check)
    need = int(sps.binom.ppf(ALPHA, 50, 0.95))
    for sign in (1, -1):
        b = power.tile_detectable_bias(ref.mean, ref.var, ref.n, check.spp, alpha=level, sign=sign)
        assert b <= power.TARGET_BIAS, f"{check.id}: {100 * b:.2f} % at {check.spp} spp"
        rate = power.injected_power(sign * b, ref.mean, ref.var, ref.n, check.spp, alpha=level,
                                    seeds=50, seed=11 + (sign > 0), image_components=False)
        assert round(rate * 50) >= need, (check.id, sign, b, rate)
