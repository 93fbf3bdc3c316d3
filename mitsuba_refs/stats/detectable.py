r"""What a comparison could see: the smallest global bias its mean test detects.

The closed forms at the end of these notes bound the power of the whole-image component
against a reference alone (the test side's variance a multiple of the reference's). A comparison knows
more: the test side's own per-sample variances and its sample count. :class:`MeanTestPower`
takes both sides and the mean test's configuration as :func:`mitsuba_refs.stats.compare_means`
was called (bounded variance or not, whole-image components or tiles only, the film's pixel
correlation) and gives the smallest relative bias :math:`|b|` whose image :math:`(1+b)` times
the truth the test rejects with probability ``power`` (0.95) at its level.

Every component is a two-sided z test of a difference :math:`D` whose real spread is
:math:`\sigma` and whose denominator is :math:`s`; for an image :math:`(1+b)` times the truth,
:math:`D \sim N(b\mu, \sigma^2)` and the component rejects in channel :math:`c` with
probability

.. math:: \pi_c(b) = \Phi^c\!\left(\frac{z^* s_c - |b\mu_c|}{\sigma_c}\right)
                   + \Phi^c\!\left(\frac{z^* s_c + |b\mu_c|}{\sigma_c}\right).

* **Image, own variance:** :math:`\sigma^2 = s^2 = (1+b)^2\sum_p v^a_{p}/(n_a P^2) +
  \sum_p v^b_{p}/(n_b P^2)`. With a tent or gaussian film ``v / n`` is each pixel's covariance
  row sum, so these sums stay the image mean's variance (docs/statistics.md, section 7): no
  correction is needed.
  With ``same_estimator`` the denominator's test term is the larger of that and the pooled
  one, :math:`\max(T, (n_a T + n_b R) / (n_a + n_b))` with :math:`T = (1+b)^2\sum_p v^a_p`,
  :math:`R = \sum_p v^b_p` (the test's heavy-tail guard, :mod:`mitsuba_refs.stats.mean`);
  :math:`\sigma` stays the real spread.
* **Image, bounded variance** (same estimator): the same :math:`\sigma`, and
  :math:`s^2 = K\sum_p v^b_p/(n_a P^2) + \sum_p v^b_p/(n_b P^2)` whatever the test's own.
* **Tiles** (own variance; in splatting renders, whose pixels are correlated across the
  image, the tiles decide alone): per ``tile`` x ``tile`` tile, the tile means' difference,
  with the share :math:`s_T` of the pixels' covariance row sums inside the tile
  (:meth:`~mitsuba_refs.stats.correlation.PixelCorrelation.within_tile_share`) and the
  denominator of :func:`mitsuba_refs.stats.mean.tile_z` (its no-hit guard included; tiles
  only, with ``max_var_ratio``, also the bounded tiles). The tiles are independent: the
  component rejects with probability :math:`1 - \prod_T (1 - \max_c \pi_{Tc})`. Where a
  few pixels carry most of the image's variance (a caustic, a glossy highlight of a small
  light) the image mean is noisy but the other tiles see a global bias clearly: on
  ``veach-mis`` (``path``, 64 spp) the tiles see 3.3 % where the image mean alone needs 29 %.

**Which pixels a bias moves.** A pixel that carries no noise on either side (its per-sample
variance below :data:`~mitsuba_refs.stats._tiles.REL_NOISE_FLOOR` of its squared mean: a
directly seen constant emitter, the environment, black) is deterministic, so the test
would see the smallest change of it; but what an estimator gets wrong is the light it
*samples*, and those pixels are the emitters' own values. So the bias is that of the sampled
light: the image is the truth with every noisy pixel :math:`(1+b)` times its value and the
noiseless pixels as they are. (Scaled with the rest, the constant environment of
``bsdf_twosided_cbox`` made the bound 0.0039 % beside a bias interval of ±0.1 %.)

The numerical floor of the real test (``rel_floor`` = 1e-5 of the mean) is added to
:math:`s` and :math:`\sigma`. Three simplifications make the result an **upper bound** on the
detectable bias (the real test is at least this powerful): the critical value :math:`z^*` is
Šidák's over the components, the tiles and *independent* channels (the test's
correlated-channel maximum has a smaller one); only the best channel of each component (tile)
counts; and the family's power is taken as its most powerful component's.

Pure functions, no I/O; the sums over the image are taken once, so the bias at many sample
counts (``mitsuba-refs compare --detect``) is cheap.

The whole-image component alone, against a reference alone
------------------------------------------------------------
:func:`detectable_bias`, :func:`bias_power` and :func:`spp_for_bias` bound the power of the
whole-image component from a reference alone (the test side's variance a multiple of the
reference's); :func:`gross_error_bound` and :func:`tile_gross_error_bound` give what the
bounded-variance components always reject, and :func:`tile_detectable_bias` the tiles-only
test's bound with Bonferroni over tiles (the grader's, :mod:`autograder.power`).

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
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import special
from scipy.stats import norm

from ._tiles import as_image, noiseless_pixels, sidak_per_test, tile_counts, tile_sums
from .correlation import INDEPENDENT
from .mean import MeanTestOptions, tile_z

__all__ = ["DetectableBias", "MeanTestPower", "detectable_global_bias", "WEAK_BIAS",
           "weak_agreement", "image_mean_se", "image_critical_z", "bias_power", "detectable_bias",
           "spp_for_bias", "gross_error_bound", "tile_gross_error_bound", "tile_power",
           "tile_detectable_bias"]

#: An agreement whose detectable global bias exceeds this is weak.
WEAK_BIAS = 0.05
#: Largest bias the search tries, brighter (a factor 1e6) and darker (all but black).
_LARGEST = {+1: 1e6, -1: 1.0 - 1e-12}
#: "Infinitely many" test samples (finite, so that the no-hit guard's weights stay numbers).
_UNLIMITED = 1e30


def _tail(x):
    """Upper normal tail Φc(x), for arrays."""
    return 0.5 * special.erfc(np.asarray(x, dtype=np.float64) / math.sqrt(2.0))


def _rejection(diff, spread, denominator, crit):
    r"""P(|diff + spread Z| >= crit * denominator), elementwise (see the module notes)."""
    diff, spread = np.abs(diff), np.asarray(spread, dtype=np.float64)
    threshold = crit * np.asarray(denominator, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        lo, hi = (threshold - diff) / spread, (threshold + diff) / spread
        p = _tail(lo) + _tail(hi)
    deterministic = np.where(diff > threshold, 1.0, 0.0)      # no noise: rejected iff beyond
    return np.where(spread > 0, p, deterministic)


@dataclass(frozen=True)
class DetectableBias:
    """The smallest global bias one mean test detects with probability ``power``.

    Attributes
    ----------
    brighter, darker : float
        Smallest ``b > 0`` (image ``1+b`` times the truth) and smallest ``|b|`` of ``b < 0``
        detected with probability ``power``; ``inf`` when none is (a black reference).
    floor : float
        The same (larger of the two signs) with infinitely many test samples: what the
        reference's own noise alone leaves unseen.
    power, alpha : float
        The detection probability and the mean test's level.
    test_spp, reference_spp : float
        The sample counts it was computed for.
    component : str
        ``"image"`` (whole-image means decide) or ``"tiles"`` (tiles only: splatting renders).
    """

    brighter: float
    darker: float
    floor: float
    power: float
    alpha: float
    test_spp: float
    reference_spp: float
    component: str = "image"

    @property
    def bias(self) -> float:
        """The larger of the two signs: every global bias at least this large, brighter or
        darker, is detected with probability >= ``power``."""
        return max(self.brighter, self.darker)


class MeanTestPower:
    """The power of :func:`~mitsuba_refs.stats.compare_means` against a global bias of the
    sampled light (module notes).

    Parameters
    ----------
    ref_mean, ref_var : array (H, W, C)
        The reference's per-pixel mean (taken as the truth) and per-sample variance.
    test_var : array (H, W, C)
        The test side's per-sample variance (as a correct render of its estimator would
        have it; must be finite).
    alpha : float
        Level of the whole mean test.
    max_var_ratio : float, optional
        As given to ``compare_means``: adds the bounded-variance component.
    image_components : bool
        As given to ``compare_means``; False: the tiles decide alone.
    options : MeanTestOptions
        As given to ``compare_means``: its tile edge, numerical floor, the film's pixel
        correlation (tiles only; the image sums need none) and the image components'
        heavy-tail guard (``same_estimator``).
    """

    def __init__(self, ref_mean, ref_var, test_var, *, alpha: float,
                 max_var_ratio: float | None = None, image_components: bool = True,
                 options: MeanTestOptions = MeanTestOptions()):
        tile, pixel_correlation = options.tile, options.pixel_correlation
        same_estimator, self.rel_floor = options.same_estimator, options.rel_floor
        if not 0.0 < alpha < 1.0:
            raise ValueError("alpha must be in (0, 1)")
        mean = as_image(ref_mean, "ref_mean")
        v_ref = np.maximum(as_image(ref_var, "ref_var"), 0.0)
        v_test = np.maximum(as_image(test_var, "test_var"), 0.0)
        if not (mean.shape == v_ref.shape == v_test.shape):
            raise ValueError(f"shape mismatch: {mean.shape} {v_ref.shape} {v_test.shape}")
        if not (np.all(np.isfinite(v_test)) and np.all(np.isfinite(v_ref))):
            raise ValueError("the variances must be finite")
        self.alpha, self.ratio, self.guarded = float(alpha), max_var_ratio, bool(same_estimator)
        self.component = "image" if image_components else "tiles"
        channels = mean.shape[2]
        components = (2 if image_components else 1) + (max_var_ratio is not None)
        level = sidak_per_test(alpha, components)
        # whole image: the channel means and their per-sample variances (the row sums of a
        # filtered film's pixels add up to the image mean's variance: no correction)
        self.image = image_components
        # the light a bias moves: the noisy pixels' (module notes)
        noiseless = noiseless_pixels(v_ref.sum(axis=2), v_test.sum(axis=2), mean, mean)
        sampled = np.where(noiseless[..., None], 0.0, mean)
        if image_components:
            pixels = mean.shape[0] * mean.shape[1]
            self.image_mu = mean.mean(axis=(0, 1))                    # (C,)
            self.image_sampled = sampled.mean(axis=(0, 1))
            self.image_ref = v_ref.sum(axis=(0, 1)) / pixels ** 2     # per sample, image mean
            self.image_test = v_test.sum(axis=(0, 1)) / pixels ** 2
            self.image_crit = float(-special.ndtri(sidak_per_test(level, channels) / 2))
        # tiles: a filtered film's tile keeps the share s_T of its pixels' row sums
        share = (pixel_correlation or INDEPENDENT).within_tile_share(tile)
        counts = tile_counts(mean.shape[0], mean.shape[1], tile)[..., None]
        self.counts = counts
        self.mu = tile_sums(mean, tile) / counts                   # tile means (Ht, Wt, C)
        self.sampled = tile_sums(sampled, tile) / counts           # their sampled light
        self.v_ref = share * tile_sums(v_ref, tile) / counts       # tile-average per-sample
        self.v_test = share * tile_sums(v_test, tile) / counts
        informative = ((self.v_ref > 0) | (self.v_test > 0) | (self.mu != 0)).any(axis=2)
        self.informative = informative
        tiles = max(int(informative.sum()), 1)
        self.crit = float(-special.ndtri(sidak_per_test(level, tiles) / (2 * channels)))
        # the bounded tiles exist only without the image components (compare_means)
        self.tile_ratio = None if image_components else max_var_ratio

    # ---- power -----------------------------------------------------------------------
    def power(self, b: float, test_spp: float, reference_spp: float) -> float:
        """Lower bound on the probability that the test rejects an image ``(1+b)`` times the
        truth, the test at ``test_spp`` and the reference at ``reference_spp`` samples: its
        most powerful component's (whole image, or the tiles)."""
        tiles = self._tile_power(b, test_spp, reference_spp)
        if not self.image:
            return tiles
        return max(tiles, self._image_power(b, test_spp, reference_spp))

    def _floor(self, b, mu, sampled):
        return (self.rel_floor * np.maximum(np.abs(mu), np.abs(mu + b * sampled))) ** 2

    def _image_power(self, b, n_a, n_b):
        ref = self.image_ref / n_b
        floor = self._floor(b, self.image_mu, self.image_sampled)
        test = (1.0 + b) ** 2 * self.image_test
        spread2 = test / n_a + ref + floor
        denominator2 = spread2
        if self.guarded:     # the test side's variance: the larger of its own and the pooled
            pooled = (n_a * test + n_b * self.image_ref) / (n_a + n_b)
            denominator2 = np.maximum(test, pooled) / n_a + ref + floor
        diff = b * self.image_sampled
        best = float(np.max(_rejection(diff, np.sqrt(spread2), np.sqrt(denominator2),
                                       self.image_crit)))
        if self.ratio is not None:
            bounded = np.sqrt(self.ratio * self.image_ref / n_a + ref + floor)
            best = max(best, float(np.max(_rejection(diff, np.sqrt(spread2), bounded,
                                                     self.image_crit))))
        return min(best, 1.0)

    @staticmethod
    def _guarded(va, vb, n_a, n_b, pixels):
        """The squared denominator of :func:`mitsuba_refs.stats.mean.tile_z` (no-hit guard)."""
        pooled = (n_a * va + n_b * vb) / (n_a + n_b)
        return (np.maximum(va, pooled) / (pixels * n_a)
                + np.maximum(vb, pooled) / (pixels * n_b))

    def _tile_power(self, b, n_a, n_b):
        va = (1.0 + b) ** 2 * self.v_test
        floor = self._floor(b, self.mu, self.sampled)
        spread = np.sqrt(va / (self.counts * n_a) + self.v_ref / (self.counts * n_b) + floor)
        diff = b * self.sampled
        own = np.sqrt(self._guarded(va, self.v_ref, n_a, n_b, self.counts) + floor)
        p = _rejection(diff, spread, own, self.crit)
        if self.tile_ratio is not None:
            bounded = np.sqrt(self._guarded(self.tile_ratio * self.v_ref, self.v_ref, n_a, n_b,
                                            self.counts) + floor)
            p = np.maximum(p, _rejection(diff, spread, bounded, self.crit))
        per_tile = np.minimum(p.max(axis=2), 1.0)[self.informative]
        return float(-np.expm1(np.sum(np.log1p(-np.minimum(per_tile, 1.0 - 1e-16)))))

    # ---- the detectable bias ------------------------------------------------------------
    def detectable(self, test_spp: float, reference_spp: float, *, power: float = 0.95,
                   sign: int = +1) -> float:
        """Smallest ``|b|`` of sign ``sign`` detected with probability >= ``power`` (``inf``
        if none up to a factor 1e6 brighter or a black image); the power grows with ``|b|``."""
        if sign not in (-1, 1):
            raise ValueError("sign must be +1 or -1")
        if not 0.0 < power < 1.0:
            raise ValueError("power must be in (0, 1)")

        def enough(size):
            return self.power(sign * size, test_spp, reference_spp) >= power

        lo, hi = 0.0, _LARGEST[sign]
        if not enough(hi):
            return math.inf
        for _ in range(200):
            mid = 0.5 * (lo + hi) if hi < 10 * max(lo, 1e-9) else math.sqrt(max(lo, 1e-12) * hi)
            lo, hi = (lo, mid) if enough(mid) else (mid, hi)
            if hi - lo <= 1e-6 * hi:
                break
        return hi

    def bound(self, test_spp: float, reference_spp: float, *, power: float = 0.95) -> DetectableBias:
        """The :class:`DetectableBias` at these sample counts."""
        return DetectableBias(
            brighter=self.detectable(test_spp, reference_spp, power=power, sign=+1),
            darker=self.detectable(test_spp, reference_spp, power=power, sign=-1),
            floor=self.floor(reference_spp, power=power), power=float(power), alpha=self.alpha,
            test_spp=float(test_spp), reference_spp=float(reference_spp),
            component=self.component)

    def worst(self, test_spp: float, reference_spp: float, *, power: float = 0.95) -> float:
        """The larger of the two signs' detectable biases."""
        return max(self.detectable(test_spp, reference_spp, power=power, sign=s) for s in (1, -1))

    def floor(self, reference_spp: float, *, power: float = 0.95) -> float:
        """The detectable bias (larger sign) with infinitely many test samples."""
        return self.worst(_UNLIMITED, reference_spp, power=power)


