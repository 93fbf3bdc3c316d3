r"""Do two renderers agree on the expected image?  A tiled two-sample z test plus a whole-image test.

Inputs per side: the per-pixel mean image, the per-pixel *per-sample* variance
(unbiased sample variance of that pixel's samples) and the sample count ``n``.
Side ``a`` is the image under test, side ``b`` the reference.

Why tiles
---------
Radiance samples are heavily skewed (mostly ~0, rare large values when a path hits
a small light).  A per-pixel z test with the pixel's own variance estimate is badly
miscalibrated then (a pixel with no light hit has mean 0 *and* variance 0).  Summing
the ``P`` pixels of a tile first gives a statistic built from ``n P`` samples, where the
central limit theorem holds.  For tile :math:`T` and channel :math:`c`

.. math::

    \bar a_T = \frac1P \sum_{p\in T} a_p, \qquad
    \widehat{\mathrm{Var}}(\bar a_T) = \frac{1}{P^2}\sum_{p\in T}\frac{v^a_p}{n^a_p}
      = \frac{V^a_T}{P\, n^a_T}

with :math:`V^a_T` the tile-average per-sample variance and :math:`n^a_T` the harmonic
mean of the counts in the tile.

Variance used in the denominator (the "no-hit" guard)
-----------------------------------------------------
If the test side saw *no* light hit in a tile while the reference (64x more samples)
did, the test's own variance estimate is ~0 and the Welch z explodes although both
sides are correct.  We therefore use, per tile and side,

.. math::

    \tilde V^a_T = \max\!\Big(V^a_T,\; V^{pool}_T\Big),\qquad
    V^{pool}_T = \frac{n^a_T V^a_T + n^b_T V^b_T}{n^a_T + n^b_T},

and :math:`z_T = (\bar a_T - \bar b_T)/\sqrt{\tilde V^a_T/(P n^a_T) + \tilde V^b_T/(P n^b_T)}`.
Under the null of a *common* estimator, :math:`V^{pool}` is the best estimate of both
variances; if the test side uses a *noisier* estimator its own (larger) variance wins
the max; if it uses a better one the reference variance is used (conservative).  A
numerical floor :math:`(\epsilon_{rel}\max(|\bar a_T|,|\bar b_T|))^2` is added to the
squared standard error so that zero-variance pixels (black background, furnace tests)
compare exactly up to float32 resolution; tiles whose two means are both exactly 0
with zero variance carry no evidence and are left out of the family.  Equal-but-nonzero
deterministic means give z = 0; unequal deterministic means give |z| = inf (p = 0) when
``rel_floor=0`` and a huge |z| otherwise.

Channels and the family
-----------------------
The three channels of one path are strongly correlated (grey light), so a Šidák
correction over channels would be conservative (~alpha/3 for grey scenes).  The channel
correlation :math:`R` is estimated image-wide from the per-pixel differences
:math:`d_p = a_p - b_p` (mean 0 under the null), and a tile's p-value is that of its largest
channel, :math:`P(\max_c|Z_c|\ge\max_c|z_{Tc}|)` for :math:`Z\sim N(0,R)`, computed by
nested Gauss-Legendre quadrature.  Within the image the tiles are independent, so the
smallest of the :math:`m` informative tiles' p-values is Šidák-adjusted,
:math:`p_{tiles}=1-(1-p_{min})^m`.  A second component tests the whole-image means
(same channel treatment; there the test side's own variances are used: 260k samples; with
``same_estimator`` the larger of its own and the pooled one, see "Heavy tails" below).
The two components are combined by Šidák, :math:`p = 1-(1-\min(p_{tiles},p_{image}))^2`,
valid for any correlation between them (Šidák's inequality for two-sided normal tests), and
nearly exact here because the two are only weakly correlated.  Reject iff :math:`p\le\alpha`.

Bounded variance (``max_var_ratio``)
------------------------------------
Both components divide by the test side's *own* variance.  A wrong, heavy-tailed estimator
(one enormous sample in a tile) inflates that variance as fast as its bias, so its z stays
near 1 whatever the bias: a render 1e35x too bright "agreed" with p = 0.55.  With
``max_var_ratio = K`` a third component tests the whole-image means with the test side's
image-mean variance taken as :math:`K\sum_p v^b_p/n_a/P^2` (K times the reference's, known
from millions of samples) instead of its own.  Under :math:`H_0`: equal means and a test-side
variance at most K times the reference's, it is valid (conservative); an observed image mean
off by more than :math:`z^*\sqrt{K n_b/n_a+1}\,\mathrm{se}_b` is rejected whatever the test's
own variance.  The family is then Šidák over three components.  Without the image
components (splatting renders, ``image_components=False``) the same bound is applied per
tile: each tile's test-side variance is taken as K times the reference's tile variance, an
"8px, bounded variance" component Šidák-adjusted over the informative tiles; the family is
then Šidák over two components (own-variance tiles and bounded tiles).

Heavy tails (``same_estimator``)
--------------------------------
Where a few rare samples carry much of a pixel's light (a point light's highlight on a
glossy anisotropic surface, smaller than a sample's share of the pixel), a short render
that happens to miss them is darker *and* reports less variance of its own: the image
component, dividing by that variance, then rejects a correct renderer (a mitsuba-data file
at 64 spp: image 0.95x the reference with 0.26x its per-sample variance, p = 4e-6, while it
agrees at 4096 spp). When the test side runs the reference's estimator, both share one
per-sample variance under the null, which the reference's 64x more samples estimate far
better; so the image components then take the test side's image-mean variance as

.. math:: \max\!\Big(\sum_p \frac{v^a_p}{n_a},\; \sum_p \frac{v^{pool}_p}{n_a}\Big),
          \qquad v^{pool}_p = \frac{n_a v^a_p + n_b v^b_p}{n_a + n_b},

the tiles' no-hit guard over the whole image (at the image level, so that the power's closed
form stays exact: :mod:`mitsuba_refs.stats.detectable`). It can only enlarge the standard
error: the test stays valid whatever the estimator; a noisier test side keeps its own
variance; only a render quieter than the reference's estimator loses power, which for the
same estimator is chance.

Which tiles are reported as significant: those whose largest-channel |z| exceeds the
per-tile critical value of the family.  A global bias too small to show in any one tile is
caught by the image component ("no single tile stands out").

Relative bias
-------------
The headline bias uses luminance :math:`Y = 0.212671R + 0.715160G + 0.072169B` (Mitsuba's weights,
:data:`pathtracer.core.color.LUMINANCE`) of the image means,
:math:`r = \bar Y_a/\bar Y_b - 1`.  Channel covariances are not supplied, so the standard
error of :math:`\bar Y` uses the Cauchy-Schwarz bound :math:`\mathrm{sd}(\sum_c w_c X_c)\le\sum_c w_c\,\mathrm{sd}(X_c)`
(exact for perfectly correlated channels, i.e. grey light; otherwise conservative).  The CI
is the delta-method interval
:math:`r \pm z_{1-\gamma/2}\,(1+r)\sqrt{(s_a/\bar Y_a)^2+(s_b/\bar Y_b)^2}`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize, special

from pathtracer.core.color import LUMINANCE

from ._mvn import correlation_from_differences, p_max_abs
from ._tiles import as_count, as_image, sidak, sidak_per_test, tile_counts, tile_sums
from .correlation import INDEPENDENT, PixelCorrelation

__all__ = ["MeanAgreement", "MeanTestOptions", "compare_means", "tile_z", "VARIANCE_BOUND", "overflow_scale"]

#: Default ``max_var_ratio`` of the bounded-variance image component for two renders of the
#: same estimator: a correct test side is assumed to have at most this many times the
#: reference's per-sample variance (summed over the image).  It sits well above the correct
#: alternatives (balance heuristic 1.04-1.12x, constant-q roulette 1.34x, uniform hemisphere
#: 1.9-2.0x, measured on the Cornell box) and above the variance policy
#: (``variance.MAX_VARIANCE_RATIO`` = 1.5x), leaving a factor >= 2 for the reference's own
#: variance estimate being low.
VARIANCE_BOUND = 4.0
#: Magnitudes above this are rescaled before any arithmetic (their squares and sums over
#: an image must stay finite in float64, whose largest value is ~1.8e308).
_OVERFLOW_GUARD = 1e100


def overflow_scale(*arrays, guard: float = _OVERFLOW_GUARD) -> float:
    """A power of two near the largest finite magnitude of ``arrays`` when that exceeds
    ``guard``, else 1.  Dividing means by it (and variances by its square) keeps squares and
    image sums finite; the tests are invariant to a common scale."""
    largest = 0.0
    for a in arrays:
        a = np.abs(np.asarray(a, dtype=np.float64))
        finite = a[np.isfinite(a)]
        if finite.size:
            largest = max(largest, float(finite.max()))
    if largest <= guard:
        return 1.0
    return float(2.0 ** math.floor(math.log2(largest)))


def _norm_ppf(q: float) -> float:
    return float(special.ndtri(q))


@dataclass(frozen=True)
class MeanTestOptions:
    """How :func:`compare_means` measures (the defaults are the test's own).

    Attributes
    ----------
    tile : int
        Tile edge (pixels); edge tiles may be partial.
    ci_level : float
        Level of the relative-bias confidence interval.
    rel_floor : float
        Relative numerical floor on standard errors (float32 resolution headroom).
    pixel_correlation : PixelCorrelation, optional
        How the film's reconstruction filter correlates neighbouring pixels
        (:func:`mitsuba_refs.stats.correlation.pixel_correlation`); None: independent
        pixels (box filter).  With a tent or gaussian filter ``var / n`` is each pixel's
        covariance row sum, and a tile's variance is the share of it inside the tile.
    same_estimator : bool
        The test side runs the reference's estimator: its image-mean variance is taken as the
        larger of its own and the pooled one (module notes, "Heavy tails").
    """

    tile: int = 8
    ci_level: float = 0.95
    rel_floor: float = 1e-5
    pixel_correlation: PixelCorrelation | None = None
    same_estimator: bool = False


@dataclass(frozen=True, eq=False)
class MeanAgreement:
    """Result of :func:`compare_means` (side a = test, side b = reference): numbers only
    (the words: :func:`mitsuba_refs.report.wording.mean_verdict`).

    Attributes
    ----------
    agree : bool
        True unless the family test (tiles + image) rejects at level ``alpha``.
    p_value : float
        Family p-value (Šidák over the tile and image components).
    alpha, tile : float, int
        Level and base tile size used.
    z_tiles : ndarray, shape (ceil(H/tile), ceil(W/tile), C)
        Signed per-tile z, (test - reference)/se, 0 where no evidence.
    n_tests : int
        Informative tiles (some channel carries evidence).
    n_significant : int
        Tiles whose largest-channel |z| exceeds the per-tile critical value.
    worst_tile : tuple (row, col, channel) or None
        Tile-channel with the largest |z| (tile indices).
    worst_z : float
        Its z.
    scale_p_values : dict
        Component p-values: "<tile>px" (Šidák over tiles), "image" and, with
        ``max_var_ratio``, "image, bounded variance" (tiles only: "<tile>px, bounded variance").
    image_z : ndarray, shape (C,)
        Per-channel z of the whole-image means.
    rel_bias, rel_bias_ci : float, (float, float)
        Luminance relative bias mean_a/mean_b - 1 and its CI (level ``ci_level``).
    rel_bias_channels : ndarray, shape (C,)
        Per-channel relative bias.
    critical_z : float
        The per-tile critical |z| of the family at level ``alpha`` (nan when the test
        agrees: then no tile can exceed it, and it is not computed).
    significant : ndarray of bool, shape like ``z_tiles``
        Tile-channels whose |z| exceeds ``critical_z`` (the tiles ``n_significant`` counts).
    shape : (int, int)
        The image's height and width in pixels.
    max_var_ratio : float or None
        The bound of the bounded-variance component (None: none ran).
    bounded_z : ndarray, shape (C,), or None
        Per-channel z of the whole-image means with the bounded variance (None: not run).
    bounded_only : bool
        Only the tiles' bounded-variance component rejects: ``z_tiles`` are its z.
    """

    agree: bool
    p_value: float
    alpha: float
    tile: int
    z_tiles: np.ndarray
    n_tests: int
    n_significant: int
    worst_tile: tuple | None
    worst_z: float
    scale_p_values: dict = field(default_factory=dict)
    image_z: np.ndarray = None
    rel_bias: float = 0.0
    rel_bias_ci: tuple = (0.0, 0.0)
    rel_bias_channels: np.ndarray = None
    ci_level: float = 0.95
    critical_z: float = math.nan
    significant: np.ndarray = None
    # Not in the repr, which stays what it was before these fields (test logs print it).
    shape: tuple = field(default=(0, 0), repr=False)
    max_var_ratio: float | None = field(default=None, repr=False)
    bounded_z: np.ndarray | None = field(default=None, repr=False)
    bounded_only: bool = field(default=False, repr=False)

    def __bool__(self) -> bool:  # ``if compare_means(...):`` reads naturally
        return bool(self.agree)


def tile_z(mean_a, var_a, n_a, mean_b, var_b, n_b, tile: int, *, rel_floor: float = 1e-5):
    r"""Signed per-tile, per-channel z of (a - b) with the no-hit guard (see module docs).

    Parameters
    ----------
    mean_a, var_a, mean_b, var_b : array (H, W, C)
        Per-pixel means and unbiased per-sample variances.
    n_a, n_b : int or array (H, W)
        Samples per pixel (>= 2).
    tile : int
        Tile edge in pixels (edge tiles may be partial).
    rel_floor : float
        Relative numerical floor on the standard error.

    Returns
    -------
    z : ndarray (Ht, Wt, C)
        z statistics; 0 for tiles with no evidence (both means 0, zero variance).
    informative : ndarray of bool (Ht, Wt, C)
        Tile-channels that carry evidence.
    """
    ma, va, mb, vb = (as_image(x, nm) for x, nm in
                      ((mean_a, "mean_a"), (var_a, "var_a"), (mean_b, "mean_b"), (var_b, "var_b")))
    h, w = ma.shape[:2]
    na = as_count(n_a, (h, w), "n_a")
    nb = as_count(n_b, (h, w), "n_b")
    cnt = tile_counts(h, w, tile)[..., None]                      # P_T
    abar = tile_sums(ma, tile) / cnt
    bbar = tile_sums(mb, tile) / cnt
    Va = tile_sums(np.maximum(va, 0.0), tile) / cnt               # tile-average per-sample variance
    Vb = tile_sums(np.maximum(vb, 0.0), tile) / cnt
    nha = (cnt[..., 0] / tile_sums(1.0 / na, tile))[..., None]    # harmonic mean count
    nhb = (cnt[..., 0] / tile_sums(1.0 / nb, tile))[..., None]
    Vp = (nha * Va + nhb * Vb) / (nha + nhb)
    se2 = np.maximum(Va, Vp) / (cnt * nha) + np.maximum(Vb, Vp) / (cnt * nhb)
    se2 = se2 + (rel_floor * np.maximum(np.abs(abar), np.abs(bbar))) ** 2
    diff = abar - bbar
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(se2 > 0, diff / np.sqrt(se2), np.where(diff == 0, 0.0, np.sign(diff) * np.inf))
    informative = (se2 > 0) | (diff != 0)
    return z, informative


def _solve_crit(level: float, R: np.ndarray) -> float:
    """|z| threshold with P(max_c |Z_c| >= t) = level.

    The root lies between the one-channel quantile (P(|Z_1| >= t) = level) and the
    Bonferroni one (C P(|Z_1| >= t) = level); Brent's method on log P finds it to 1e-12 in
    ~8 evaluations of the tail, where bisection from [0, 40] took 40 (most of the time
    ``compare_means`` spends on a rejected image). Bisection stays for what Brent cannot
    bracket (a level outside (0, 1), round-off at the bracket's ends).
    """
    C = R.shape[0]
    if 0.0 < level < 1.0:
        one, bonferroni = (math.sqrt(2.0) * special.erfcinv(x) for x in (level, level / C))
        if C == 1:                            # the two quantiles coincide: exact
            return float(one)

        def log_excess(t):
            return math.log(max(p_max_abs(t, R), 1e-300)) - math.log(level)

        lo, hi = max(0.0, one - 1e-6), bonferroni + 1e-6
        if log_excess(lo) > 0 > log_excess(hi):
            return float(optimize.brentq(log_excess, lo, hi, xtol=1e-12))
    lo, hi = 0.0, 40.0
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if p_max_abs(mid, R) > level:
            lo = mid
        else:
            hi = mid
    return hi


def _checked_inputs(mean_a, var_a, mean_b, var_b, alpha, max_var_ratio, tile):
    """The four images as (H, W, C) float arrays, divided by a common scale when huge."""
    if not (0.0 < alpha < 1.0):
        raise ValueError("alpha must be in (0, 1)")
    ma, va, mb, vb = (as_image(x, nm) for x, nm in
                      ((mean_a, "mean_a"), (var_a, "var_a"), (mean_b, "mean_b"), (var_b, "var_b")))
    if not (ma.shape == va.shape == mb.shape == vb.shape):
        raise ValueError(f"shape mismatch: {ma.shape} {va.shape} {mb.shape} {vb.shape}")
    for x, nm in ((ma, "mean_a"), (mb, "mean_b"), (vb, "var_b")):
        if not np.all(np.isfinite(x)):
            raise ValueError(f"{nm} contains NaN or inf")
    if np.any(np.isnan(va)) or np.any(va == -np.inf):
        raise ValueError("var_a contains NaN or -inf")
    if max_var_ratio is not None and not max_var_ratio > 0:
        raise ValueError("max_var_ratio must be > 0")
    # Finite but huge values (a broken estimator, 1e35 or 1e300) would overflow the squares
    # and sums below; every statistic is invariant to a common scale, so divide it out.
    scale = overflow_scale(ma, mb, np.sqrt(np.abs(va)), np.sqrt(np.abs(vb)))
    if scale != 1.0:
        ma, mb, va, vb = ma / scale, mb / scale, va / scale / scale, vb / scale / scale
    if int(tile) < 1:
        raise ValueError("tile must be >= 1")
    return ma, va, mb, vb


def _difference_z(A, B, se_test, se_ref, rel_floor):
    """Per-channel z of the image means ``A - B`` (numerical floor added; a deterministic
    difference is +-inf, an equal one 0)."""
    se = np.sqrt(se_test ** 2 + se_ref ** 2 + (rel_floor * np.maximum(np.abs(A), np.abs(B))) ** 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(se > 0, (A - B) / se, np.where(A == B, 0.0, np.sign(A - B) * np.inf))


def _channel_p(z, R) -> float:
    """p-value of the largest |z| over correlated channels (1 when every z is 0)."""
    return p_max_abs(float(np.max(np.abs(z))), R) if np.any(z != 0) else 1.0


def _image_means(ma, va, na, mb, vb, nb, options):
    """Whole-image channel means ``A, B``, their standard errors ``sa, sb`` and z."""
    npx = ma.shape[0] * ma.shape[1]
    A = ma.mean(axis=(0, 1))
    B = mb.mean(axis=(0, 1))
    own = (np.maximum(va, 0) / na).sum(axis=(0, 1))                  # own variances: CLT-safe here
    if options.same_estimator:      # a render that missed heavy-tailed samples: module notes
        pooled = (na * np.maximum(va, 0) + nb * np.maximum(vb, 0)) / (na + nb)
        own = np.maximum(own, (pooled / na).sum(axis=(0, 1)))
    sa = np.sqrt(own) / npx
    sb = np.sqrt((np.maximum(vb, 0) / nb).sum(axis=(0, 1))) / npx
    return A, B, sa, sb, _difference_z(A, B, sa, sb, options.rel_floor)


def _relative_bias(A, B, sa, sb, ci_level):
    """Luminance relative bias, its CI (CS-bounded se) and the per-channel relative bias."""
    C = A.shape[0]
    wts = LUMINANCE if C == 3 else np.full(C, 1.0 / C)
    YA, YB = float(wts @ A), float(wts @ B)
    sYA, sYB = float(wts @ sa), float(wts @ sb)
    zq = _norm_ppf(0.5 + ci_level / 2)
    if YB > 0 and YA > 0:
        ratio = YA / YB
        sr = ratio * math.sqrt((sYA / YA) ** 2 + (sYB / YB) ** 2)
        rel = ratio - 1.0
        rel_ci = (rel - zq * sr, rel + zq * sr)
    elif YA == YB:
        rel, rel_ci = 0.0, (0.0, 0.0)
    else:
        rel, rel_ci = (math.inf if YB == 0 else -1.0), (math.nan, math.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel_ch = np.where(B != 0, A / B - 1.0, np.where(A == B, 0.0, np.inf))
    return float(rel), (float(rel_ci[0]), float(rel_ci[1])), rel_ch


def _significant_tiles(agree, alpha, components, z0, inf0, R, bounded_tiles_z):
    """Per-tile critical |z|, the significant tile-channels, the z they refer to and whether
    only the tiles' bounded component rejects."""
    m0 = int(inf0.any(axis=2).sum())
    # per-tile critical |z|: solve p_max_abs(crit, R) = Šidák per-tile level
    lvl = sidak_per_test(sidak_per_test(alpha, components), max(m0, 1))
    if agree:          # then no tile can exceed the critical value
        return math.nan, np.zeros(z0.shape, dtype=bool), z0, False
    crit = _solve_crit(lvl, R)
    sig = inf0 & (np.abs(z0) > crit)
    if bounded_tiles_z is not None and not sig.any():
        # only the bound rejects (a heavy-tailed test side): report the tiles it rejects
        return crit, inf0 & (np.abs(bounded_tiles_z) > crit), bounded_tiles_z, True
    return crit, sig, z0, False


def compare_means(mean_a, var_a, n_a, mean_b, var_b, n_b, *, alpha: float,
                  max_var_ratio: float | None = None, image_components: bool = True,
                  options: MeanTestOptions = MeanTestOptions()) -> MeanAgreement:
    r"""Test whether two renders (a = test, b = reference) have the same expected image.

    Parameters
    ----------
    mean_a, mean_b : array (H, W, C) or (H, W)
        Per-pixel mean radiance.
    var_a, var_b : array like the means
        Per-pixel unbiased per-sample variance :math:`s^2 = \frac{1}{n-1}\sum (x_i-\bar x)^2`.
    n_a, n_b : int or array (H, W)
        Samples per pixel (>= 2).
    alpha : float, keyword (required)
        Family false-rejection level for this comparison (take it from
        :func:`mitsuba_refs.stats.budget.per_test_alpha`).
    max_var_ratio : float, optional
        Adds the bounded-variance image component: the whole-image means are also tested with
        the test side's variance taken as ``max_var_ratio`` times the reference's instead of
        its own estimate, so that a test-side variance far above the reference's cannot hide
        a bias (e.g. :data:`VARIANCE_BOUND` for two renders of the same estimator).  Valid
        when the test estimator's per-sample variance, summed over the image, is at most
        that many times the reference's.  With ``image_components=False`` the bound applies
        to each tile instead ("8px, bounded variance"; valid when it holds per tile).
        None (default): tiles and image only.
    image_components : bool
        False leaves out the whole-image components (own and bounded variance): for
        renders whose pixels are correlated across the image, where summed pixel variances
        misjudge the image mean's (a light path splats into every pixel its vertices
        project to; docs/statistics.md section 8). The tiles then decide alone, with
        their own variance and, if ``max_var_ratio`` is given, with the bounded one.
    options : MeanTestOptions
        Tile size, CI level, numerical floor, the film's pixel correlation and the heavy-tail
        guard (``same_estimator``); see :class:`MeanTestOptions`.

    Returns
    -------
    MeanAgreement
        See its docstring.  The test is calibrated for skewed radiance when tiles hold
        >= ~4000 samples of the test side (e.g. 8x8 tiles at 64 spp); see docs/statistics.md.
        ``var_a`` may hold ``+inf`` (a variance that overflowed float64): the components using
        it then carry no evidence, the bounded one still does.

    Notes
    -----
    Pixels must be independent (box reconstruction filter) unless ``options.pixel_correlation``
    describes the filter.  Pure function: no I/O.
    """
    tile, rel_floor = int(options.tile), options.rel_floor
    ma, va, mb, vb = _checked_inputs(mean_a, var_a, mean_b, var_b, alpha, max_var_ratio, tile)
    h, w, C = ma.shape

    # ---- per-tile z at the base scale -----------------------------------------------
    # A filtered pixel's var / n is its covariance row sum; a tile keeps the share inside it.
    share = (options.pixel_correlation or INDEPENDENT).within_tile_share(tile)
    z0, inf0 = tile_z(ma, va * share, n_a, mb, vb * share, n_b, tile, rel_floor=rel_floor)
    m0 = int(inf0.any(axis=2).sum())                       # informative tiles
    R = correlation_from_differences((ma - mb).reshape(-1, C))
    zmax_t = float(np.max(np.abs(np.where(inf0, z0, 0.0)))) if m0 else 0.0
    p_tile_min = p_max_abs(zmax_t, R) if m0 else 1.0     # smallest per-tile p (max over channels)
    scale_p: dict[str, float] = {f"{tile}px": sidak(p_tile_min, m0)}

    # ---- whole image, per channel (max over channels, correlation-aware) ------------
    na = as_count(n_a, (h, w), "n_a")[..., None]
    nb = as_count(n_b, (h, w), "n_b")[..., None]
    A, B, sa, sb, image_z = _image_means(ma, va, na, mb, vb, nb, options)
    if image_components:
        scale_p["image"] = _channel_p(image_z, R)

    # ---- whole image, the test's variance bounded by max_var_ratio x the reference's ------
    # The components above divide by the test side's own variance, so a heavy-tailed wrong
    # estimator (a few enormous samples) inflates its standard error as fast as its bias and
    # passes.  Here the test side's image-mean variance is what it would be with
    # max_var_ratio times the reference's per-sample variances (16.7M samples at 4096 spp:
    # a precise estimate), so the z grows with the bias whatever the test's variance.
    bounded_z = None
    if max_var_ratio is not None and image_components:
        sab = np.sqrt(max_var_ratio * (np.maximum(vb, 0) / na).sum(axis=(0, 1))) / (h * w)
        bounded_z = _difference_z(A, B, sab, sb, rel_floor)
        scale_p["image, bounded variance"] = _channel_p(bounded_z, R)

    # ---- tiles, the test's variance bounded (renders without image components) --------
    # Splatting correlates pixels across the image but hardly within a tile (docs/statistics.md
    # section 8), so there the bound applies tile by tile: the test side's tile variance is
    # max_var_ratio times the reference's, whatever the test's own.
    bounded_tiles_z = None
    if max_var_ratio is not None and not image_components:
        bounded_tiles_z, inf_b = tile_z(ma, max_var_ratio * vb * share, n_a, mb, vb * share, n_b,
                                        tile, rel_floor=rel_floor)
        m_b = int(inf_b.any(axis=2).sum())
        zmax_b = float(np.max(np.abs(np.where(inf_b, bounded_tiles_z, 0.0)))) if m_b else 0.0
        scale_p[f"{tile}px, bounded variance"] = sidak(p_max_abs(zmax_b, R), m_b) if m_b else 1.0

    p_family = sidak(min(scale_p.values()), len(scale_p))
    agree = not (p_family <= alpha)
    rel, rel_ci, rel_ch = _relative_bias(A, B, sa, sb, options.ci_level)

    # ---- where is it worst (base scale) ------------------------------------------
    crit, sig, z0, bounded_only = _significant_tiles(agree, alpha, len(scale_p), z0, inf0, R,
                                                     bounded_tiles_z)
    worst_tile, worst_z = None, 0.0
    if m0:
        absz = np.where(inf0, np.abs(z0), -1.0)
        idx = np.unravel_index(int(np.argmax(absz)), absz.shape)
        worst_tile, worst_z = tuple(int(i) for i in idx), float(z0[idx])

    for arr in (z0, image_z, rel_ch, sig) + (() if bounded_z is None else (bounded_z,)):
        arr.flags.writeable = False
    return MeanAgreement(
        agree=agree, p_value=float(p_family), alpha=float(alpha), tile=tile, z_tiles=z0,
        n_tests=m0, n_significant=int(sig.any(axis=2).sum()), worst_tile=worst_tile,
        worst_z=worst_z, scale_p_values=scale_p, image_z=image_z, rel_bias=rel,
        rel_bias_ci=rel_ci, rel_bias_channels=rel_ch, ci_level=float(options.ci_level),
        critical_z=float(crit), significant=sig, shape=(int(h), int(w)),
        max_var_ratio=None if max_var_ratio is None else float(max_var_ratio),
        bounded_z=bounded_z, bounded_only=bounded_only)
