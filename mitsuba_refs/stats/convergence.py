r"""Does the error fall like :math:`N^{-1/2}`?  The convergence-law test on an spp ladder.

Input: a geometric ladder of sample counts :math:`N_1<\dots<N_L` and a (K, L) array of
per-replica image MSEs against a reference, with the reference's own noise subtracted
(:func:`image_mse`).  For an unbiased estimator with independent samples
:math:`E[\mathrm{MSE}(N)] = \bar\sigma^2/N` exactly (mean per-sample variance over pixels).

Slope
-----
Let :math:`\bar y_l` be the replica mean at level :math:`l` and :math:`x_l=\log N_l`.  The
least-squares slope of :math:`\log\bar y_l` on :math:`x_l` is :math:`\hat\beta=\sum_l c_l\log\bar y_l`,
:math:`c_l=(x_l-\bar x)/\sum(x_l-\bar x)^2`.  Its variance by the delta method, with the level
covariance estimated from the K replicas (so nested/progressive ladders whose levels share
samples are handled too):

.. math:: \widehat{\mathrm{Var}}(\hat\beta) = g^\top \frac{\hat\Sigma}{K} g,\qquad g_l = c_l/\bar y_l,

:math:`\hat\Sigma` the sample covariance of the rows.  :math:`(\hat\beta+1)/\mathrm{se}\sim t_{K-1}`.
The reported ratio :math:`\mathrm{RMSE}(N)/\mathrm{RMSE}(4N) = 4^{-\hat\beta/2}` with the
transformed CI (it contains 2 iff the slope CI contains -1).

Bias floor
----------
A biased estimator has :math:`E[\mathrm{MSE}] = C/N + B` with :math:`B` the mean squared
bias.  Fit :math:`\bar y_l = C/N_l + B` by weighted least squares with the fixed weights
:math:`N_l^2` (relative errors under the null model; fixed weights keep :math:`\hat B` linear
in the data and exactly unbiased, :math:`E\hat B=0`, for a correct estimator) and test :math:`B>0` one-sided with the same replica covariance
(:math:`\hat B = a^\top\bar y`, :math:`\mathrm{Var}=a^\top\hat\Sigma a/K`, :math:`t_{K-1}`).  The floor
sits where the two terms meet, :math:`N^* = \hat C/\hat B`; the RMS bias is
:math:`\sqrt{\hat B}` (relative to ``image_mean`` when given).  The slope test alone is
blind to a small bias (DESIGN.md: 5 % bias still gave slope -0.48): always pair this with
:func:`mitsuba_refs.stats.mean.compare_means`.

Correlated samples
------------------
If the error barely falls from the first level on (:math:`\hat\beta>-0.25` with the slope
test rejecting) the samples are not independent (random numbers reused).

Family: Šidák over the two components (slope, floor).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats as sps

from ._tiles import sidak, sidak_per_test

__all__ = ["ConvergenceResult", "convergence_law", "image_mse", "reference_mse_floor"]


def image_mse(test_mean, ref_mean, ref_var, ref_n) -> float:
    r"""MSE of a test image against a noisy reference, with the reference's noise removed.

    .. math:: \widehat{\mathrm{MSE}} = \overline{(t-r)^2} - \overline{v_r/n_r}

    :math:`E[(t-r)^2] = \mathrm{MSE}(t) + \mathrm{Var}(r)` for independent renders and
    :math:`v_r/n_r` is unbiased for :math:`\mathrm{Var}(r)`, so the result is unbiased for
    the test's MSE (it can be slightly negative when the test is nearly exact).
    Averages run over all pixels and channels.
    """
    t = np.asarray(test_mean, dtype=np.float64)
    r = np.asarray(ref_mean, dtype=np.float64)
    v = np.asarray(ref_var, dtype=np.float64)
    n = np.asarray(ref_n, dtype=np.float64)
    if n.ndim == 2 and v.ndim == 3:
        n = n[..., None]
    return float(np.mean((t - r) ** 2) - np.mean(np.maximum(v, 0) / n))


def reference_mse_floor(ref_var, ref_n) -> float:
    """The reference's own noise contribution mean(v_r / n_r) that :func:`image_mse` subtracts."""
    v = np.asarray(ref_var, dtype=np.float64)
    n = np.asarray(ref_n, dtype=np.float64)
    if n.ndim == 2 and v.ndim == 3:
        n = n[..., None]
    return float(np.mean(np.maximum(v, 0) / n))


