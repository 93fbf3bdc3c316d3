r"""How large a global bias the mean test detects: analytic power of its whole-image component.

A submission whose image is :math:`(1+b)` times the truth everywhere shifts the whole-image
mean of channel :math:`c` by :math:`b\,\mu_c`.  :func:`mitsuba_refs.stats.compare_means`
tests the whole-image means with

.. math:: z_c = \frac{\bar a_c - \bar b_c}{\sqrt{s_{a,c}^2 + s_{b,c}^2}},\qquad
          s_{a,c}^2 = \frac{1}{P^2}\sum_p \frac{v^a_{pc}}{n_a},\quad
          s_{b,c}^2 = \frac{1}{P^2}\sum_p \frac{v^b_{pc}}{n_b},

(``P`` pixels) and rejects when :math:`\max_c |z_c|` exceeds the critical value of its share of
the level.  With :math:`2^{18}` or more samples per image, :math:`z_c` is normal with mean

.. math:: \delta_c(b) = \frac{b\,\mu_c}{\sqrt{\rho(1+b)^2 \sigma_c^2/n_a + \sigma_c^2/n_b}},
          \qquad \sigma_c^2 = \frac{1}{P^2}\sum_p v^b_{pc},

where :math:`\rho` is the test estimator's variance relative to the reference's (1 for the
same estimator), and the reference's own noise (the :math:`1/n_b` term) is counted: it stays
whatever the test's sample count.

Two simplifications make the result an *upper bound* on the detectable bias (the real test
is at least this powerful):

* the critical value is the one for independent channels (the largest possible: the test
  itself uses the estimated channel correlation, which lowers it);
* the power is that of the single best channel, :math:`P(|Z+\delta_{max}| \ge z^*)`, and the
  tile component (which also reacts to a global bias) is ignored.

Pure functions, no I/O.  :mod:`autograder.power` applies them to the graded checks.
"""
from __future__ import annotations

import math

import numpy as np
from scipy import special

from ._tiles import sidak_per_test
from .mean import tile_z

__all__ = ["image_mean_se", "image_critical_z", "bias_power", "detectable_bias", "spp_for_bias",
           "gross_error_bound", "tile_gross_error_bound"]


def image_mean_se(ref_var, n) -> np.ndarray:
    r"""Standard error of each channel's whole-image mean for per-sample variances ``ref_var``
    (H, W, C) at ``n`` samples per pixel: :math:`\sqrt{\sum_p v_p / n} / P`."""
    v = np.maximum(np.asarray(ref_var, dtype=np.float64), 0.0)
    if v.ndim == 2:
        v = v[..., None]
    pixels = v.shape[0] * v.shape[1]
    return np.sqrt(v.sum(axis=(0, 1)) / float(n)) / pixels


def image_critical_z(alpha: float, *, components: int = 3, channels: int = 3) -> float:
    """Largest |z| the image component of the mean test may reach without rejecting.

    ``alpha`` is the whole mean test's level; it is split by Šidák over ``components``
    (tiles, image, bounded-variance image: 3) and, conservatively, over independent
    ``channels``.
    """
    level = sidak_per_test(sidak_per_test(alpha, components), channels)
    return float(-special.ndtri(level / 2))


