"""Measured rejection rates: how sure a calibration run of ``n`` repetitions is of its rate."""
from __future__ import annotations

from scipy import stats

__all__ = ["clopper_pearson"]


def clopper_pearson(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """Exact (Clopper-Pearson) confidence interval of a binomial rate.

    Parameters
    ----------
    k, n : int
        Successes (e.g. false rejections) in ``n`` independent trials, ``0 <= k <= n``.
    level : float
        Coverage of the interval.

    Returns
    -------
    (float, float)
        Lower and upper bound of the rate; 0 and 1 where ``k`` is 0 or ``n``.
    """
    tail = (1 - level) / 2
    low = stats.beta.ppf(tail, k, n - k + 1) if k > 0 else 0.0
    high = stats.beta.ppf(1 - tail, k + 1, n - k) if k < n else 1.0
    return float(low), float(high)