def detectable_global_bias(ref_mean, ref_var, ref_n, test_var, test_n, *, alpha: float,
                           power: float = 0.95, max_var_ratio: float | None = None,
                           image_components: bool = True,
                           options: MeanTestOptions = MeanTestOptions()) -> DetectableBias:
    """The smallest global bias ``compare_means`` (called with these arguments) detects with
    probability ``power``: :meth:`MeanTestPower.bound` (an upper bound, see the module notes).

    Parameters
    ----------
    ref_mean, ref_var, ref_n : the reference's mean, per-sample variance and sample count
    test_var, test_n : the test side's per-sample variance and sample count
    alpha, max_var_ratio, image_components, options : as for ``compare_means``
    power : float
        Detection probability (0.95).
    """
    model = MeanTestPower(ref_mean, ref_var, test_var, alpha=alpha, max_var_ratio=max_var_ratio,
                          image_components=image_components, options=options)
    return model.bound(float(test_n), float(ref_n), power=power)


def weak_agreement(agree: bool, bound: DetectableBias | None) -> bool:
    """An agreement that could not see a global bias of :data:`WEAK_BIAS`."""
    return bool(agree and bound is not None and bound.bias > WEAK_BIAS)


# ---- the whole-image component alone, against a reference alone ----------------------
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


