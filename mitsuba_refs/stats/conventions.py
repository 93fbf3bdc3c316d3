r"""Differences of convention: image transforms and their estimates (pure functions on arrays).

A renderer can be right and still disagree with Mitsuba because it follows another
convention: its lights in other units (a factor pi, 2, 4 pi), a white balance, an sRGB or
gamma-encoded output, values clamped at 1, the image flipped or shifted by a pixel or by half
of one. Each
convention here is an *inverse*: what turns the renderer's image back into Mitsuba's
convention, so that the same mean test can be run again on the corrected image
(:mod:`mitsuba_refs.verdicts.conventions` does that and decides what to name). A half-pixel
shift cannot be undone on the test image; the reference is moved instead
(:func:`half_shifted`).

Means and per-sample variances transform together. A transform ``f`` applied to a pixel mean
changes the variance of the mean by ``f'(x)^2`` (the delta method; exact for the linear ones:
factors, gains, flips and shifts). Nonlinear ones (sRGB, gamma) are exact only when they are
applied to each independent image before its moments are taken, which is what
:mod:`mitsuba_refs.verdicts.conventions` does for replicas without variance channels.

How much of the error a correction explains is measured by the tiles' chi-square,
:func:`tile_chi_square`: the mean squared tile z of a mean test (about 1 when the two images
agree). A correction explains an error when it brings that from far above the noise
(:func:`explains`) down to it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._tiles import tile_counts, tile_sums

__all__ = ["GLOBAL_FACTORS", "GAMMA", "srgb_encode", "gamma_encode", "srgb_decode", "srgb_decode_slope", "gamma_decode",
           "gamma_decode_slope", "flipped", "shifted", "half_shifted", "ChannelGains", "channel_gains",
           "clamp_ceiling", "clamp_mask", "tile_chi_square", "explains", "masked"]

#: Global factors between a renderer's units and Mitsuba's: pi (radiance against radiant
#: exitance, rho against rho/pi), 2 (one- against two-sided lights or surfaces), 4 pi (a point
#: light's intensity against its power), each both ways.
GLOBAL_FACTORS = (math.pi, 1 / math.pi, 2.0, 0.5, 4 * math.pi, 1 / (4 * math.pi))
#: The exponent of a plain gamma encoding (the one before sRGB, still common in LDR output).
GAMMA = 2.2
#: Fewest pixel-channels at exactly the largest value before it is taken for a ceiling: one
#: or two maxima are ordinary noise, four identical ones are not.
MIN_CLAMPED = 4
#: Relative tolerance of "at the ceiling" (float32 rounding of a replica mean of 1.0s).
CEILING_TOLERANCE = 1e-6


def srgb_encode(linear):
    """sRGB-encoded values of linear ones (what a display image stores; the inverse of
    :func:`srgb_decode`, for tests and injections)."""
    x = np.asarray(linear, dtype=np.float64)
    curve = 1.055 * np.power(np.maximum(x, 0.0), 1 / 2.4) - 0.055
    return np.where(x <= 0.0031308, 12.92 * x, curve)


def gamma_encode(linear, gamma: float = GAMMA):
    """``x ** (1 / gamma)`` (negative values clipped to 0): the inverse of :func:`gamma_decode`."""
    return np.power(np.maximum(np.asarray(linear, dtype=np.float64), 0.0), 1 / gamma)


def srgb_decode(encoded):
    """Linear values of sRGB-encoded ones (IEC 61966-2-1's curve; negatives stay linear)."""
    x = np.asarray(encoded, dtype=np.float64)
    curve = np.power(np.maximum(x + 0.055, 0.0) / 1.055, 2.4)
    return np.where(x <= 0.04045, x / 12.92, curve)


def srgb_decode_slope(encoded):
    """The derivative of :func:`srgb_decode` (for the variance of a decoded mean)."""
    x = np.asarray(encoded, dtype=np.float64)
    curve = 2.4 / 1.055 * np.power(np.maximum(x + 0.055, 0.0) / 1.055, 1.4)
    return np.where(x <= 0.04045, 1.0 / 12.92, curve)


def gamma_decode(encoded, gamma: float = GAMMA):
    """Linear values of gamma-encoded ones, ``x ** gamma`` (negative values clipped to 0)."""
    return np.power(np.maximum(np.asarray(encoded, dtype=np.float64), 0.0), gamma)


def gamma_decode_slope(encoded, gamma: float = GAMMA):
    """The derivative of :func:`gamma_decode`."""
    return gamma * np.power(np.maximum(np.asarray(encoded, dtype=np.float64), 0.0), gamma - 1)


def flipped(image, vertical: bool):
    """``image`` (H, W, ...) upside down (``vertical``) or mirrored left-right."""
    image = np.asarray(image)
    return image[::-1] if vertical else image[:, ::-1]


def shifted(image, dy: int, dx: int):
    """``image`` moved by ``(dy, dx)`` pixels: ``out[y, x] = image[y - dy, x - dx]``.

    Returns
    -------
    out : ndarray like ``image``
        Zero where nothing moved in.
    valid : ndarray of bool (H, W)
        The pixels that hold a moved value.
    """
    image = np.asarray(image, dtype=np.float64)
    h, w = image.shape[:2]
    out = np.zeros_like(image)
    valid = np.zeros((h, w), dtype=bool)
    ys, yd = (slice(0, h - dy), slice(dy, h)) if dy >= 0 else (slice(-dy, h), slice(0, h + dy))
    xs, xd = (slice(0, w - dx), slice(dx, w)) if dx >= 0 else (slice(-dx, w), slice(0, w + dx))
    out[yd, xd] = image[ys, xs]
    valid[yd, xd] = True
    return out, valid


def half_shifted(mean, variance, dy: int, dx: int):
    """A reference image moved by half a pixel in direction ``(dy, dx)`` (one of them +-1, the
    other 0): each pixel the average of itself and its neighbour at ``(-dy, -dx)``, which is
    the integral over the pixel moved by half when the radiance is linear across the two
    pixels (at a sharp edge within a pixel it is not: docs/external.md gives what that costs).

    Parameters
    ----------
    mean, variance : array (H, W, C)
        The reference's per-pixel mean and per-sample variance.

    Returns
    -------
    mean, variance : ndarray (H, W, C)
        The moved image and the per-sample variance of its mean (two pixels' independent
        samples averaged: a quarter of their sum).
    valid : ndarray of bool (H, W)
        Pixels whose neighbour exists.
    """
    neighbour, valid = shifted(mean, dy, dx)
    neighbour_variance, _ = shifted(variance, dy, dx)
    return (np.asarray(mean) + neighbour) / 2, (np.asarray(variance) + neighbour_variance) / 4, valid


@dataclass(frozen=True)
class ChannelGains:
    """Per-channel brightness of a test image against a reference (white balance).

    Attributes
    ----------
    gains : ndarray (C,)
        Test image mean over reference image mean, per channel.
    log_se : ndarray (C,)
        Standard error of each ``log(gain)`` (delta method, both images' noise).
    spread_z : float
        The largest difference of two channels' log gains over its standard error (the
        Cauchy-Schwarz bound ``se_i + se_j``, as the channels' noise is correlated): how far
        the gains are from one common factor.
    """

    gains: np.ndarray
    log_se: np.ndarray
    spread_z: float

    @property
    def spread(self) -> float:
        """The largest gain over the smallest, minus 1."""
        return float(self.gains.max() / self.gains.min() - 1.0)


def channel_gains(mean_a, var_a, n_a, mean_b, var_b, n_b, tile: int = 8) -> ChannelGains:
    """The gains that map the reference's channels onto the test's.

    Each channel's gain is the inverse-variance weighted least-squares fit of the test's tile
    means on the reference's, :math:`g = \\sum_T A_T B_T/s_T^2 / \\sum_T B_T^2/s_T^2` with
    :math:`s_T^2` the two tile means' variances: a ratio of image means would be carried by the
    brightest, noisiest pixels (a visible light), whose chance excess then shows as a bias in
    every other tile once divided out.

    Parameters
    ----------
    mean_a, var_a, mean_b, var_b : array (H, W, C)
        Test and reference per-pixel means and per-sample variances.
    n_a, n_b : int
        Their samples per pixel.
    tile : int
        Tile edge in pixels (the mean test's).
    """
    a, b = (np.asarray(x, np.float64) for x in (mean_a, mean_b))
    h, w = a.shape[:2]
    count = tile_counts(h, w, tile)[..., None]
    tile_a, tile_b = tile_sums(a, tile) / count, tile_sums(b, tile) / count
    spread = (tile_sums(np.maximum(var_a, 0.0), tile) / n_a
              + tile_sums(np.maximum(var_b, 0.0), tile) / n_b) / count ** 2
    # Tiles without noise (black on both sides) carry no weight; a noiseless tile that is
    # not black gets the smallest noise of the others, not an infinite weight.
    positive = spread[spread > 0]
    floor = float(positive.min()) if positive.size else 1.0
    weight = np.where((spread > 0) | (tile_b != 0), 1.0 / np.maximum(spread, floor), 0.0)
    information = (weight * tile_b ** 2).sum(axis=(0, 1))
    with np.errstate(divide="ignore", invalid="ignore"):
        gains = np.where(information > 0, (weight * tile_a * tile_b).sum(axis=(0, 1)) / information,
                         np.nan)
        log_se = 1.0 / np.sqrt(information) / gains
    spread_z = 0.0
    channels = gains.shape[0]
    for i in range(channels):
        for j in range(i + 1, channels):
            z = abs(math.log(gains[i] / gains[j])) / (log_se[i] + log_se[j]) \
                if gains[i] > 0 and gains[j] > 0 else math.nan
            spread_z = max(spread_z, z) if math.isfinite(z) else math.nan
    return ChannelGains(gains, log_se, float(spread_z))


def clamp_ceiling(mean, min_clamped: int = MIN_CLAMPED) -> float:
    """The value a clamped image is clamped at: its largest value when at least
    ``min_clamped`` pixel-channels hold it; NaN otherwise (no sign of clamping)."""
    values = np.asarray(mean, dtype=np.float64)
    top = float(values.max()) if values.size else 0.0
    if not top > 0:
        return math.nan
    at_top = int(np.count_nonzero(values >= top * (1 - CEILING_TOLERANCE)))
    return top if at_top >= min_clamped else math.nan


def clamp_mask(mean, reference, ceiling: float, reference_noise):
    """Pixels a clamp at ``ceiling`` can have changed: any channel of the test at the ceiling,
    or of the reference within ``reference_noise`` (an (H, W, C) spread, e.g. 4 standard
    deviations of a test replica) of it. (H, W) bool."""
    at_ceiling = np.asarray(mean) >= ceiling * (1 - CEILING_TOLERANCE)
    near = np.asarray(reference) + np.asarray(reference_noise) >= ceiling
    return (at_ceiling | near).any(axis=2)


def masked(image, mask):
    """``image`` with the pixels of ``mask`` (H, W) set to 0 (None: unchanged). Both sides of a
    mean test masked alike leave those pixels out of it: tiles whose pixels are all 0 with no
    variance carry no evidence, and zeros add nothing to either image mean."""
    if mask is None:
        return image
    return np.where(np.asarray(mask)[..., None], 0.0, image)


def tile_chi_square(z_tiles) -> float:
    """Mean squared tile z over the tile-channels that carry evidence (z exactly 0 is a tile
    without any): about 1 when two images agree, inf when a deterministic difference made a
    z infinite, 0 when no tile carries evidence."""
    z = np.asarray(z_tiles, dtype=np.float64)
    informative = z[z != 0]
    return float(np.mean(informative ** 2)) if informative.size else 0.0


def explains(before: float, after: float, min_ratio: float) -> bool:
    """Whether a correction that took the tiles' chi-square from ``before`` to ``after``
    explains the error: it falls by at least ``min_ratio`` and ends within the noise of an
    agreement (both are mean squared z: 1 under agreement)."""
    if not math.isfinite(after):
        return False
    return before >= min_ratio * max(after, 1.0)
