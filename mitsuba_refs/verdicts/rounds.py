"""Render until decided: the test side's mean-and-variance render in rounds, judged after each.

With a tolerance (``Settings.tolerance``) the mean verdict has three outcomes
(:mod:`mitsuba_refs.stats.equivalence`): the test side renders ``look_totals(max_spp)``
samples per pixel in doubling rounds (:mod:`mitsuba_refs.stats.sequential`), each round with a
seed of its own, the rounds' moments pooled, and stops at the first look that decides, at
``max_spp``, or when the next round would pass ``max_seconds``. Each look spends
``alpha / looks`` of each side's budget.
"""
from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

from ..stats.equivalence import UNDECIDED, ToleranceDecision, decide_tolerance, samples_to_decide
from ..stats.mean import VARIANCE_BOUND, MeanTestOptions
from ..stats.sequential import alpha_per_look, look_totals, merge_moments, round_seed

__all__ = ["MeanRounds", "render_until_decided", "mean_test_keywords", "OUTCOMES"]

#: The most independent pieces (the original included) a reference grows to when its own
#: noise is what keeps the mean undecided: 4 x 4096 spp.
MAX_REFERENCE_PIECES = 4
#: The outcomes' words, by :data:`mitsuba_refs.stats.equivalence` outcome.
OUTCOMES = {"agrees": "AGREES", "disagrees": "DISAGREES", "undecided": "INCONCLUSIVE"}


@dataclass(frozen=True)
class MeanRounds:
    """How the mean verdict was decided in rounds.

    Attributes
    ----------
    decision : ToleranceDecision
        The last look's.
    looks : tuple of dict
        Per look: ``spp`` (total), ``seconds`` (since the first round began), ``outcome``,
        ``rel_bias``, ``interval``.
    max_spp, max_seconds : int, float or None
        The budget.
    alpha_look : float
        Each look's share of each side's error budget.
    stopped_by : str
        "decided", "spp" (``max_spp`` reached) or "seconds" (the next round would pass
        ``max_seconds``).
    spp_needed : float
        Undecided: the spp at which the observed bias would be decided (inf: never).
    reference_limited : bool
        Undecided because of the reference's own noise (a longer reference would decide).
    reference_spp, reference_pieces : int
        The reference's samples per pixel at the last look and the independent cached pieces
        it was pooled from (more than 1 when it was extended).
    """

    decision: ToleranceDecision
    looks: tuple
    max_spp: int
    max_seconds: float | None
    alpha_look: float
    stopped_by: str
    spp_needed: float = math.nan
    reference_limited: bool = False
    reference_spp: int = 0
    reference_pieces: int = 1

    @property
    def outcome(self) -> str:
        """AGREES, DISAGREES or INCONCLUSIVE."""
        return OUTCOMES[self.decision.outcome]

    @property
    def tolerance_percent(self) -> float:
        return 100.0 * self.decision.tolerance

    def record(self) -> dict:
        """The JSON record of the rounds."""
        d = self.decision
        return {"outcome": self.outcome, "tolerance_percent": self.tolerance_percent,
                "rel_bias": d.rel_bias, "interval": list(d.interval), "alpha_per_look": d.alpha,
                "p_beyond": dict(d.p_beyond), "beyond_tiles": d.beyond_tiles,
                "looks": [dict(look) for look in self.looks], "max_spp": self.max_spp,
                "max_seconds": self.max_seconds, "stopped_by": self.stopped_by,
                "spp_needed": None if not math.isfinite(self.spp_needed) else self.spp_needed,
                "reference_limited": self.reference_limited, "reference_spp": self.reference_spp,
                "reference_pieces": self.reference_pieces}


def mean_test_keywords(settings, correlation) -> dict:
    """The keywords of the comparison's mean test beside its images and alpha
    (:func:`mitsuba_refs.stats.mean.compare_means`, and the looks' ``decide_tolerance``): the
    same estimator on both sides bounds the test side's variance (a variance far above the
    reference's is itself wrong, so it may not hide a bias); splatting renders have no
    whole-image component; the film's pixel correlation."""
    return {"max_var_ratio": VARIANCE_BOUND if settings.same_estimator else None,
            "image_components": not settings.splatting,
            "options": MeanTestOptions(pixel_correlation=correlation,
                                       same_estimator=settings.heavy_tail_guard)}


def reference_dominates(decision: ToleranceDecision) -> bool:
    """Whether the reference's noise is a large share of the relative bias's standard error
    (its variance at least a fifth of the whole): then a longer reference decides sooner."""
    own = math.sqrt(max(decision.rel_se ** 2 - decision.rel_se_reference ** 2, 0.0))
    return 2.0 * decision.rel_se_reference >= own


