r"""Per-pixel moments: the one home of the sample mean and variance of every pixel.

A pixel's samples are summarised in one of three ways, each where its samples come from:

* **Count, mean and M2** (the sum of squared deviations from the mean), per block of
  samples; blocks merge with Chan et al.'s formula, single samples with Welford's. The
  camera integrators' renders (:func:`block_statistics`, :func:`merge_block`), the light
  tracer's replicas (:func:`add_sample`) and the Mitsuba batch references
  (:func:`two_pass_block_statistics`, :func:`merge_statistics`).
* **Power sums or means**, :math:`\sum f` and :math:`\sum f^2` (or both over :math:`n`):
  the strategy images of :mod:`.strategies`, where a strategy missing from a replica
  adds nothing (:func:`mean_and_variance_from_sums`), and the Mitsuba ``rgb_moments``
  film (:func:`combine_power_means`, :func:`variance_from_power_means`).
* **Filter-weighted sums**, :math:`\sum w`, :math:`\sum w f`, :math:`\sum w f^2`, of a
  film with a tent or gaussian filter (:func:`filtered_mean_and_variance`).

Where two users compute the same statistic in different arithmetic (a block's sums
shifted by its first sample or taken around its mean; the order of the additions in
Chan's merge), both versions are kept: each user's images and references (the committed
ones included, compared bit for bit) depend on the rounding of its own arithmetic.
"""

from __future__ import annotations

import numpy as np

# ---------------------------------------------------------------- count, mean and M2


