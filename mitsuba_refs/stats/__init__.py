"""Calibrated statistics for comparing Monte Carlo renders (pure functions on arrays).

* :func:`compare_means`      -- same expected image? (tiled z tests + image mean, bias with CI)
* :func:`compare_variances`  -- same per-sample variance? (kurtosis-robust tile t test), and
  the one-sided policy "not more than X times the reference's"
* :func:`detectable_bias`    -- the smallest global bias the mean test detects (power;
  :mod:`.detectable` is the home of that math)
* :func:`convergence_law`    -- does RMSE fall as N^-1/2? (slope, ratio, bias floor, correlation)
* :func:`first_diverging_bounce` -- which max_depth breaks first
* :func:`per_test_alpha`, :class:`ErrorBudget` -- the suite-wide false-failure budget
* :func:`clopper_pearson`    -- the exact interval of a rejection rate measured in calibration runs

Results are frozen objects of numbers (p-values, intervals, flags, counts, tile indices); the
words of the verdicts are in :mod:`mitsuba_refs.report.wording`.

See docs/statistics.md for the assumptions and the measured calibration.
"""
from .bounce import depth_order, first_diverging_bounce
from .budget import SUITE_ALPHA, ErrorBudget, per_test_alpha, suite_false_failure
from .convergence import (
                          MIN_EFFECTIVE_ROWS,
                          ConvergenceResult,
                          convergence_law,
                          effective_rows,
                          image_mse,
                          image_mse_parts,
                          rare_errors_dominate,
                          reference_mse_floor,
)
from .detectable import bias_power, detectable_bias, spp_for_bias
from .mean import VARIANCE_BOUND, MeanAgreement, MeanTestOptions, compare_means, tile_z
from .rates import clopper_pearson
from .variance import MAX_VARIANCE_RATIO, VarianceAgreement, VarianceTestOptions, compare_variances

__all__ = [
    "MeanAgreement", "MeanTestOptions", "compare_means", "tile_z", "VARIANCE_BOUND",
    "VarianceAgreement", "VarianceTestOptions", "compare_variances", "MAX_VARIANCE_RATIO",
    "bias_power", "detectable_bias", "spp_for_bias",
    "ConvergenceResult", "convergence_law", "effective_rows", "image_mse", "image_mse_parts",
    "rare_errors_dominate",
    "reference_mse_floor", "MIN_EFFECTIVE_ROWS",
    "depth_order", "first_diverging_bounce",
    "SUITE_ALPHA", "ErrorBudget", "per_test_alpha", "suite_false_failure", "clopper_pearson",
]
