"""The words of the verdicts: every sentence the reports print about a statistical result.

The tests of :mod:`mitsuba_refs.stats` return frozen results of numbers (p-values,
intervals, flags, counts, tile indices); this module says them: the verdict lines of the
mean, variance and convergence tests and of the bounce sweep, where in the image the
evidence sits, what a mean test could see (:mod:`mitsuba_refs.stats.detectable`) and the
headline. The command line, the JSON records, JUnit, HTML, the pictures' titles, the hints
and the grader all take their words from here, so that a sentence is written in one place.

One formatter each for a p-value (:func:`format_p`) and a percentage (:func:`percent`).
"""
from __future__ import annotations

import math

import numpy as np

from ..stats.bounce import depth_order
from ..stats.detectable import DetectableBias, weak_agreement
from .encoding import to_float

__all__ = ["format_p", "percent", "region_name", "mean_verdict", "mean_region",
           "variance_verdict", "variance_policy_verdict", "variance_region",
           "variance_not_independent", "VARIANCE_NO_ESTIMATOR", "VARIANCE_NOT_STATED",
           "MEAN_WITH_STRATIFIED_VARIANCE",
           "convergence_verdict", "convergence_warnings", "rmse_rate", "depth_name", "bounce_verdict",
           "verdict_line", "sees", "status_text", "mean_line", "convention_text"]

#: How a verdict line writes a p-value that is not a number (the reports' tables write "–").
NO_P = "<1e-300"


# ---- numbers ---------------------------------------------------------------------------------
def format_p(value, *, missing: str = "–", digits: int | None = None) -> str:
    """A p-value as the reports write it: ``0.53``, ``2.2e-26``, ``<1e-300`` for 0.

    ``missing`` is written for None or NaN (the verdict lines pass :data:`NO_P`, which they
    always wrote there); ``digits`` significant digits throughout (the bounce line's
    ``3e-09``, ``0.5``) instead of two decimals from 0.01 and two significant digits below.
    """
    if value is None:
        return missing
    p = to_float(value)
    if math.isnan(p):
        return missing
    if digits is not None:
        return f"{p:.{digits}g}" if p > 0 else "<1e-300"
    if p >= 0.01:
        return f"{p:.2f}"
    return f"{p:.1e}" if p > 0 else "<1e-300"


def percent(x: float, *, signed: bool = False, minus: str = "\u2212") -> str:
    """A fraction in percent.

    Unsigned (the detectable bias, ``--detect``): ``2.4%``, ``13%``, ``0.02%``; ``any`` when not
    finite. ``signed`` (a relative bias): ``+1.0%``, one decimal, or one significant digit
    below 0.05 % (``-0.04%``, never ``-0.0%``), the minus sign ``minus`` (the verdict lines'
    U+2212; the reports' interval texts pass ``"-"``).
    """
    if signed:
        return f"{_one_decimal(100 * x, '+')}%".replace("-", minus)
    if not math.isfinite(x):
        return "any"
    value = 100.0 * x
    if value >= 10:
        return f"{value:.0f}%"
    return f"{value:.1f}%" if value >= 0.1 else f"{value:.2g}%"


def _one_decimal(value: float, sign: str = "") -> str:
    """``value`` with one decimal, or one significant digit when that decimal would be 0."""
    if value == 0 or not math.isfinite(value) or abs(value) >= 0.05:
        return f"{value + 0.0:{sign}.1f}"        # + 0.0: no "-0.0"
    return f"{value:{sign}.1g}"


def region_name(row_center: float, col_center: float, h: float, w: float) -> str:
    """Name the 3x3 region of an image (top-left, top, ..., center, ..., bottom-right)."""
    r = min(2, max(0, int(3 * row_center / h)))
    c = min(2, max(0, int(3 * col_center / w)))
    vert = ["top", "", "bottom"][r]
    horz = ["left", "", "right"][c]
    if not vert and not horz:
        return "center"
    if vert and horz:
        return f"{vert}-{horz}"
    return vert or horz


