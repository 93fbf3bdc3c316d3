"""Each verdict of a comparison as one JSON entry (part of the ``mitsuba-refs/result/1`` record).

Every entry has ``status`` (``"agree"``, ``"disagree"`` or ``"not compared"``; the mean with a
tolerance also ``"inconclusive"``, and ``rounds``: how it was decided), ``line``
(the verdict as the command line prints it), ``p_value`` and ``alpha``; one that was not
compared has ``reason`` instead of statistics. The rest is the verdict's own: intervals,
component p-values and the maps a report draws (tile z, tile variance ratio, MSE per level).
"""
from __future__ import annotations

import numpy as np

from ..stats.convergence import mse_levels
from ..verdicts.detect import WEAK_BIAS, is_weak
from .encoding import plain
from .wording import (
    convergence_verdict,
    convergence_warnings,
    mean_line,
    mean_region,
    mean_verdict,
    variance_policy_verdict,
    variance_region,
    variance_verdict,
)

__all__ = ["VERDICTS", "mean_entry", "variance_entry", "convergence_entry", "bounces_entry",
           "verdict_entries", "detectable_entry"]

#: The verdicts of a record, in the order reports show them.
VERDICTS = ("mean", "variance", "convergence", "bounces")
AGREE, DISAGREE, NOT_COMPARED = "agree", "disagree", "not compared"
#: The mean's status when the budget ran out before it was decided (``--tolerance``).
INCONCLUSIVE = "inconclusive"


def _status(agree: bool) -> str:
    return AGREE if agree else DISAGREE


def _not_compared(reason: str, **fields) -> dict:
    return {"status": NOT_COMPARED, "reason": reason, "line": f"not compared ({reason})",
            "p_value": None, **fields}


def mean_entry(mean) -> dict:
    """A :class:`~mitsuba_refs.stats.mean.MeanAgreement` as a JSON entry.

    ``significant_tiles`` lists ``[row, col, channel, z]`` for every tile-channel whose |z|
    exceeds the per-tile critical value ``critical_z`` (the tiles ``n_significant`` counts);
    ``z_tiles`` is the whole (rows, cols, channels) map.
    """
    if getattr(mean, "faults", None):      # the renderer's images held NaN, Inf or negatives
        return plain({"status": "disagree", "agree": False, "p_value": mean.p_value,
                      "alpha": mean.alpha, "line": mean_verdict(mean), "faults": list(mean.faults)})
    z = np.asarray(mean.z_tiles, dtype=np.float64)
    significant = getattr(mean, "significant", None)
    if significant is None:
        significant = np.zeros(z.shape, dtype=bool)
    tiles = [[int(r), int(c), int(ch), z[r, c, ch]] for r, c, ch in np.argwhere(significant)]
    return plain({
        "status": _status(mean.agree), "agree": mean.agree, "p_value": mean.p_value,
        "alpha": mean.alpha, "line": mean_verdict(mean),
        "rel_bias": mean.rel_bias, "rel_bias_ci": mean.rel_bias_ci, "ci_level": mean.ci_level,
        "rel_bias_channels": mean.rel_bias_channels,
        "component_p_values": dict(mean.scale_p_values), "image_z": mean.image_z,
        "tile": mean.tile, "n_tests": mean.n_tests, "n_significant": mean.n_significant,
        "critical_z": getattr(mean, "critical_z", None), "significant_tiles": tiles,
        "worst_tile": mean.worst_tile, "worst_z": mean.worst_z, "worst_region": mean_region(mean),
        "z_tiles": z,
    })


def detectable_entry(result) -> dict | None:
    """What the comparison's mean test could see (:mod:`mitsuba_refs.verdicts.detect`), or None.

    ``bias``: every global bias at least this large (brighter or darker) is detected with
    probability ``power`` at level ``alpha``; ``brighter`` / ``darker`` per sign; ``floor``: the
    same with infinitely many test samples (the reference's own noise); ``component``:
    ``"image"`` or ``"tiles"``; ``weak``: an agreement that could not see ``weak_above``.
    """
    bound = getattr(result, "detectable", None)
    if bound is None:
        return None
    return plain({"bias": bound.bias, "brighter": bound.brighter, "darker": bound.darker,
                  "floor": bound.floor, "power": bound.power, "alpha": bound.alpha,
                  "test_spp": bound.test_spp, "reference_spp": bound.reference_spp,
                  "component": bound.component, "weak": is_weak(result),
                  "weak_above": WEAK_BIAS})


