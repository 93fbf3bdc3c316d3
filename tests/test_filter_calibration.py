"""Calibration of the mean and variance tests on filtered films (tent, gaussian).

Simulated renders (mitsuba_refs.stats.simulate_filtered): every sample of the moderate
scene of tests/test_stats_calibration.py lands at a uniform position in its pixel and is
splatted through the filter by the tracer's own film code; a test and a reference render of
the same scene are compared as ``compare()`` does, with and without the correction for
correlated pixels (mitsuba_refs.stats.correlation). docs/statistics.md has the 400-seed
measurement; here 80 seeds per filter at alpha = 0.2, Binomial acceptance intervals with
coverage 1 - 1e-5 (as tests/test_stats_calibration.py).
"""
import numpy as np
import pytest
from scipy import stats as sps

from mitsuba_refs.stats import MeanTestOptions, VarianceTestOptions, compare_means, compare_variances
from mitsuba_refs.stats.correlation import pixel_correlation
from mitsuba_refs.stats.simulate import make_scene
from mitsuba_refs.stats.simulate_filtered import render_filtered
from pathtracer.sensors.film import ReconstructionFilter

COVER = 1 - 1e-5
SEEDS, N_TEST, N_REF, ALPHA = 80, 4, 32, 0.2


def _p_values(kind):
    rfilter = ReconstructionFilter.make(kind)
    correlation = pixel_correlation(rfilter)
    scene = make_scene(32, 32, seed=3, p_range=(0.1, 0.6))
    rng = np.random.default_rng(17)
    rows = []
    for _ in range(SEEDS):
        ma, va = render_filtered(scene, rfilter, N_TEST, rng)
        mb, vb = render_filtered(scene, rfilter, N_REF, rng)
        mean = compare_means(ma, va, N_TEST, mb, vb, N_REF, alpha=ALPHA, max_var_ratio=4,
                             options=MeanTestOptions(pixel_correlation=correlation))
        var = compare_variances(va, N_TEST, vb, N_REF, alpha=ALPHA,
                                options=VarianceTestOptions(pixel_correlation=correlation))
        naive = compare_variances(va, N_TEST, vb, N_REF, alpha=ALPHA)
        rows.append((mean.p_value, var.p_value, naive.p_value))
    return np.array(rows)


@pytest.mark.parametrize("kind", ["tent", "gaussian"])
def test_false_rejections_of_filtered_films(kind):
    p = _p_values(kind)
    lo, hi = (int(v) for v in sps.binom.interval(COVER, SEEDS, ALPHA))
    mean_k, var_k, naive_k = (int(np.sum(p[:, i] <= ALPHA)) for i in range(3))
    print(f"{kind}: mean {mean_k}/{SEEDS}, variance {var_k}/{SEEDS}, variance as if "
          f"pixels were independent {naive_k}/{SEEDS}; acceptance [{lo}, {hi}]")
    assert lo <= mean_k <= hi
    assert var_k <= hi            # the per-tile component is conservative
    # Without the correction the per-tile variance check takes correlated pixels for
    # independent ones and rejects correct renders far too often.
    assert naive_k > hi