def _recorded(result, name: str) -> str | None:
    """The words a result recorded in words carries under ``name`` (the compact evidence of
    :mod:`autograder.hints.evidence_io` keeps a verdict's line and region as it was printed), or
    None for a result of numbers."""
    value = getattr(result, name, None)
    return value if isinstance(value, str) else None


def _tile_region(worst_tile, tile: int, shape) -> str:
    """The region of a tile (row, col, ...) of an image of ``shape``; "nowhere" for None."""
    if worst_tile is None:
        return "nowhere"
    h, w = shape
    return region_name((worst_tile[0] + 0.5) * tile, (worst_tile[1] + 0.5) * tile, h, w)


# ---- the mean test ---------------------------------------------------------------------------
def _span(indices) -> str:
    return f"{indices[0]}" if indices[0] == indices[-1] else f"{indices[0]}-{indices[-1]}"


def _significant_where(mean) -> tuple:
    """Where a disagreeing mean test's significant tiles are: (tiles, rows, cols, where)."""
    any_sig = np.asarray(mean.significant).any(axis=2)
    rows = np.flatnonzero(any_sig.any(axis=1))
    cols = np.flatnonzero(any_sig.any(axis=0))
    h, w = mean.shape
    tile = mean.tile
    spread = (rows[-1] - rows[0] + 1) * tile >= h / 2 and (cols[-1] - cols[0] + 1) * tile >= w / 2
    if spread and int(any_sig.sum()) >= max(4, any_sig.size // 4):
        where = "whole image"
    else:
        where = f"{_tile_region(mean.worst_tile, tile, mean.shape)} region"
    return any_sig, rows, cols, where


def mean_region(mean) -> str:
    """Where the mean test's worst evidence sits in words ("top-left", "center", "whole image",
    "nowhere" when no tile carries evidence)."""
    recorded = _recorded(mean, "worst_region")
    if recorded is not None:
        return recorded
    region = _tile_region(mean.worst_tile, mean.tile, mean.shape)
    if mean.agree:
        return region
    if mean.n_significant:
        where = _significant_where(mean)[3]
        return where if where == "whole image" else region
    return "whole image"


def _bias_text(mean) -> str:
    low, high = mean.rel_bias_ci
    return (f"relative bias {percent(mean.rel_bias, signed=True)} "
            f"[{percent(low, signed=True)}, {percent(high, signed=True)}]")


def _mean_evidence(mean) -> list:
    """What a disagreeing mean test saw: significant tiles, or the whole-image means."""
    if mean.n_significant:
        any_sig, rows, cols, where = _significant_where(mean)
        parts = [f"{int(any_sig.sum())} of {any_sig.size} {mean.tile}px tiles, largest "
                 f"|z|={abs(mean.worst_z):.1f} at tile rows {_span(rows)}, cols {_span(cols)} "
                 f"({where})"]
        if mean.bounded_only:
            parts.append(f"with at most {mean.max_var_ratio:g}x the reference's variance (your own "
                         f"variance is so large that it hides the difference)")
        return parts
    components = mean.scale_p_values
    if (mean.bounded_z is not None
            and components["image, bounded variance"] < components["image"]):
        return [f"the whole-image means differ by far more than the noise of an estimator with "
                f"at most {mean.max_var_ratio:g}x the reference's variance "
                f"(max |z|={np.max(np.abs(mean.bounded_z)):.1f}; "
                f"with the image's own variance {np.max(np.abs(mean.image_z)):.1f})"]
    return [f"no single tile stands out (largest |z|={abs(mean.worst_z):.1f}); whole-image means "
            f"differ (max |z|={np.max(np.abs(mean.image_z)):.1f})"]


def _brightness(mean) -> str:
    """The image-level bias of a disagreeing mean test."""
    rel, (low, high) = mean.rel_bias, mean.rel_bias_ci
    if math.isfinite(rel) and rel > 1.0:
        # a factor reads better than thousands of percent (e.g. a render 930x too bright)
        return f"image {1 + rel:.3g}x too bright"
    if (low > 0 or high < 0) and math.isfinite(rel):
        word = "too dark" if rel < 0 else "too bright"
        near, far = (low, high) if rel > 0 else (high, low)
        return (f"image {_one_decimal(100 * abs(rel))}% {word} "
                f"[{_one_decimal(100 * abs(near))}%, {_one_decimal(100 * abs(far))}%]")
    if rel == math.inf:
        return "image bright where the reference is black"
    return f"image-level {_bias_text(mean)} (not significant)"


def mean_verdict(mean) -> str:
    """The mean test's line, e.g. ``agree (p=0.53); relative bias +0.1% [−0.4%, +0.6%]``.

    ``mean`` is a :class:`~mitsuba_refs.stats.mean.MeanAgreement`, or a result with ``faults``
    (an external renderer's impossible values, :mod:`mitsuba_refs.external.check`).
    """
    recorded = _recorded(mean, "verdict")
    if recorded is not None:
        return recorded
    faults = getattr(mean, "faults", None)
    if faults:
        return "disagree: the renderer's images hold impossible values: " + "; ".join(faults)
    p = format_p(mean.p_value, missing=NO_P)
    if mean.agree:
        return f"agree (p={p}); {_bias_text(mean)}"
    return f"disagree (p={p}): " + ", ".join(_mean_evidence(mean) + [_brightness(mean)])


# ---- the variance test -----------------------------------------------------------------------
def _ratio_text(variance) -> str:
    low, high = variance.ratio_ci
    return f"{variance.ratio:.2f}\u00d7 the reference [{low:.2f}, {high:.2f}]"


def variance_region(variance) -> str:
    """Where the variance test's worst tile is in words ("nowhere" when no tile carries any)."""
    return _tile_region(variance.worst_tile, variance.tile, variance.shape)


def variance_verdict(variance) -> str:
    """The variance test's line, e.g. ``variance 3.1× the reference [2.8, 3.4] (p=1e-20)``."""
    p = format_p(variance.p_value, missing=NO_P)
    ratio = _ratio_text(variance)
    if variance.agree:
        return f"variance agrees (p={p}): {ratio}"
    parts = [f"variance {ratio}" if variance.global_significant
             else f"global variance {ratio} (not significant)"]
    if variance.n_outliers:
        row, col = variance.worst_tile
        parts.append(f"{variance.n_outliers} tile(s) with excess variance, worst at tile row {row}, "
                     f"col {col} ({variance_region(variance)} region)")
    return f"variance disagrees (p={p}): " + "; ".join(parts)


#: Why a comparison has no variance verdict, in words (``Comparison.variance_not_applicable``
#: adds the measured ratio where both images have a variance).
VARIANCE_NO_ESTIMATOR = "not applicable: Mitsuba has no run of this estimator (mean only)"
VARIANCE_NOT_STATED = ("not applicable: --same-estimator was not given (per-sample variances "
                       "are comparable only when the renderer runs the reference's estimator, "
                       "which only its user can say)")


#: A check's note when the mean test took the renderer's own per-sample variance channels
#: and its samples turned out not to be independent within a pixel.
MEAN_WITH_STRATIFIED_VARIANCE = (
    "the mean test took the per-sample variance the renderer wrote, which overstates the "
    "noise of stratified samples (the test is conservative: it sees less than it could); "
    "images without variance channels make the harness use the spread of independent replicas")


def variance_not_independent(law) -> str:
    """Why the variance verdict does not apply to a renderer whose samples are stratified:
    the convergence verdict ``law`` measured its error falling faster than N^-1/2."""
    return (f"not applicable: the renderer's samples are not independent within a pixel (its "
            f"error falls as {rmse_rate(law)}, faster than independent samples' N^-1/2, "
            f"p={format_p(law.faster_p, missing=NO_P)}), so no per-sample variance describes "
            "its noise; not counted as a disagreement")


def variance_policy_verdict(variance) -> str:
    """The one-sided policy's line, e.g. ``variance within 1.5x the reference (p=1.00): ...``."""
    recorded = _recorded(variance, "policy_verdict")
    if recorded is not None:
        return recorded
    side = "within" if variance.policy_agree else "above"
    return (f"variance {side} {variance.max_ratio:g}x the reference "
            f"(p={format_p(variance.policy_p, missing=NO_P)}): {_ratio_text(variance)}")


# ---- the convergence test --------------------------------------------------------------------
_OVERFLOWED = ("the error is too large to compute: the squared error overflows float64 (pixel "
               "values beyond ~1e154) (the image is astronomically far from the reference, e.g. "
               "a weight that grows without bound)")


def _rare_note(law) -> list:
    if law.rare_replicas is None:
        return []
    return [f"rare bright paths carry the error even with {law.rare_replicas} replicas at the top "
            "level: this verdict is less reliable"]


def _looks_note(law) -> list:
    """How the test looked at the ladder when it did so more than once (``--tolerance``)."""
    looks = getattr(law, "looks", 1)
    if looks <= 1:
        return []
    if getattr(law, "stopped_early", False):
        return [f"decided at the first of {looks} looks, after half the ladder's renders "
                f"(each look at alpha/{looks})"]
    return [f"{looks} looks, each at alpha/{looks}"]


def _fit_warnings(law) -> list:
    """The convergence fit's own warnings (not the caller's rare-paths note)."""
    if law.overflowed:
        return [_OVERFLOWED]
    out = []
    if law.dropped_levels:
        out.append(f"dropped levels with non-positive mean MSE: {list(law.dropped_levels)}")
    if law.noisy_reference_levels:
        out.append("reference noise comparable to the test error at spp "
                   f"{list(law.noisy_reference_levels)}: use a longer reference")
    if law.rough_slope:
        out.append(f"one level's error rests on ~{law.effective_rows:.0f} of {law.rows} "
                   "rows (e.g. a light smaller than a pixel in one image block): the slope "
                   "is known only roughly and the test has little power")
    return out


def convergence_warnings(law) -> list:
    """The convergence verdict's warnings, one line each."""
    return _fit_warnings(law) + _rare_note(law)


def rmse_rate(law) -> str:
    """The measured law in words, as the RMSE's exponent (half the MSE slope) with its CI:
    ``N^-0.500 [-0.521, -0.479]``. The reports never print an MSE slope beside ``N^-1/2``."""
    low, high = (bound / 2 for bound in law.slope_ci)      # RMSE = sqrt(MSE)
    return f"N^{law.slope / 2:.3f} [{low:.3f}, {high:.3f}]"


def _law_text(law) -> str:
    (r0, r1) = law.ratio_ci
    return (f"error (RMSE) falls as {rmse_rate(law)}, "
            f"RMSE(N)/RMSE(4N) = {law.ratio:.2f} [{r0:.2f}, {r1:.2f}]")


def _convergence_outcome(law) -> str:
    p, fit = format_p(law.p_value, missing=NO_P), _law_text(law)
    if law.passed and getattr(law, "faster", False):
        return (f"converges, faster than N^-1/2 (p={p}): {fit}: faster than independent "
                "samples, as stratified or low-discrepancy sampling does (the samples inside "
                "a pixel are not independent; not a fault)")
    if law.passed:
        return f"converges as N^-1/2 (p={p}): {fit}"
    if law.correlated:
        return f"error does not fall: samples are correlated / random numbers reused (p={p}): {fit}"
    if law.floor_detected:
        # The floor is a per-pixel RMS error: pixels biased both ways add up here while they
        # may cancel in the image mean that the mean verdict's relative bias measures.
        btxt = (f"{100 * law.bias_rel:.2g}% of the image mean" if math.isfinite(law.bias_rel)
                else f"{law.bias_rms:.3g}")
        where = f"~{law.floor_spp:.0f} spp" if law.floor_spp > 0 else "the first level"
        return (f"bias floor: error stops falling at {where} (per-pixel RMS bias \u2248 {btxt}) "
                f"(p={p}): {fit}")
    return (f"error falls slower than N^-1/2 (p={p}): {fit}: slower than independent samples "
            "(a bias that fades only slowly, samples positively correlated inside a render, or "
            "a renderer that renders more samples than asked at the lowest levels, as Mitsuba's "
            "ldsampler rounds 1 spp up to 4)")


def convergence_verdict(law) -> str:
    """The convergence test's line, its warnings in brackets."""
    if law.overflowed:
        text = _OVERFLOWED
    else:
        text = _convergence_outcome(law)
        warnings = _fit_warnings(law)
        if warnings:
            text += " [" + "; ".join(warnings) + "]"
    return text + "".join(f" [{note}]" for note in _rare_note(law) + _looks_note(law))


# ---- the bounce sweep ------------------------------------------------------------------------
def depth_name(depth: int) -> str:
    """Human name of a Mitsuba max_depth."""
    if depth < 0:
        return "full paths (unbounded depth)"
    if depth == 0:
        return "nothing (depth 0)"
    if depth == 1:
        return "directly visible emitters (bounce 1)"
    if depth == 2:
        return "direct light (bounce 2)"
    if depth == 3:
        return "one indirect bounce (bounce 3)"
    return f"{depth - 2} indirect bounces (bounce {depth})"


def bounce_verdict(results, line=None) -> tuple:
    """The first diverging depth of a max_depth sweep and the sweep in words: ``(depth, text)``.

    ``results`` maps a depth to its mean result (:func:`mitsuba_refs.stats.first_diverging_bounce`
    reads it); ``line`` gives a result's own line (default :func:`mean_verdict`). The text is
    e.g. "direct light (bounce 2) already disagrees (p=3e-09): ...; directly visible emitters
    (bounce 1) agree".
    """
    line = mean_verdict if line is None else line
    if not results:
        return None, "no depths compared"
    order = depth_order(results)
    bad = [d for d in order if not results[d].agree]
    if not bad:
        return None, f"all depths agree ({', '.join(str(d) for d in order)})"
    first = bad[0]
    result = results[first]
    ok_below = order[:order.index(first)]
    p = format_p(result.p_value, missing=NO_P, digits=2)
    detail = line(result)
    # The line says "disagree (p=...): why" itself: its verdict and p are not repeated.
    if detail.startswith("disagree (p="):
        detail = detail[len("disagree "):]
    else:
        detail = f"(p={p}): {detail}"
    text = f"{depth_name(first)} {'already ' if first == order[0] else ''}disagrees {detail}"
    if ok_below:
        text += ("; " + ", ".join(depth_name(d) for d in ok_below)
                 + (" agrees" if len(ok_below) == 1 else " agree"))
        text += f" -> look at what depth {first} adds"
    later_ok = [d for d in order[order.index(first) + 1:] if results[d].agree]
    if later_ok:
        text += (f"; note: deeper depths {later_ok} agree again (a small error at depth {first} "
                 "can drown in more noise deeper, not a contradiction)")
    return first, text


def verdict_line(result) -> str:
    """The line of any statistical result: mean, variance (its equality test) or convergence."""
    if hasattr(result, "policy_p"):
        return variance_verdict(result)
    if hasattr(result, "slope"):
        return convergence_verdict(result)
    return mean_verdict(result)


# ---- what a comparison could see, and the headline -------------------------------------------
def sees(bound: DetectableBias) -> str:
    """What a mean test could see: "detects a global bias of +2.4% / −2.3% with probability ..."."""
    if not math.isfinite(bound.bias):
        return "a global bias is invisible to it (the reference image is black)"
    where = ", tiles only" if bound.component == "tiles" else ""
    return (f"detects a global bias of +{percent(bound.brighter)} / \u2212{percent(bound.darker)} "
            f"with probability {bound.power:g} (alpha {bound.alpha:.2g}{where})")


def _is_weak(result) -> bool:
    return weak_agreement(result.agree, getattr(result, "detectable", None))


def status_text(result) -> str:
    """The headline's verdict: AGREES (weakly, with what it could not see) or DISAGREES; with a
    tolerance AGREES within +-T %, DISAGREES or INCONCLUSIVE."""
    rounds = getattr(result, "rounds", None)
    if rounds is not None:
        outcome = result.outcome
        if outcome == "AGREES":
            return f"AGREES with Mitsuba within \u00b1{rounds.tolerance_percent:g}%"
        return f"{outcome} with Mitsuba" + (f" (tolerance \u00b1{rounds.tolerance_percent:g}%)"
                                            if outcome == "INCONCLUSIVE" else "")
    if not result.agree:
        return "DISAGREES with Mitsuba"
    if _is_weak(result):
        return f"AGREES with Mitsuba, weakly (could not see less than {percent(result.detectable.bias)})"
    return "AGREES with Mitsuba"


def mean_line(result) -> str:
    """The mean verdict line of a comparison, with what the test could see."""
    if getattr(result, "rounds", None) is not None and not hasattr(result.mean, "faults"):
        return rounds_line(result.rounds)
    verdict = mean_verdict(result.mean)
    bound = getattr(result, "detectable", None)
    if bound is None:
        return verdict
    if _is_weak(result):
        verdict = verdict.replace("agree", f"agrees, but could not see less than "
                                  f"{percent(bound.bias)}", 1)
        if bound.floor <= 0.02:
            hint = "--detect 2% picks the spp that would see 2%"
        else:
            hint = f"the reference's own noise alone hides less than {percent(bound.floor)}"
        return f"{verdict}; {sees(bound)}; {hint}"
    return f"{verdict}; {sees(bound)}"


def rounds_line(rounds) -> str:
    """The mean's three-outcome line: outcome, tolerance, interval reached, samples and, when
    undecided, what would decide."""
    d, tol = rounds.decision, rounds.tolerance_percent
    low, high = (percent(x, signed=True) for x in d.interval)
    last = rounds.looks[-1]
    head = {"AGREES": f"agrees within \u00b1{tol:g}%", "DISAGREES": f"disagrees beyond \u00b1{tol:g}%",
            "INCONCLUSIVE": f"inconclusive at \u00b1{tol:g}%"}[rounds.outcome]
    text = (f"{head}: relative bias {percent(d.rel_bias, signed=True)}, interval [{low}, {high}] "
            f"(level {1 - 2 * d.alpha:.4g}) after {len(rounds.looks)} round"
            f"{'s' if len(rounds.looks) != 1 else ''}, {last['spp']} spp of at most {rounds.max_spp}")
    if d.beyond_tiles:
        text += f"; {d.beyond_tiles} tile{'s' if d.beyond_tiles != 1 else ''} beyond the tolerance"
    if rounds.reference_pieces > 1:
        text += (f"; the reference extended to {rounds.reference_spp} spp "
                 f"({rounds.reference_pieces} cached pieces)")
    if rounds.outcome != "INCONCLUSIVE":
        return text
    stop = "the time budget" if rounds.stopped_by == "seconds" else "the sample budget"
    if rounds.reference_limited:
        return f"{text}; {stop} ran out, and the reference's own noise alone keeps it " \
               "undecided: a longer reference (or a wider --tolerance) would decide"
    if math.isfinite(rounds.spp_needed):
        return f"{text}; {stop} ran out: about --max-spp {max_spp_to_give(rounds.spp_needed)} would decide"
    return (f"{text}; {stop} ran out, with the observed bias at the tolerance (more samples "
            "decide only if it moves off it)")


def max_spp_to_give(spp: float) -> int:
    """The ``--max-spp`` that would decide an undecided mean needing ``spp``: the power of two
    at or above it (the rounds double)."""
    return 1 << max(0, math.ceil(math.log2(max(spp, 1.0))))


# ---- differences of convention (mitsuba_refs.verdicts.conventions) ----------------------------
#: The global factors by name, and what each suggests.
_FACTOR_WORDS = (
    (math.pi, "pi", "light or BSDF units: radiance against exitance, rho against rho/pi?"),
    (1 / math.pi, "1/pi", "light or BSDF units: exitance against radiance, rho/pi against rho?"),
    (2.0, "2", "two-sided lights or surfaces where Mitsuba's are one-sided?"),
    (0.5, "1/2", "one-sided lights or surfaces where Mitsuba's are two-sided?"),
    (4 * math.pi, "4 pi", "a point light's power given as its intensity?"),
    (1 / (4 * math.pi), "1/(4 pi)", "a point light's intensity given as its power?"),
)
_SHIFT_WORDS = {(1, 0): "down", (-1, 0): "up", (0, 1): "right", (0, -1): "left"}


def _factor_words(value: float) -> tuple:
    return min(_FACTOR_WORDS, key=lambda entry: abs(math.log(value / entry[0])))[1:]


def _convention_claim(convention: str, value) -> str:
    """What the convention is and how the image was corrected, for one finding."""
    if convention == "factor":
        name, why = _factor_words(float(value))
        return f"the image is {name} times Mitsuba's ({why}): divided by {name} it agrees"
    if convention == "channel_gains":
        gains = ", ".join(f"{g:.3f}" for g in value)
        return (f"per-channel gains (white balance, or a light of another colour?): R, G, B are "
                f"{gains}x Mitsuba's; divided by them it agrees")
    if convention == "srgb":
        return "the output is sRGB-encoded (a display image, not radiance?): decoded it agrees"
    if convention == "gamma":
        return f"the output is gamma-encoded ({value:g}): decoded it agrees"
    if convention == "clamp":
        return (f"values are clamped at {value:.4g} (an LDR output?): without the pixels at or "
                "near that ceiling it agrees")
    if convention == "flip_vertical":
        return "the image is upside down (row 0 at the bottom?): flipped it agrees"
    if convention == "flip_horizontal":
        return "the image is mirrored left-right (camera handedness?): mirrored back it agrees"
    if convention == "shift":
        return (f"the image is moved one pixel {_SHIFT_WORDS[tuple(value)]} (pixel centres at "
                "integers, or another film origin?): moved back it agrees")
    if convention == "half_shift":
        dy, dx = (float(v) for v in value)
        where = _SHIFT_WORDS[(int(math.copysign(1, dy)) if dy else 0,
                              int(math.copysign(1, dx)) if dx else 0)]
        return (f"the image is moved half a pixel {where} (samples at pixel corners, or pixel "
                "centres at integers?): against Mitsuba's moved alike it agrees")
    if convention == "filter":
        return (f"another reconstruction filter than the file's box (a {value} filter fits "
                f"best): against Mitsuba's reference with a {value} filter it agrees")
    if convention == "centre_samples":
        which = ("every pixel sample at the pixel centre (no antialiasing?)" if float(value) >= 1
                 else f"the first sample of every render at the pixel centre ({percent(float(value))} of "
                 "the samples: a fixed first sample, as Cycles draws it?)")
        return f"{which}: against Mitsuba's image of the pixel centres, mixed alike, it agrees"
    if convention == "fov_axis":
        return (f"another field-of-view axis (the image is a scaled copy about its centre): "
                f"against Mitsuba's reference with the file's fov measured along {value} it "
                "agrees")
    if convention == "bounces":
        return (f"one bounce too few (max_depth counted differently?): it agrees with Mitsuba at "
                f"max_depth = {int(value)}")
    return f"{convention}: corrected it agrees"


def convention_text(finding) -> str:
    """The hint naming a convention (a :class:`mitsuba_refs.verdicts.conventions.ConventionFinding`):
    "convention: the image is 1/pi times Mitsuba's (...): divided by 1/pi it agrees (p = 0.41)"."""
    text = (f"convention: {_convention_claim(finding.convention, finding.value)} "
            f"(p = {format_p(finding.p_value)}; tile chi-square {finding.chi_square_before:.3g} "
            f"-> {finding.chi_square_after:.2f}")
    if finding.masked_fraction > 0:
        text += f", {percent(finding.masked_fraction)} of the pixels left out"
    text += ")"
    if finding.alternatives:
        text += f"; corrected as {', '.join(finding.alternatives)} it agrees too"
    return text