def variance_entry(result) -> dict:
    """The variance verdict of a :class:`~mitsuba_refs.verdicts.compare.Comparison` as a JSON entry.

    ``applicable``: Mitsuba ran the same estimator as the test side (ours by name; an external
    renderer by its user's word, ``--same-estimator``) and the test side's samples are
    independent within a pixel (not judged otherwise: ``Settings.judge_independence``), so
    that the per-sample variances are comparable; ``compared``: the test ran; ``reason``
    says why not.
    """
    # Every reason that the verdict does not apply starts "not applicable" (report.wording).
    applicable = result.compares_variance and not result.variance_skipped.startswith(
        "not applicable")
    variance = result.variance
    if variance is None:
        arrays = result.arrays or {}
        noiseless = all(arrays.get(name) is not None and not np.any(arrays[name])
                        for name in ("test_variance", "reference_variance"))
        if not applicable or result.variance_skipped:
            reason = result.variance_not_applicable()
        elif noiseless:
            reason = "both images are noiseless"
        else:
            reason = "not run"
        return _not_compared(reason, applicable=applicable, compared=False)
    return plain({
        "status": _status(variance.agree), "applicable": applicable, "compared": True,
        "agree": variance.agree, "p_value": variance.p_value, "alpha": variance.alpha,
        "line": variance_verdict(variance), "ratio": variance.ratio, "ratio_ci": variance.ratio_ci,
        "ci_level": variance.ci_level, "global_p": variance.global_p, "tile_p": variance.tile_p,
        "tile": variance.tile, "n_tiles": variance.n_tiles, "n_outliers": variance.n_outliers,
        "worst_tile": variance.worst_tile, "worst_region": variance_region(variance),
        "policy": {"max_ratio": variance.max_ratio, "agree": variance.policy_agree,
                   "p_value": variance.policy_p, "line": variance_policy_verdict(variance)},
        "tile_log_ratio": variance.tile_log_ratio,
    })


def mse_per_level(mse, n_levels: int) -> dict:
    """Mean, standard error of the mean, smallest and largest MSE of each ladder level, and
    how many values (renders x sub-lattices, or blocks of a filtered film) each has."""
    levels, _ = mse_levels(mse, n_levels)
    return {"mse_mean": [float(level.mean()) for level in levels],
            "mse_se": [float(level.std(ddof=1) / np.sqrt(level.size)) if level.size > 1 else None
                       for level in levels],
            "mse_min": [float(level.min()) for level in levels],
            "mse_max": [float(level.max()) for level in levels],
            "mse_count": [int(level.size) for level in levels]}


def convergence_entry(result) -> dict:
    """The convergence verdict (MSE over the spp ladder) as a JSON entry."""
    law = result.convergence
    if law is None:
        reason = getattr(result, "not_run", {}).get("convergence", "not run (--no-convergence)")
        return _not_compared(reason, compared=False)
    ladder = [int(n) for n in result.ladder]
    levels = (mse_per_level(result.convergence_mse, len(ladder))
              if result.convergence_mse is not None else {})
    return plain({
        "status": _status(law.passed), "compared": True, "agree": law.passed,
        "p_value": law.p_value, "alpha": law.alpha, "line": convergence_verdict(law),
        "slope": law.slope, "slope_ci": law.slope_ci, "ratio": law.ratio, "ratio_ci": law.ratio_ci,
        "slope_p": law.slope_p, "floor_p": law.floor_p, "floor_detected": law.floor_detected,
        "rmse_exponent": law.slope / 2, "faster_p": law.faster_p, "faster": law.faster,
        "floor_spp": law.floor_spp, "bias_rel": law.bias_rel, "correlated": law.correlated,
        "ladder": ladder, "levels_used": list(law.levels_used), "looks": law.looks,
        "stopped_early": law.stopped_early, **levels,
        "warnings": convergence_warnings(law),
    })


def bounces_entry(result) -> dict:
    """The per-bounce localisation (mean test at max_depth 1, 2, 3) as a JSON entry.

    ``status`` is ``"disagree"`` when some depth disagrees; ``p_value`` is that of the first
    diverging depth (None when every depth agrees; each depth's own is in ``depths``).
    """
    if not result.bounce_results:
        reason = ("not run: the mean agrees (--bounces always runs it)" if result.mean.agree
                  else getattr(result, "not_run", {}).get("bounces", "not run (--bounces never)"))
        return _not_compared(reason, compared=False)
    first, text = result.bounce if result.bounce is not None else (None, "")
    depths = [{"max_depth": depth, "agree": mean.agree, "p_value": mean.p_value,
               "rel_bias": mean.rel_bias, "rel_bias_ci": mean.rel_bias_ci, "line": mean_verdict(mean)}
              for depth, mean in sorted(result.bounce_results.items(), key=lambda item: (item[0] < 0, item[0]))]
    first_mean = result.bounce_results.get(first) if first is not None else None
    return plain({
        "status": _status(first is None), "compared": True, "agree": first is None,
        "p_value": first_mean.p_value if first_mean is not None else None,
        "alpha": min(mean.alpha for mean in result.bounce_results.values()),
        "line": text, "first_diverging_depth": first, "depths": depths,
    })


def verdict_entries(result) -> dict:
    """All four verdicts of a comparison, by name (:data:`VERDICTS`)."""
    mean = mean_entry(result.mean)
    detectable = detectable_entry(result)
    if detectable is not None:
        mean.update(line=mean_line(result), detectable_bias=detectable)
    rounds = getattr(result, "rounds", None)
    if rounds is not None and not getattr(result.mean, "faults", None):
        # With a tolerance the mean's outcome is the rounds' (stats.equivalence), and the
        # equal-means test's numbers stay beside it (tiles, intervals for the pictures).
        status = {"AGREES": AGREE, "DISAGREES": DISAGREE}.get(rounds.outcome, INCONCLUSIVE)
        mean.update(status=status, agree=status == AGREE, line=mean_line(result),
                    p_value=rounds.decision.p_value, alpha=rounds.alpha_look,
                    rounds=plain(rounds.record()))
    return {"mean": mean, "variance": variance_entry(result),
            "convergence": convergence_entry(result), "bounces": bounces_entry(result)}
