r"""Does the error fall like :math:`N^{-1/2}`?  The convergence-law test on an spp ladder.

Input: a geometric ladder of sample counts :math:`N_1<\dots<N_L` and, per level, the image
MSEs of independent renders against a reference, with the reference's own noise subtracted
(:func:`image_mse`).  For an unbiased estimator with independent samples
:math:`E[\mathrm{MSE}(N)] = \bar\sigma^2/N` exactly (mean per-sample variance over pixels).
The MSEs come either as a (K, L) table whose rows are paired across levels (a nested or
progressive ladder: levels may share samples), or as L independent per-level arrays, which
may differ in length.

Equal work per level
--------------------
Give every level the same number of samples in total (K_l proportional to 1/N_l).  When
most of the variance comes from rare bright paths (a small light hit by BSDF sampling),
a level with few samples in total usually contains none of them and its mean MSE is far
below its expectation, while the levels with more samples do see them: with equal
replicas per level the fitted slope is then much flatter than -1 for a correct tracer
(measured on veach-mis: -0.30 [-0.51, -0.09]).  With equal work every level sees the rare
paths equally often, so their absence biases every level by the same factor and the slope
stays unbiased.

A level whose mean rests on a handful of rare values also has an estimated variance that
is too small exactly when those values are missing, and the t test becomes
anti-conservative.  :func:`rare_errors_dominate` says when: Kish's effective sample size
:math:`(\sum y)^2/\sum y^2` of the whole-image MSEs of the lowest level (the one with the
most renders; with equal work every level sees the rare paths equally often) is below
both ``MIN_EFFECTIVE_ROWS`` and 80 % of the renders.  The caller then renders more, at
every level alike.  Simulated with 0.29 rare hits per 1-spp image (1000 seeds, ladder
1-4-16, 2 replicas at the top): fixed work rejects 11.9 % at alpha 0.05 and 1.7 % at 1e-3;
extended by this rule (up to 16x), 4.2 % and 0.3 %; with 2.9 hits, 3.9 % and 0 %.

Slope
-----
Let :math:`\bar y_l` be the mean at level :math:`l` and :math:`x_l=\log N_l`.  The
least-squares slope of :math:`\log\bar y_l` on :math:`x_l` is :math:`\hat\beta=\sum_l c_l\log\bar y_l`,
:math:`c_l=(x_l-\bar x)/\sum(x_l-\bar x)^2`.  For independent levels its variance by the
delta method:

.. math:: \widehat{\mathrm{Var}}(\hat\beta) = g^\top \hat\Sigma g,\qquad g_l = c_l/\bar y_l,

:math:`\hat\Sigma` diagonal, :math:`s_l^2/K_l` (Welch-Satterthwaite degrees of freedom).
For a paired table (rows: e.g. the image blocks of a filtered film) the leave-one-row-out
jackknife, :math:`\frac{K-1}{K}\sum_k(\hat\beta_{(k)}-\bar\beta_{(\cdot)})^2` with
:math:`t_{K-1}`.  The delta method would use the rows' sample covariance, i.e. the scores
:math:`s_k=\sum_l c_l y_{kl}/\bar y_l`; when one row carries most of every level's mean (a
light smaller than a pixel in one block, hit by a few samples), its ratios
:math:`y_{kl}/\bar y_l\approx K` at every level whatever its own noise, so its score is
near 0 and the variance comes from the quiet rows alone.  Measured on Mitsuba's
``integrator_direct_both`` at 64x48 (one of 16 blocks held 90 % of each level's MSE):
Mitsuba against its own reference gave slope -1.77 with p = 1.4e-3, the tracer -0.77 with
p = 5e-7, both "significant" in opposite directions; with the jackknife p = 0.28 and 0.31.
For homogeneous rows the jackknife and the delta method agree to first order.  Its
degrees of freedom are those of the fewest effective rows (Kish's :func:`effective_rows`
of each level's column) minus one, at least 1: a row that carries a level alone is one
observation of its own noise, which no row-based estimate sees.  The test is
:math:`(\hat\beta+1)/\mathrm{se}\sim t`.
The reported ratio :math:`\mathrm{RMSE}(N)/\mathrm{RMSE}(4N) = 4^{-\hat\beta/2}` with the
transformed CI (it contains 2 iff the slope CI contains -1).

Bias floor
----------
A biased estimator has :math:`E[\mathrm{MSE}] = C/N + B` with :math:`B` the mean squared
bias.  Fit :math:`\bar y_l = C/N_l + B` by weighted least squares with the fixed weights
:math:`N_l^2` (relative errors under the null model; fixed weights keep :math:`\hat B` linear
in the data and exactly unbiased, :math:`E\hat B=0`, for a correct estimator) and test :math:`B>0` one-sided
with the same replica covariance
(:math:`\hat B = a^\top\bar y`, :math:`\mathrm{Var}=a^\top\hat\Sigma a`).  The floor
sits where the two terms meet, :math:`N^* = \hat C/\hat B`; the RMS bias is
:math:`\sqrt{\hat B}` (relative to ``image_mean`` when given).  The slope test alone is
blind to a small bias (docs/statistics.md, "Measured before the tests were written": a 5 %
bias still gave slope -0.48): always pair this with
:func:`mitsuba_refs.stats.mean.compare_means`.

One-sided: only an error that falls too slowly fails
-----------------------------------------------------
The slope test is one-sided, :math:`H_0: \beta \le -1` against :math:`\beta > -1`: an error
that falls slower than :math:`N^{-1/2}` (RMSE; MSE slope above -1) or stops falling (the bias
floor) is a fault, one that falls faster is not.  Independent samples give exactly
:math:`E[\mathrm{MSE}] = \bar\sigma^2/N`; a renderer whose samples inside a pixel are
stratified (jittered, multi-jittered, orthogonal arrays, scrambled Sobol as in Cycles,
pbrt-v4 and Mitsuba's ``ldsampler``) has a smaller variance that falls faster (jittered
sampling of a d-dimensional integrand: :math:`N^{-1-2/d}` where it is smooth,
:math:`N^{-1-1/d}` across an edge; a path tracer's many dimensions leave it near :math:`N^{-1}`
in the end, so the measured slope lies between).  The other side is a detection, not a
failure: ``faster_p`` tests :math:`\beta < -1` one-sided at the caller's level and
``faster`` says the samples inside a render are not independent, which the variance verdict
needs to know (a per-sample variance from the spread of replicas times ``N / K`` is not one
when samples are stratified).  For a renderer with independent
samples both one-sided tests reject at most at their level (docs/statistics.md, section 3).
The fitted floor tests the same side as the slope: :math:`\hat B` is the least-squares
slope of :math:`N\bar y` on :math:`N` (the weights :math:`N^2` make it so), positive when
:math:`N\,\mathrm{MSE}` grows (slower than :math:`1/N`), negative when it falls (faster).

Correlated samples
------------------
If the error barely falls from the first level on (:math:`\hat\beta>-0.25` with the slope
test rejecting) the samples are not independent (random numbers reused).

Family: Šidák over the two components (slope, floor), both one-sided towards "too slow".
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats as sps

from ._tiles import sidak, sidak_per_test
from .mean import overflow_scale

__all__ = ["ConvergenceResult", "convergence_law", "effective_rows", "image_mse", "image_mse_parts",
           "mse_levels", "rare_errors_dominate", "reference_mse_floor", "MIN_EFFECTIVE_ROWS"]

#: Effective renders (:func:`effective_rows`) the lowest level needs for a calibrated t test.
MIN_EFFECTIVE_ROWS = 30
#: Below this many effective rows of a paired table the verdict says the slope is rough.
FEW_ROWS = 4


def image_mse(test_mean, ref_mean, ref_var, ref_n) -> float:
    r"""MSE of a test image against a noisy reference, with the reference's noise removed.

    .. math:: \widehat{\mathrm{MSE}} = \overline{(t-r)^2} - \overline{v_r/n_r}

    :math:`E[(t-r)^2] = \mathrm{MSE}(t) + \mathrm{Var}(r)` for independent renders and
    :math:`v_r/n_r` is unbiased for :math:`\mathrm{Var}(r)`, so the result is unbiased for
    the test's MSE (it can be slightly negative when the test is nearly exact).
    Averages run over all pixels and channels.
    """
    return image_mse_parts(test_mean, [np.asarray(ref_mean, dtype=np.float64)],
                           [reference_mse_floor(ref_var, ref_n)], [...])[0]


def image_mse_parts(test_mean, ref_means, floors, parts) -> list:
    """:func:`image_mse` of every part ``test_mean[part]`` of one test image.

    The reference's side is the same for every test image, so it comes precomputed:
    ``ref_means[i]`` is ``ref_mean[parts[i]]`` and ``floors[i]`` its
    :func:`reference_mse_floor` (the convergence test scores hundreds of renders against
    one reference).
    """
    t = np.asarray(test_mean, dtype=np.float64)
    # np.mean's own sum and division (same bits), without its per-call overhead.
    with np.errstate(over="ignore"):       # beyond float64 (images ~1e155 and up): +inf
        return [float(np.add.reduce((t[part] - r) ** 2, axis=None) / r.size - floor)
                for part, r, floor in zip(parts, ref_means, floors)]


def effective_rows(mse) -> float:
    r"""Kish's effective sample size :math:`(\sum y)^2 / \sum y^2` of one level's MSEs.

    Equal to the number of values when they are all alike, close to the number of rare
    large values when those dominate the mean.  Negative MSEs (possible after the
    reference-noise subtraction) count as zero.
    """
    y = np.maximum(np.asarray(mse, dtype=np.float64), 0.0)
    if np.any(np.isinf(y)):
        return float(np.sum(np.isinf(y)))    # the infinite values carry everything
    largest = float(y.max()) if y.size else 0.0
    if largest <= 0:
        return 0.0
    y = y / largest         # the ratio is scale-free; unscaled, (sum y)^2 overflows for y ~1e160
    return float(np.sum(y)) ** 2 / float(np.sum(y * y))


def rare_errors_dominate(image_mses) -> bool:
    """True when a few renders carry the mean MSE of a level (see the module notes).

    Parameters
    ----------
    image_mses : array (R,)
        Whole-image MSE of each render of the ladder's lowest level.
    """
    mses = np.asarray(image_mses, dtype=np.float64)
    effective = effective_rows(mses)
    return effective < MIN_EFFECTIVE_ROWS and effective < 0.8 * mses.size


def reference_mse_floor(ref_var, ref_n) -> float:
    """The reference's own noise contribution mean(v_r / n_r) that :func:`image_mse` subtracts."""
    v = np.asarray(ref_var, dtype=np.float64)
    n = np.asarray(ref_n, dtype=np.float64)
    if n.ndim == 2 and v.ndim == 3:
        n = n[..., None]
    return float(np.mean(np.maximum(v, 0) / n))