@dataclass(frozen=True, eq=False)
class ConvergenceResult:
    """Result of :func:`convergence_law`.

    Attributes
    ----------
    slope, slope_ci : float, (float, float)
        Fitted d log MSE / d log N (expected -1) and its CI.
    ratio, ratio_ci : float, (float, float)
        RMSE(N)/RMSE(4N) = 4^(-slope/2) (expected 2) and its CI.
    p_value : float
        Family p-value (Šidák over slope test and floor test).
    floor_detected : bool
        The fitted bias term B > 0 is significant.
    verdict : str
        One line.
    slope_p, floor_p : float
        Component p-values (two-sided slope = -1; one-sided B > 0).
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
    """

    slope: float
    slope_ci: tuple
    ratio: float
    ratio_ci: tuple
    p_value: float
    floor_detected: bool
    verdict: str
    slope_p: float = math.nan
    floor_p: float = math.nan
    floor_spp: float = math.nan
    bias_rms: float = math.nan
    bias_rel: float = math.nan
    correlated: bool = False
    passed: bool = True
    alpha: float = 0.05
    levels_used: tuple = ()
    warnings: tuple = ()

    def __bool__(self) -> bool:
        return bool(self.passed)


def _fmt_p(p: float) -> str:
    return f"{p:.2f}" if p >= 0.01 else (f"{p:.1e}" if p > 0 else "<1e-300")