def extended(reference, piece):
    """``reference`` pooled with an independent ``piece`` of the same scene and estimator."""
    mean, var = merge_moments(reference.mean, reference.var, int(reference.n), piece.mean,
                              piece.var, int(piece.n))
    metadata = {**reference.metadata, "extended_spp": int(reference.n) + int(piece.n)}
    return dataclasses.replace(reference, mean=mean, var=var, n=int(reference.n) + int(piece.n),
                               metadata=metadata)


def render_until_decided(render, scene, integrator, params, reference, settings, correlation,
                         seed: int, log=None, reference_piece=None):
    """Render the test side in rounds until the mean verdict decides or the budget ends.

    Parameters
    ----------
    render : callable
        The comparison's render hook (``render(scene, integrator, params, spp, seed,
        processes=...)`` returning mean and per-sample variance).
    reference : Reference
        Mitsuba's (``mean``, ``var``, ``n``).
    settings : Settings
        ``tolerance`` (percent), ``max_spp`` (None: ``spp``), ``max_seconds``, ``alpha``,
        ``same_estimator``, ``splatting``, ``heavy_tail_guard``, ``processes``.
    correlation : PixelCorrelation or None
        The film's pixel correlation.
    seed : int
        The first round's seed (the others: :func:`mitsuba_refs.stats.sequential.round_seed`).
    reference_piece : callable, optional
        ``reference_piece(k)``: the ``k``-th independent piece of the reference (k >= 1; a
        cached reference with its own seed). After an undecided look whose reference noise
        dominates (:func:`reference_dominates`), the next piece is pooled in before the next
        look, up to :data:`MAX_REFERENCE_PIECES`. None: the reference stays as it is.

    Returns
    -------
    mean, variance, spp, MeanRounds, reference
        The pooled images, their total spp, how it was decided and the reference of the last
        look (``reference`` itself unless it was extended).
    """
    max_spp = int(settings.max_spp or settings.spp)
    totals = look_totals(max_spp)
    alpha_look = alpha_per_look(settings.alpha, len(totals))
    mean = variance = None
    spp, looks, start = 0, [], time.perf_counter()
    stopped_by, decision, pieces = "spp", None, 1
    for index, total in enumerate(totals):
        extra_mean, extra_var = render(scene, integrator, params, total - spp,
                                       round_seed(seed, index), processes=settings.processes)
        if mean is None:
            mean, variance = extra_mean, extra_var
        else:
            mean, variance = merge_moments(mean, variance, spp, extra_mean, extra_var, total - spp)
        spp = total
        decision = decide_tolerance((mean, variance, spp), (reference.mean, reference.var,
                                    reference.n), tolerance=settings.tolerance / 100.0,
                                    alpha=alpha_look, **mean_test_keywords(settings, correlation))
        seconds = time.perf_counter() - start
        looks.append({"spp": spp, "seconds": round(seconds, 3), "outcome": OUTCOMES[decision.outcome],
                      "rel_bias": decision.rel_bias, "interval": list(decision.interval)})
        if log is not None:
            low, high = decision.interval
            log(f"round {index + 1}/{len(totals)}: {spp} spp, relative bias in "
                f"[{100 * low:+.2f} %, {100 * high:+.2f} %]: {OUTCOMES[decision.outcome]}")
        if decision.outcome != UNDECIDED:
            stopped_by = "decided"
            break
        # The next round renders as many samples as all before it: about as many seconds.
        if settings.max_seconds is not None and index + 1 < len(totals) \
                and seconds * total_ratio(totals, index) > settings.max_seconds:
            stopped_by = "seconds"
            break
        if reference_piece is not None and pieces < MAX_REFERENCE_PIECES \
                and index + 1 < len(totals) and reference_dominates(decision):
            reference = extended(reference, reference_piece(pieces))
            pieces += 1
            if log is not None:
                log(f"the reference's own noise dominates: extended to {reference.n} spp")
    needed, limited = (math.nan, False) if decision.outcome != UNDECIDED else \
        samples_to_decide(decision, spp, alpha_look)
    rounds = MeanRounds(decision, tuple(looks), max_spp, settings.max_seconds, alpha_look,
                        stopped_by, needed, limited, int(reference.n), pieces)
    return mean, variance, spp, rounds, reference


def total_ratio(totals, index: int) -> float:
    """How many times the seconds so far the rounds up to look ``index + 1`` take."""
    return totals[index + 1] / totals[index]