@dataclass(frozen=True, eq=False)
class ConvergenceResult:
    """Result of :func:`convergence_law`: numbers only (the words:
    :func:`mitsuba_refs.report.wording.convergence_verdict` and ``convergence_warnings``).

    Attributes
    ----------
    slope, slope_ci : float, (float, float)
        Fitted d log MSE / d log N (expected ``expected_slope``, -1) and its CI.
    ratio, ratio_ci : float, (float, float)
        RMSE(N)/RMSE(4N) = 4^(-slope/2) (expected 2) and its CI.
    p_value : float
        Family p-value (Šidák over slope test and floor test).
    floor_detected : bool
        The fitted bias term B > 0 is significant.
    slope_p, floor_p : float
        Component p-values, both one-sided towards an error that falls too slowly: slope
        above ``expected_slope``; B > 0.
    faster_p : float
        One-sided p-value of the slope below ``expected_slope`` (the error falls faster:
        samples inside a render are not independent, e.g. stratified). Not a failure.
    faster : bool
        ``faster_p <= alpha``: the renderer's samples are not independent within a pixel.
    floor_spp : float
        N* = C/B where bias and variance are equal (nan if no floor).
    bias_rms, bias_rel : float
        sqrt(B) and sqrt(B)/image_mean (nan if unknown).
    correlated : bool
        Error does not fall from the start (slope > -0.25 and rejected).
    passed : bool
        p_value > alpha.
    levels_used : tuple of int
        Ladder levels used in the fit (levels with non-positive mean MSE are dropped).
    expected_slope : float
        The slope of the null hypothesis.
    dropped_levels : tuple of int
        Levels (spp) left out for a non-positive mean MSE.
    noisy_reference_levels : tuple of int
        Levels (spp) whose mean MSE is below 4x the reference's own noise.
    rough_slope : bool
        A level's error rests on fewer than ``FEW_ROWS`` effective rows of a paired table.
    effective_rows : float
        The fewest effective rows of a level (paired tables; nan otherwise).
    rows : int
        Rows of a paired table (0 for independent levels).
    overflowed : bool
        The squared error overflowed float64: nothing was fitted.
    rare_replicas : int or None
        Set by the caller: rare bright paths still carried the error with this many
        replicas at the top level (None: they did not).
    looks : int
        Set by the caller: how many looks the test had, each at ``alpha`` (already divided
        among them by the caller); 1 for the fixed-budget test.
    stopped_early : bool
        Set by the caller: the law was rejected at a look before the last, and the renders
        of the later looks were not made.
    """

    slope: float
    slope_ci: tuple
    ratio: float
    ratio_ci: tuple
    p_value: float
    floor_detected: bool
    slope_p: float = math.nan
    floor_p: float = math.nan
    floor_spp: float = math.nan
    bias_rms: float = math.nan
    bias_rel: float = math.nan
    correlated: bool = False
    passed: bool = True
    alpha: float = 0.05
    levels_used: tuple = ()
    expected_slope: float = -1.0
    dropped_levels: tuple = ()
    noisy_reference_levels: tuple = ()
    rough_slope: bool = False
    effective_rows: float = math.nan
    rows: int = 0
    overflowed: bool = False
    rare_replicas: int | None = None
    faster_p: float = math.nan
    faster: bool = False
    looks: int = 1
    stopped_early: bool = False

    def __bool__(self) -> bool:
        return bool(self.passed)

    @property
    def rmse_exponent(self) -> float:
        """The exponent x of RMSE ~ N^x: half the MSE slope (-1/2 for independent samples)."""
        return self.slope / 2

    @property
    def rmse_exponent_ci(self) -> tuple:
        """The CI of :attr:`rmse_exponent` (half the slope's)."""
        return (self.slope_ci[0] / 2, self.slope_ci[1] / 2)