def convergence_law(spp, mse, ref_mse_floor: float | None = None, *, alpha: float = 0.01,
                    ci_level: float = 0.95, image_mean: float | None = None,
                    expected_slope: float = -1.0) -> ConvergenceResult:
    r"""Test MSE(N) ∝ 1/N on a geometric spp ladder with K replicas.

    Parameters
    ----------
    spp : array (L,)
        Sample counts, increasing (e.g. 1, 4, 16, 64, 256).
    mse : array (K, L)
        Per-replica MSE at each level, reference noise subtracted (:func:`image_mse`), K >= 2.
    ref_mse_floor : float, optional
        The reference's own noise contribution (:func:`reference_mse_floor`).  Levels whose
        mean MSE is below 4x this are flagged in ``warnings``: there the unmodelled error
        of the common reference (the same for all replicas) is no longer negligible.
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
    Y = np.asarray(mse, dtype=np.float64)
    if Y.ndim == 1:
        Y = Y[None, :]
    if Y.ndim != 2 or Y.shape[1] != N.size:
        raise ValueError(f"mse must be (K, L) with L = len(spp) = {N.size}, got {Y.shape}")
    if np.any(np.diff(N) <= 0) or N[0] <= 0:
        raise ValueError("spp must be positive and increasing")
    K = Y.shape[0]
    if K < 2:
        raise ValueError("need K >= 2 replicas to estimate the uncertainty")
    if not np.all(np.isfinite(Y)):
        raise ValueError("mse contains NaN or inf")
    ybar = Y.mean(axis=0)
    keep = ybar > 0
    warnings = []
    if not keep.all():
        warnings.append(f"dropped levels with non-positive mean MSE: {N[~keep].astype(int).tolist()}")
    if ref_mse_floor is not None and np.any(keep & (ybar < 4 * ref_mse_floor)):
        warnings.append("reference noise comparable to the test error at spp "
                        f"{N[keep & (ybar < 4 * ref_mse_floor)].astype(int).tolist()}: use a longer reference")
    N, Y, ybar = N[keep], Y[:, keep], ybar[keep]
    L = N.size
    if L < 3:
        raise ValueError("need >= 3 levels with positive MSE")
    Sig = np.atleast_2d(np.cov(Y, rowvar=False, ddof=1)) / K       # covariance of ybar
    df = K - 1
    tq = float(sps.t.ppf(0.5 + ci_level / 2, df))

    # ---- slope ----------------------------------------------------------------------
    x = np.log(N)
    c = (x - x.mean()) / np.sum((x - x.mean()) ** 2)
    slope = float(c @ np.log(ybar))
    g = c / ybar
    se = math.sqrt(max(float(g @ Sig @ g), 0.0))
    if se > 0:
        t_s = (slope - expected_slope) / se
        slope_p = float(2 * sps.t.sf(abs(t_s), df))
    else:
        slope_p = 1.0 if slope == expected_slope else 0.0
    slope_ci = (slope - tq * se, slope + tq * se)
    ratio = 4.0 ** (-slope / 2)
    ratio_ci = (4.0 ** (-slope_ci[1] / 2), 4.0 ** (-slope_ci[0] / 2))

    # ---- bias floor: ybar = C/N + B, WLS with weights N^2 ------------------------
    X = np.column_stack([1.0 / N, np.ones(L)])
    W = N ** 2                 # relative errors under the null model y = C/N (data-independent weights)
    XtW = X.T * W
    Amat = np.linalg.solve(XtW @ X, XtW)                            # (2, L): coef = Amat @ ybar
    Chat, Bhat = (float(v) for v in Amat @ ybar)
    aB = Amat[1]
    seB = math.sqrt(max(float(aB @ Sig @ aB), 0.0))
    if seB > 0:
        floor_p = float(sps.t.sf(Bhat / seB, df))
    else:
        floor_p = 0.0 if Bhat > 0 else 1.0

    p_family = sidak(min(slope_p, floor_p), 2)
    passed = not (p_family <= alpha)
    a2 = sidak_per_test(alpha, 2)
    floor_detected = floor_p <= a2
    slope_rejected = slope_p <= a2
    correlated = slope_rejected and slope > -0.25
    floor_spp = Chat / Bhat if (floor_detected and Bhat > 0 and Chat > 0) else (
        0.0 if floor_detected else math.nan)
    bias_rms = math.sqrt(Bhat) if floor_detected and Bhat > 0 else math.nan
    bias_rel = bias_rms / image_mean if (image_mean and math.isfinite(bias_rms)) else math.nan

    # ---- verdict ------------------------------------------------------------------------
    law = (f"slope {slope:.3f} [{slope_ci[0]:.3f}, {slope_ci[1]:.3f}], "
           f"RMSE(N)/RMSE(4N) = {ratio:.2f} [{ratio_ci[0]:.2f}, {ratio_ci[1]:.2f}]")
    if passed:
        verdict = f"converges as N^-1/2 (p={_fmt_p(p_family)}): {law}"
    elif correlated:
        verdict = (f"error does not fall: samples are correlated / random numbers reused "
                   f"(p={_fmt_p(p_family)}): {law}")
    elif floor_detected:
        btxt = f"{100 * bias_rel:.2g}% of the mean" if math.isfinite(bias_rel) else f"RMS {bias_rms:.3g}"
        where = f"~{floor_spp:.0f} spp" if floor_spp > 0 else "the first level"
        verdict = (f"bias floor: error stops falling at {where} (bias \u2248 {btxt}) "
                   f"(p={_fmt_p(p_family)}): {law}")
    elif slope < expected_slope:
        verdict = f"error falls faster than N^-1/2 (stratified or correlated across levels?) (p={_fmt_p(p_family)}): {law}"
    else:
        verdict = f"error falls slower than N^-1/2 (p={_fmt_p(p_family)}): {law}"
    if warnings:
        verdict += " [" + "; ".join(warnings) + "]"
    return ConvergenceResult(
        slope=slope, slope_ci=(float(slope_ci[0]), float(slope_ci[1])), ratio=float(ratio),
        ratio_ci=(float(ratio_ci[0]), float(ratio_ci[1])), p_value=float(p_family),
        floor_detected=bool(floor_detected), verdict=verdict, slope_p=slope_p, floor_p=floor_p,
        floor_spp=float(floor_spp), bias_rms=float(bias_rms), bias_rel=float(bias_rel),
        correlated=bool(correlated), passed=bool(passed), alpha=float(alpha),
        levels_used=tuple(int(v) for v in N), warnings=tuple(warnings))