def block_statistics(x: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
    """(n, mean, M2) per pixel of samples ``x`` shaped (pixels, n, 3).

    Sums are shifted by each pixel's first sample, so identical samples give
    M2 = 0 exactly and the mean equals the sample exactly.
    """
    n = x.shape[1]
    shift = x[:, :1, :]
    centred = np.ascontiguousarray((x - shift).transpose(0, 2, 1))   # (pixels, 3, n)
    s1 = centred.sum(axis=2)
    s2 = (centred * centred).sum(axis=2)
    mean = shift[:, 0, :] + s1 / n
    m2 = np.maximum(s2 - s1 * s1 / n, 0.0)
    return n, mean, m2


def two_pass_block_statistics(samples: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
    """(n, mean, M2) over axis 1 of ``samples``: the mean first, then M2 around it.

    The Mitsuba batch references' reduction (``samples`` (H, k, W, 3), ``k`` single
    samples of every pixel). Identical samples give M2 = 0 exactly, as with
    :func:`block_statistics`, whose shifted sums round differently.
    """
    n = samples.shape[1]
    mean = samples.mean(axis=1)
    m2 = ((samples - mean[:, None]) ** 2).sum(axis=1)
    return n, mean, m2


def pixel_statistics(n_pixels: int, channels: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Empty running statistics: count (n_pixels, 1) and mean, M2 as (2, n_pixels, channels)."""
    return np.zeros((n_pixels, 1)), np.zeros((2, n_pixels, channels))


def merge_block(stats, unit, block) -> None:
    """Chan et al.'s parallel update of (count, mean, M2) for the unit's pixels.

    ``stats`` are :func:`pixel_statistics`, updated in place over the unit's pixel range
    ``unit[0]:unit[1]``; M2 gains the block's M2 plus the correction term, added together
    first.
    """
    p0, p1 = unit[0], unit[1]
    n_b, mean_b, m2_b = block
    count, (mean, m2) = stats[0][p0:p1], stats[1][:, p0:p1]
    n_a = count
    total = n_a + n_b
    delta = mean_b - mean
    mean += delta * (n_b / total)
    m2 += m2_b + delta * delta * (n_a * n_b / total)
    count += n_b


def merge_statistics(a, b) -> tuple[int, np.ndarray, np.ndarray]:
    """Chan et al.'s merge of two (n, mean, M2) of the same pixels, into new arrays.

    ``b`` itself when ``a`` has no samples. M2 is ``M2_a + M2_b`` plus the correction term,
    added in that order (:func:`merge_block` adds the block's two terms first).
    """
    n_a, mean_a, m2_a = a
    n_b, mean_b, m2_b = b
    if n_a == 0:
        return b
    n = n_a + n_b
    delta = mean_b - mean_a
    return n, mean_a + delta * (n_b / n), m2_a + m2_b + delta * delta * (n_a * n_b / n)


def add_sample(count: int, mean: np.ndarray, m2: np.ndarray, value: np.ndarray) -> int:
    """Welford's update of running (count, mean, M2) with one more sample ``value``.

    ``mean`` and ``m2`` are updated in place; returns the new count.
    """
    count += 1
    delta = value - mean
    mean += delta / count
    m2 += delta * (value - mean)
    return count


def mean_and_variance(stats) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel mean and sample variance; M2 becomes the variance in place (no third image)."""
    count, (mean, m2) = stats
    m2 /= np.maximum(count - 1, 1)
    return mean, m2


# ---------------------------------------------------------------- power sums and means


def power_sums(n_pixels: int, channels: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Empty sums ``sum f`` and ``sum f^2``, (n_pixels, channels) each."""
    return np.zeros((n_pixels, channels)), np.zeros((n_pixels, channels))


def add_power_sums(sums, value: np.ndarray) -> None:
    """Add one sample ``value`` of every pixel to :func:`power_sums` (in place)."""
    first, second = sums
    first += value
    second += value * value


def mean_and_variance_from_sums(sums, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Mean ``sum f / n`` and unbiased variance ``(sum f^2 - n mean^2) / (n - 1)`` of ``n``
    samples, clipped at 0 (rounding can make it slightly negative where all samples agree)."""
    first, second = sums
    mean = first / n
    return mean, np.maximum(second - n * mean * mean, 0.0) / max(n - 1, 1)


def combine_power_means(passes) -> tuple[np.ndarray, np.ndarray, int]:
    """Passes ``[(m1, m2, n), ...]`` of means of f and f^2 over ``n`` samples each, combined
    into ``(m1, m2, n)`` over all samples (weighted by each pass's ``n``)."""
    n = sum(p[2] for p in passes)
    m1 = sum(p[0] * p[2] for p in passes) / n
    m2 = sum(p[1] * p[2] for p in passes) / n
    return m1, m2, n


def variance_from_power_means(m1: np.ndarray, m2: np.ndarray, n) -> np.ndarray:
    """Unbiased per-sample variance ``(m2 - m1^2) n / (n - 1)`` from the means of f and f^2
    over ``n`` samples (a number, or one per pixel), clipped at 0 (rounding can make it
    slightly negative where all samples agree)."""
    return np.maximum(m2 - m1 * m1, 0.0) * (n / (n - 1))


# ---------------------------------------------------------------- filter-weighted sums


def film_sums(n_pixels: int, channels: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Empty filter-weighted sums: ``sum w`` (n_pixels,), ``sum w f`` and ``sum w f^2``."""
    return np.zeros(n_pixels), np.zeros((n_pixels, channels)), np.zeros((n_pixels, channels))


def merge_sums(sums, unit, block) -> None:
    """Add a unit's block ``(lo, hi, sum w, sum w f, sum w f^2)`` to the film's sums over ``lo:hi``."""
    lo, hi, *parts = block
    for total, part in zip(sums, parts):
        total[lo:hi] += part


def filtered_mean_and_variance(sums, n_eff) -> tuple[np.ndarray, np.ndarray]:
    """Pixel value ``sum w f / sum w`` and per-sample variance of a filtered film.

    The variance is the weighted spread ``sum w f^2 / sum w - mean^2`` made unbiased with
    the pixel's effective sample count ``n_eff`` (:func:`pathtracer.sensors.film.effective_counts`):
    times ``n_eff / (n_eff - 1)``, which is ``n / (n - 1)`` for the box filter. Spreads
    within float64 rounding of zero (every sample equal) are set to exactly zero.
    """
    weight, wf, wf2 = sums
    w = np.maximum(weight, np.finfo(float).tiny)[:, None]
    mean, second = wf / w, wf2 / w
    spread = second - mean * mean
    spread[spread <= 16 * np.finfo(float).eps * np.abs(second)] = 0.0
    n_eff = np.asarray(n_eff, dtype=np.float64)
    return mean, spread * (n_eff / np.maximum(n_eff - 1, 1e-300))
