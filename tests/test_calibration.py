"""Calibration and power of the verdicts on real renders of the correct tracer.

Calibration: the correct ``path`` integrator (same estimator as Mitsuba's
``path``) is rendered with 200 independent seeds and compared with the
committed reference at a nominal alpha of 0.05. If the tests are calibrated,
the number of rejections is Binomial(200, 0.05); the assertion accepts the
central interval of that law with coverage 1 - 1e-6, so this test itself
fails a correct tracer with probability < 1e-6. A test miscalibrated like the
per-pixel z test (~70 % false rejections, docs/statistics.md) is far outside it.

Power: a 2 % global bias and a 3 % bias confined to a 16x16 region (at 1024
spp, where a region's standard error is ~0.6 %) must be rejected at the
suite's per-test alpha.
"""
import numpy as np
import pytest
from scipy import stats

from mitsuba_refs.reference.cache import get_reference
from mitsuba_refs.report.wording import verdict_line
from mitsuba_refs.stats import VARIANCE_BOUND, compare_means, compare_variances
from mitsuba_refs.verdicts.scenes import default_params, render_ours
from tests.budget import ALPHA

pytestmark = pytest.mark.statistical(assertions=1)

SEEDS = 200
NOMINAL = 0.05
SCENE, INTEGRATOR, SPP = "cornell-box", "path", 8


def binomial_acceptance(n, p, coverage=1 - 1e-6):
    """Central interval of Binomial(n, p) with at least ``coverage`` probability."""
    tail = (1 - coverage) / 2
    return stats.binom.ppf(tail, n, p), stats.binom.isf(tail, n, p)


@pytest.fixture(scope="module")
def reference():
    return get_reference(SCENE, default_params(SCENE), INTEGRATOR, render=False)


@pytest.fixture(scope="module")
def correct_renders():
    params = default_params(SCENE)
    return [render_ours(SCENE, INTEGRATOR, params, SPP, 50_000 + seed, processes=2)
            for seed in range(SEEDS)]


def test_mean_test_false_rejection_rate_is_nominal(reference, correct_renders):
    rejections = sum(not compare_means(mean, var, SPP, reference.mean, reference.var, reference.n,
                                       alpha=NOMINAL).agree for mean, var in correct_renders)
    low, high = binomial_acceptance(SEEDS, NOMINAL)
    assert low <= rejections <= high, f"{rejections}/{SEEDS} rejections at alpha {NOMINAL}"


def test_mean_test_with_variance_bound_false_rejection_rate(reference, correct_renders):
    """The grader's mean test (with the bounded-variance image component, K = 4): rejections
    of the correct tracer at alpha 0.05 at most the upper end of the same interval (the extra
    component only splits alpha three ways: conservative, not liberal)."""
    rejections = sum(not compare_means(mean, var, SPP, reference.mean, reference.var, reference.n,
                                       alpha=NOMINAL, max_var_ratio=VARIANCE_BOUND).agree
                     for mean, var in correct_renders)
    low, high = binomial_acceptance(SEEDS, NOMINAL)
    print(f"{rejections}/{SEEDS} rejections with the variance bound at alpha {NOMINAL}")
    assert rejections <= high, f"{rejections}/{SEEDS} rejections at alpha {NOMINAL}"


def test_variance_test_false_rejection_rate_is_nominal(reference, correct_renders):
    rejections = sum(not compare_variances(var, SPP, reference.var, reference.n,
                                           alpha=NOMINAL).agree for _, var in correct_renders)
    low, high = binomial_acceptance(SEEDS, NOMINAL)
    assert low <= rejections <= high, f"{rejections}/{SEEDS} rejections at alpha {NOMINAL}"


@pytest.fixture(scope="module")
def deep_render():
    return render_ours(SCENE, INTEGRATOR, default_params(SCENE), 1024, 60_000, processes=2)


def test_two_percent_global_bias_is_rejected(reference, deep_render):
    mean, var = deep_render
    assert compare_means(mean, var, 1024, reference.mean, reference.var, reference.n,
                         alpha=ALPHA).agree
    biased = compare_means(mean * 1.02, var * 1.02 ** 2, 1024, reference.mean, reference.var,
                           reference.n, alpha=ALPHA)
    assert not biased.agree, verdict_line(biased)
    assert 0.01 < biased.rel_bias < 0.03


def test_three_percent_regional_bias_is_rejected(reference, deep_render):
    mean, var = deep_render
    mean, var = mean.copy(), var.copy()
    region = np.s_[24:40, 8:24]          # 16x16 pixels on the red wall and floor
    mean[region] *= 1.03
    var[region] *= 1.03 ** 2
    result = compare_means(mean, var, 1024, reference.mean, reference.var, reference.n, alpha=ALPHA)
    assert not result.agree, verdict_line(result)
    worst_row, worst_col = result.worst_tile[0], result.worst_tile[1]
    assert 3 <= worst_row <= 4 and 1 <= worst_col <= 2, verdict_line(result)