def mse_levels(mse, n_levels: int) -> tuple[list, np.ndarray | None]:
    """The MSEs of each level as float arrays, and the paired (K, L) table if given as one.

    ``mse`` is a (K, L) table (rows paired across levels) or a list / tuple of L 1-D arrays
    (independent levels).
    """
    if isinstance(mse, (list, tuple)) and len(mse) == n_levels and all(
            np.ndim(level) == 1 for level in mse):
        return [np.asarray(level, dtype=np.float64) for level in mse], None
    table = np.asarray(mse, dtype=np.float64)
    if table.ndim == 1:
        table = table[None, :]
    if table.ndim != 2 or table.shape[1] != n_levels:
        raise ValueError("mse must be a (K, L) table or L per-level arrays, with "
                         f"L = len(spp) = {n_levels}; got shape {np.shape(mse)}")
    return list(table.T), table


class _LevelMeans:
    """Mean MSE per level and the uncertainty of linear combinations of those means."""

    def __init__(self, mse, n_levels: int):
        self.levels, self.paired = mse_levels(mse, n_levels)
        sizes = [level.size for level in self.levels]
        if min(sizes) < 2:
            raise ValueError("need >= 2 replicas at every level to estimate the uncertainty")
        if not all(np.all(np.isfinite(level)) for level in self.levels):
            raise ValueError("mse contains NaN or inf")
        self.ybar = np.array([level.mean() for level in self.levels])
        self.sizes = np.array(sizes, dtype=np.float64)
        self.effective = math.nan     # fewest effective rows of a level (paired tables)

    def keep(self, mask) -> None:
        """Drop the levels where ``mask`` is False."""
        self.levels = [level for level, k in zip(self.levels, mask) if k]
        if self.paired is not None:
            self.paired = self.paired[:, mask]
        self.ybar, self.sizes = self.ybar[mask], self.sizes[mask]

    def slope_se_df(self, c) -> tuple[float, float]:
        """Standard error and degrees of freedom of the slope ``c @ log(ybar)``.

        Independent levels: the delta method (:meth:`se_df` of ``c / ybar``).  A paired
        table: the leave-one-row-out jackknife (see the module notes, "Slope"), because
        the delta method's row scores are normalised by the very means a dominant row
        makes, so that row's own noise never reaches the estimate.
        """
        c = np.asarray(c, dtype=np.float64)
        if self.paired is None:
            return self.se_df(c / self.ybar)
        k = len(self.paired)
        without = (self.paired.sum(axis=0) - self.paired) / (k - 1)   # (K, L) row k left out
        if np.any(without <= 0):
            # Some level's mean rests on one row alone: the slope has no usable error bar.
            return math.inf, float(k - 1)
        slopes = np.log(without) @ c
        se = math.sqrt((k - 1) / k * float(np.sum((slopes - slopes.mean()) ** 2)))
        # Rows that carry little of a level's mean add little information: the degrees of
        # freedom follow the fewest effective rows of any level (Kish), at least 1.
        self.effective = min(effective_rows(level) for level in self.paired.T)
        return se, float(min(k - 1, max(1.0, self.effective - 1.0)))

    def se_df(self, weights) -> tuple[float, float]:
        """Standard error and degrees of freedom of ``weights @ ybar``."""
        w = np.asarray(weights, dtype=np.float64)
        if self.paired is not None:
            cov = np.atleast_2d(np.cov(self.paired, rowvar=False, ddof=1)) / len(self.paired)
            return math.sqrt(max(float(w @ cov @ w), 0.0)), float(len(self.paired) - 1)
        parts = w ** 2 * np.array([level.var(ddof=1) for level in self.levels]) / self.sizes
        total = float(parts.sum())
        if total <= 0:
            return 0.0, float(self.sizes.min() - 1)
        return math.sqrt(total), total ** 2 / float(np.sum(parts ** 2 / (self.sizes - 1)))


