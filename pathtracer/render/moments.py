"""Per-pixel moments: a block's (n, mean, M2), Chan's merge of blocks, filtered sums.

A block's sums are shifted by each pixel's first sample (so equal samples give a
variance of exactly zero), and blocks merge in order with Chan's formula.
"""

from __future__ import annotations

import numpy as np


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
    the pixel's effective sample count ``n_eff`` (:func:`pathtracer.film.effective_counts`):
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


def pixel_statistics(n_pixels: int, channels: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Empty running statistics: count (n_pixels, 1) and mean, M2 as (2, n_pixels, channels)."""
    return np.zeros((n_pixels, 1)), np.zeros((2, n_pixels, channels))


def mean_and_variance(stats) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel mean and sample variance; M2 becomes the variance in place (no third image)."""
    count, (mean, m2) = stats
    m2 /= np.maximum(count - 1, 1)
    return mean, m2


def merge_block(stats, unit, block) -> None:
    """Chan et al.'s parallel update of (count, mean, M2) for the unit's pixels."""
    p0, p1 = unit[0], unit[1]
    n_b, mean_b, m2_b = block
    count, (mean, m2) = stats[0][p0:p1], stats[1][:, p0:p1]
    n_a = count
    total = n_a + n_b
    delta = mean_b - mean
    mean += delta * (n_b / total)
    m2 += m2_b + delta * delta * (n_a * n_b / total)
    count += n_b