def tile_power(b: float, ref_mean, ref_var, ref_n, n_test, *, alpha: float, tile: int = 8,
               components: int = 2) -> float:
    """Probability that the tiles-only mean test rejects an image ``(1+b)`` times the truth.

    Each tile rejects when its best channel's ``|z|`` (own variance) exceeds the Bonferroni
    critical value over the test's ``components`` (own-variance tiles and bounded-variance
    tiles), tiles and channels (the real test's Šidák and its correlated-channel maximum have
    a smaller one) and the tiles are independent: a lower bound on the power, so the bias
    :func:`tile_detectable_bias` returns is an upper bound.
    """
    mean = np.asarray(ref_mean, dtype=np.float64)
    per_sample = np.maximum(np.asarray(ref_var, dtype=np.float64), 0.0)
    h, w = mean.shape[0] - mean.shape[0] % tile, mean.shape[1] - mean.shape[1] % tile

    def tiles(x):
        return x[:h, :w].reshape(h // tile, tile, w // tile, tile, -1).sum(axis=(1, 3))
    signal = tiles(mean)
    se = np.sqrt(tiles(per_sample) * (1.0 + b) ** 2 / n_test + tiles(per_sample) / ref_n)
    informative = (se > 0).any(axis=2)
    m = max(int(informative.sum()), 1)
    critical = norm.isf(alpha / (components * 2 * 3 * m))
    with np.errstate(divide="ignore", invalid="ignore"):
        shift = np.where(se > 0, np.abs(b * signal) / se, 0.0).max(axis=2)[informative]
    miss = norm.cdf(critical - shift)
    return float(1.0 - np.prod(miss))


def tile_detectable_bias(ref_mean, ref_var, ref_n, n_test, *, alpha: float, power: float = 0.95,
                         sign: int = +1) -> float:
    """Smallest relative bias (sign ``sign``) the tiles-only test detects with probability
    >= ``power`` by :func:`tile_power` (an upper bound); ``inf`` if none up to 100 %."""
    def enough(size):
        return tile_power(sign * size, ref_mean, ref_var, ref_n, n_test, alpha=alpha) >= power
    lo, hi = 0.0, 1.0 - 1e-9
    if not enough(hi):
        return math.inf
    while hi - lo > 1e-6:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if enough(mid) else (mid, hi)
    return hi