def _pow4(x: float) -> float:
    """4**x, +inf instead of OverflowError (slopes of a wildly wrong image)."""
    return math.inf if x * math.log(4.0) > 709.0 else 4.0 ** x


def _overflowed(alpha: float) -> ConvergenceResult:
    """A failed result for MSEs beyond float64 (the image is astronomically far off)."""
    nan2 = (math.nan, math.nan)
    return ConvergenceResult(slope=math.nan, slope_ci=nan2, ratio=math.nan, ratio_ci=nan2,
                             p_value=0.0, floor_detected=False, slope_p=0.0,
                             floor_p=math.nan, passed=False, alpha=float(alpha), overflowed=True)


def _t_test(estimate: float, null: float, se: float, df: float, *, two_sided: bool) -> float:
    """p-value of ``estimate`` against ``null`` with a t distribution (exact when se = 0)."""
    if se <= 0:
        differs = estimate != null if two_sided else estimate > null
        return 0.0 if differs else 1.0
    t = (estimate - null) / se
    return float(2 * sps.t.sf(abs(t), df)) if two_sided else float(sps.t.sf(t, df))


def _usable_levels(N, mse, ref_mse_floor):
    """The level means of ``mse`` (scaled when huge), the levels kept (positive mean MSE), the
    dropped and the noisy-reference levels (spp), and the scale."""
    levels, table = mse_levels(mse, N.size)
    # MSEs of a wildly wrong image (~1e70 for values ~1e35) make their variances overflow;
    # every statistic below is invariant to a common scale except sqrt(B), scaled back.
    scale = overflow_scale(*levels, guard=1e100)
    if scale != 1.0:
        mse = table / scale if table is not None else [level / scale for level in levels]
        if ref_mse_floor is not None:
            ref_mse_floor = ref_mse_floor / scale
    data = _LevelMeans(mse, N.size)
    keep = data.ybar > 0
    dropped = tuple(N[~keep].astype(int).tolist())
    noisy = ()
    if ref_mse_floor is not None and np.any(keep & (data.ybar < 4 * ref_mse_floor)):
        noisy = tuple(N[keep & (data.ybar < 4 * ref_mse_floor)].astype(int).tolist())
    data.keep(keep)
    return data, N[keep], dropped, noisy, scale