def bias_power(b: float, ref_mean, ref_var, ref_n, n_test, *, alpha: float,
               variance_ratio: float = 1.0, components: int = 3) -> float:
    """Lower bound on the chance that the mean test rejects an image ``(1+b)`` times the truth.

    Parameters
    ----------
    b : float
        Relative global bias (> -1).
    ref_mean, ref_var : array (H, W, C)
        The reference's per-pixel mean and per-sample variance (taken as the truth).
    ref_n, n_test : float
        Samples per pixel of the reference and of the test render.
    alpha : float
        Level of the whole mean test.
    variance_ratio : float
        Test estimator's per-sample variance / the reference's (1: same estimator).
    components : int
        Components of the mean test's family (see :func:`image_critical_z`).
    """
    mu = np.asarray(ref_mean, dtype=np.float64)
    mu = (mu if mu.ndim == 3 else mu[..., None]).mean(axis=(0, 1))
    se_ref = image_mean_se(ref_var, ref_n)
    se_test = image_mean_se(ref_var, n_test) * math.sqrt(variance_ratio) * abs(1.0 + b)
    se = np.sqrt(se_ref ** 2 + se_test ** 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        delta = np.where(se > 0, np.abs(b * mu) / se, np.where(b * mu != 0, np.inf, 0.0))
    best = float(np.max(delta))
    crit = image_critical_z(alpha, components=components, channels=mu.size)
    if math.isinf(best):
        return 1.0
    # P(|Z + delta| >= crit) = Φc(crit - delta) + Φc(crit + delta)
    return float(0.5 * (special.erfc((crit - best) / math.sqrt(2))
                        + special.erfc((crit + best) / math.sqrt(2))))


def detectable_bias(ref_mean, ref_var, ref_n, n_test, *, alpha: float, power: float = 0.95,
                    variance_ratio: float = 1.0, components: int = 3, sign: int = +1) -> float:
    """Smallest relative bias ``|b|`` (sign ``sign``) detected with probability >= ``power``.

    Upper bound (see the module notes); ``inf`` when even ``b = -1`` or ``b = 1e6`` is not
    detected (a noiseless-but-black image).  Parameters as for :func:`bias_power`.
    """
    if sign not in (-1, 1):
        raise ValueError("sign must be +1 or -1")
    if not 0.0 < power < 1.0:
        raise ValueError("power must be in (0, 1)")

    def enough(size):
        return bias_power(sign * size, ref_mean, ref_var, ref_n, n_test, alpha=alpha,
                          variance_ratio=variance_ratio, components=components) >= power

    hi = 1.0 - 1e-12 if sign < 0 else 1e6
    if not enough(hi):
        return math.inf
    lo = 0.0
    for _ in range(100):        # the power grows monotonically with |b| on either side
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if enough(mid) else (mid, hi)
        if hi - lo < 1e-7:
            break
    return hi


def spp_for_bias(target: float, ref_mean, ref_var, ref_n, *, alpha: float, power: float = 0.95,
                 variance_ratio: float = 1.0, components: int = 3, step: int = 64,
                 max_spp: int = 1 << 16) -> int | None:
    """Smallest multiple of ``step`` samples per pixel at which both a bias of ``+target`` and
    one of ``-target`` are detected with probability >= ``power``; None if no count up to
    ``max_spp`` suffices (the reference's own noise alone is too large)."""
    def ok(n):
        return all(detectable_bias(ref_mean, ref_var, ref_n, n, alpha=alpha, power=power,
                                   variance_ratio=variance_ratio, components=components,
                                   sign=s) <= target for s in (1, -1))
    if not ok(max_spp):
        return None
    lo, hi = 0, max_spp // step           # ok(hi * step) holds; find the smallest such
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if ok(mid * step) else (mid, hi)
    return hi * step


def gross_error_bound(ref_mean, ref_var, ref_n, n_test, *, alpha: float, max_var_ratio: float,
                      components: int = 3) -> float:
    r"""Relative image-mean deviation that the bounded-variance component always rejects.

    Whatever the test side's own variance, an observed image :math:`(1+r)` times the
    reference's with :math:`|r|` at least this value is rejected:
    :math:`|r|\,\bar b_c \ge z^* \sqrt{K\sum_p v_{pc}/n_a + \sum_p v_{pc}/n_b}/P` in some
    channel (``K = max_var_ratio``, :math:`z^*` as in :func:`image_critical_z`; the rel_floor
    term, 1e-5, is neglected).  A deterministic guarantee on the observed image, not a power.
    """
    mu = np.asarray(ref_mean, dtype=np.float64)
    mu = (mu if mu.ndim == 3 else mu[..., None]).mean(axis=(0, 1))
    se = np.sqrt(max_var_ratio * image_mean_se(ref_var, n_test) ** 2
                 + image_mean_se(ref_var, ref_n) ** 2)
    crit = image_critical_z(alpha, components=components, channels=mu.size)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(se > 0, np.abs(mu) / se, np.where(mu != 0, np.inf, 0.0))
    best = float(np.max(ratio))
    return math.inf if best == 0 else crit / best


def tile_gross_error_bound(ref_mean, ref_var, ref_n, n_test, *, alpha: float,
                           max_var_ratio: float, tile: int = 8, components: int = 2) -> float:
    r"""Relative deviation that the tiles' bounded-variance component always rejects.

    The tiles-only mean test (``compare_means(..., image_components=False,
    max_var_ratio=K)``) rejects an observed image whose tile means are :math:`(1+r)` times the
    reference's with :math:`|r|` at least this value, whatever the test side's own variance:
    in the tile and channel with the largest :math:`\bar b / \mathrm{se}` the bounded
    :math:`|z|` reaches the Bonferroni critical value over ``components``, tiles and channels
    (at least the test's own critical value, so the guarantee holds). The z is
    :func:`mitsuba_refs.stats.mean.tile_z`'s with the test side's variance ``K`` times the
    reference's (rel_floor neglected). A deterministic guarantee on the observed image, not a
    power.
    """
    mu = np.asarray(ref_mean, dtype=np.float64)
    var = np.maximum(np.asarray(ref_var, dtype=np.float64), 0.0)
    # The bounded z of an image twice the reference's (r = 1) is each tile's mean / se.
    z, informative = tile_z(2.0 * mu, max_var_ratio * var, n_test, mu, var, ref_n, tile,
                            rel_floor=0.0)
    m = max(int(informative.any(axis=2).sum()), 1)
    crit = float(-special.ndtri(sidak_per_test(alpha, components) / (2 * z.shape[2] * m)))
    best = float(np.max(np.abs(z)))
    return math.inf if best == 0 else crit / best