def _bias_floor(N, data):
    """Fit ybar = C/N + B (WLS, weights N^2): ``(C, B, p of B > 0)``."""
    L = N.size
    X = np.column_stack([1.0 / N, np.ones(L)])
    W = N ** 2                 # relative errors under the null model y = C/N (data-independent weights)
    XtW = X.T * W
    Amat = np.linalg.solve(XtW @ X, XtW)                            # (2, L): coef = Amat @ ybar
    Chat, Bhat = (float(v) for v in Amat @ data.ybar)
    seB, dfB = data.se_df(Amat[1])
    return Chat, Bhat, _t_test(Bhat, 0.0, seB, dfB, two_sided=False)


def convergence_law(spp, mse, ref_mse_floor: float | None = None, *, alpha: float = 0.01,
                    ci_level: float = 0.95, image_mean: float | None = None,
                    expected_slope: float = -1.0) -> ConvergenceResult:
    r"""Test MSE(N) ∝ 1/N on a geometric spp ladder.

    Parameters
    ----------
    spp : array (L,)
        Sample counts, increasing (e.g. 1, 4, 16, 64, 256).
    mse : array (K, L), or sequence of L arrays
        Image MSEs, reference noise subtracted (:func:`image_mse`): a table whose rows are
        paired across levels, or one array per level for independent levels (lengths may
        differ; give every level the same total number of samples, see the module notes).
        At least 2 values per level.
    ref_mse_floor : float, optional
        The reference's own noise contribution (:func:`reference_mse_floor`).  Levels whose
        mean MSE is below 4x this are flagged (``noisy_reference_levels``): there the
        unmodelled error of the common reference (the same for all replicas) is no longer
        negligible.
    alpha : float
        Family level of the slope + floor tests.
    ci_level : float
        Level of the slope / ratio CIs.
    image_mean : float, optional
        Mean of the reference image, to express the bias floor in percent.
    expected_slope : float
        -1 for independent samples.

    Returns
    -------
    ConvergenceResult
    """
    N = np.asarray(spp, dtype=np.float64)
    if N.ndim != 1 or np.any(np.diff(N) <= 0) or N[0] <= 0:
        raise ValueError("spp must be positive and increasing")
    levels, _ = mse_levels(mse, N.size)
    if any(np.any(np.isnan(level)) for level in levels):
        raise ValueError("mse contains NaN")
    if any(np.any(np.isinf(level)) for level in levels):
        return _overflowed(alpha)   # pixel values beyond ~1e154
    data, N, dropped, noisy, scale = _usable_levels(N, mse, ref_mse_floor)
    if N.size < 3:
        raise ValueError("need >= 3 levels with positive MSE")

    # ---- slope ----------------------------------------------------------------------
    x = np.log(N)
    c = (x - x.mean()) / np.sum((x - x.mean()) ** 2)
    slope = float(c @ np.log(data.ybar))
    se, df = data.slope_se_df(c)
    # One-sided: only an error that falls more slowly than the law fails (module notes);
    # the other side says the samples are not independent within a render.
    slope_p = _t_test(slope, expected_slope, se, df, two_sided=False)
    faster_p = _t_test(-slope, -expected_slope, se, df, two_sided=False)
    tq = float(sps.t.ppf(0.5 + ci_level / 2, df))
    slope_ci = (slope - tq * se, slope + tq * se)
    rough = data.paired is not None and data.effective < FEW_ROWS
    ratio = _pow4(-slope / 2)
    ratio_ci = (_pow4(-slope_ci[1] / 2), _pow4(-slope_ci[0] / 2))

    # ---- bias floor: ybar = C/N + B, WLS with weights N^2 ------------------------
    Chat, Bhat, floor_p = _bias_floor(N, data)

    p_family = sidak(min(slope_p, floor_p), 2)
    passed = not (p_family <= alpha)
    a2 = sidak_per_test(alpha, 2)
    floor_detected = floor_p <= a2
    correlated = slope_p <= a2 and slope > -0.25
    floor_spp = Chat / Bhat if (floor_detected and Bhat > 0 and Chat > 0) else (
        0.0 if floor_detected else math.nan)
    bias_rms = math.sqrt(Bhat) * math.sqrt(scale) if floor_detected and Bhat > 0 else math.nan
    bias_rel = bias_rms / image_mean if (image_mean and math.isfinite(bias_rms)) else math.nan
    return ConvergenceResult(
        slope=slope, slope_ci=(float(slope_ci[0]), float(slope_ci[1])), ratio=float(ratio),
        ratio_ci=(float(ratio_ci[0]), float(ratio_ci[1])), p_value=float(p_family),
        floor_detected=bool(floor_detected), slope_p=slope_p, floor_p=floor_p,
        floor_spp=float(floor_spp), bias_rms=float(bias_rms), bias_rel=float(bias_rel),
        correlated=bool(correlated), passed=bool(passed), alpha=float(alpha),
        levels_used=tuple(int(v) for v in N), expected_slope=float(expected_slope),
        dropped_levels=dropped, noisy_reference_levels=noisy, rough_slope=bool(rough),
        effective_rows=float(data.effective),
        rows=0 if data.paired is None else len(data.paired),
        faster_p=float(faster_p), faster=bool(faster_p <= alpha))
