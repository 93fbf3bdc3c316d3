"""What a comparison could see, said in its verdict, and ``--detect``: the spp that sees enough.

Every mean verdict carries the smallest global bias its test detects with probability
:data:`POWER` at its level (:mod:`mitsuba_refs.stats.detectable`), computed from the
reference's and the test side's per-pixel variances and sample counts. An agreement that could
not have seen a bias of :data:`WEAK_BIAS` is *weak*: it says "agrees, but could not see less
than 13 %", and so does the headline.

``--detect 2%`` (``compare`` and ``check``) picks the test's sample count instead of ``--spp``:

1. the reference alone: with infinitely many test samples the test still misses a bias below
   the reference's *floor*; a target under it cannot be met (the verdict says so, and how many
   reference samples would meet it), and the render gets the spp at which the test's own noise
   adds at most 10 % to the floor;
2. a short pilot render (:data:`PILOT_SPP` samples, seed :data:`PILOT_SEED`) gives the test
   estimator's per-sample variance (for the reference's own estimator at least the
   reference's, channel by channel: it is measured from 4096 samples a pixel) and its seconds
   per sample;
3. the smallest multiple of :data:`SPP_STEP` whose detectable bias is at most the target,
   times :data:`SPP_MARGIN` (the pilot's variance is an estimate), at least the default
   ``TEST_MAX_SPP`` (the tiles' calibration needs it), at most what ``--max-time`` allows the
   mean-and-variance render at the pilot's pace.

The choice, and why, is a note of the comparison; the verdict then reports the bias the
render really detects (from its own variance).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..errors import RefsInputError
from ..reference import config
from ..reference.rfilter import reference_correlation
from ..report.wording import percent
from ..settings import DEFAULT_MAX_TIME, PILOT_SPP, Detect, Settings
from ..stats.detectable import WEAK_BIAS, DetectableBias, MeanTestPower, weak_agreement
from ..stats.mean import VARIANCE_BOUND, MeanTestOptions

__all__ = ["POWER", "WEAK_BIAS", "Detect", "DEFAULT_MAX_TIME", "PILOT_SPP", "SppChoice", "parse_bias",
           "mean_test_power", "comparison_bound", "is_weak", "plan", "choose_spp"]

#: The detection probability every printed bound is for.
POWER = 0.95
#: The pilot render of ``--detect``: its seed (below the comparison's TEST_SEED = 1000 and its
#: bounce seeds, far from the convergence seeds from 2000); its sample count ``PILOT_SPP`` and
#: ``--max-time``'s default ``DEFAULT_MAX_TIME`` are those of :class:`mitsuba_refs.settings.Detect`.
PILOT_SEED = 900
#: The chosen sample count is a multiple of this, and this many times what the pilot asks for.
SPP_STEP = 16
SPP_MARGIN = 1.1
#: With an unreachable target, the test's noise may add this much to the reference's floor.
FLOOR_SLACK = 1.1
#: The largest sample count either side is searched up to.
_MOST_SPP = 1 << 40


def parse_bias(text: str, option: str = "--detect") -> float:
    """``"2%"`` or ``"0.02"`` as a fraction in (0, 1); a one-line error otherwise."""
    raw = str(text).strip()
    try:
        value = float(raw[:-1]) / 100.0 if raw.endswith("%") else float(raw)
    except ValueError:
        value = math.nan
    if not 0.0 < value < 1.0:
        raise RefsInputError(f"{option} takes a relative bias between 0 and 100 %, as a percentage "
                             f"or a fraction (e.g. 2% or 0.02), got {text!r}")
    return value


# ---- the bound of one comparison ----------------------------------------------------------
def mean_test_power(reference, test_var, *, alpha: float, same: bool, splats: bool,
                    guard: bool | None = None):
    """The :class:`~mitsuba_refs.stats.detectable.MeanTestPower` of the mean test that
    :func:`mitsuba_refs.verdicts.compare.compare` runs against ``reference`` (bounded variance for the
    same estimator, tiles only for a splatting render, the film's pixel correlation); None
    when ``test_var`` is missing or not finite (an overflowed render: nothing to bound).
    ``guard``: the mean test's heavy-tail guard (default: ``same``)."""
    if test_var is None or not np.all(np.isfinite(test_var)):
        return None
    return MeanTestPower(reference.mean, reference.var, test_var, alpha=alpha,
                         max_var_ratio=VARIANCE_BOUND if same else None,
                         image_components=not splats,
                         options=MeanTestOptions(pixel_correlation=reference_correlation(reference),
                                                 same_estimator=same if guard is None else guard))


def comparison_bound(reference, test_var, spp, *, alpha, same, splats,
                     guard=None) -> DetectableBias | None:
    """The detectable global bias of a comparison's mean test (None: see :func:`mean_test_power`)."""
    model = mean_test_power(reference, test_var, alpha=alpha, same=same, splats=splats, guard=guard)
    return None if model is None else model.bound(float(spp), float(reference.n), power=POWER)


def is_weak(result) -> bool:
    """An agreement that could not see a global bias of :data:`WEAK_BIAS`."""
    return weak_agreement(result.agree, getattr(result, "detectable", None))


# ---- --detect -----------------------------------------------------------------------------
@dataclass(frozen=True)
class SppChoice:
    """What ``--detect`` chose and why.

    Attributes
    ----------
    spp : int
        The mean-and-variance render's sample count.
    target : float
        The bias asked for.
    predicted : float
        The detectable bias at ``spp`` from the pilot's variance.
    needed : int or None
        The sample count the target needs (None: unreachable, the reference's floor).
    allowed : int
        The most samples ``max_time`` allows.
    floor : float
        The reference's floor (infinitely many test samples).
    reference_needed : int or None
        Reference samples at which the floor is the target (when it is above it).
    seconds_per_spp : float
        The pilot's pace (0 when no pilot was needed).
    reason : str
        One line for the verdict's notes.
    """

    spp: int
    target: float
    predicted: float
    needed: int | None
    allowed: int
    floor: float
    reference_needed: int | None
    seconds_per_spp: float
    reason: str

    @property
    def met(self) -> bool:
        """Whether the chosen spp meets the target (by the pilot's variance)."""
        return self.predicted <= self.target


def _smallest(ok, low: int, high: int = _MOST_SPP) -> int | None:
    """Smallest integer n in [low, high] with ``ok(n)`` (monotone), None if ``ok(high)`` fails."""
    if ok(low):
        return low
    step = low
    while step < high and not ok(min(2 * step, high)):
        step *= 2
    hi = min(2 * step, high)
    if not ok(hi):
        return None
    lo = step
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if ok(mid) else (mid, hi)
    return hi


def plan(model: MeanTestPower, target: float, reference_spp: int, *, seconds_per_spp: float,
         max_time: float, minimum: int = config.TEST_MAX_SPP, step: int = SPP_STEP,
         margin: float = SPP_MARGIN) -> SppChoice:
    """The sample count for ``target`` (pure: the pilot's model and pace given).

    See the module notes for the rule. ``seconds_per_spp`` is the pilot's seconds divided by
    its samples (its fixed costs included, so the estimate errs on the long side).
    """
    floor = model.floor(reference_spp, power=POWER)

    def bias_at(n):
        return model.worst(n, reference_spp, power=POWER)

    allowed = max(2, int(max_time / seconds_per_spp) // step * step) if seconds_per_spp > 0 \
        else _MOST_SPP
    allowed = max(allowed, 2)
    what = f"--detect {percent(target)}"
    pace = (f"{seconds_per_spp:.3g} s per spp in the pilot" if seconds_per_spp > 0 else "")
    if floor > target:
        need_ref = _smallest(lambda r: model.floor(r, power=POWER) <= target, int(reference_spp))
        close = _smallest(lambda n: bias_at(n) <= FLOOR_SLACK * floor, 2) or allowed
        spp = min(max(_round_up(close, step), minimum), max(allowed, 2))
        spp = max(2, min(spp, allowed))
        needs = (f"a reference of {need_ref:,} spp would have a floor of {percent(target)}"
                 if need_ref is not None else "no reference sample count reaches it")
        reason = (f"{what} cannot be met: the reference's own noise ({int(reference_spp)} spp) "
                  f"alone hides global biases below {percent(floor)} (its floor); {needs} "
                  f"(mitsuba-refs build renders references); rendering {spp} spp, where the test "
                  f"sees {percent(bias_at(spp))}")
        return SppChoice(spp, target, bias_at(spp), None, allowed, floor, need_ref,
                         seconds_per_spp, reason)
    exact = _smallest(lambda n: bias_at(n) <= target, 2)
    needed = _round_up(math.ceil(exact * margin), step)
    spp = max(needed, minimum)
    if spp <= allowed:
        predicted = bias_at(spp)
        if needed <= minimum:
            reason = (f"{what}: {spp} spp (the default) already sees {percent(bias_at(spp))} "
                      f"(the pilot's variance asks for {exact} spp)")
        else:
            reason = (f"{what}: {spp} spp, where the test sees {percent(predicted)} (the pilot's "
                      f"variance asks for {exact} spp, {margin:g}x for its own noise"
                      + (f"; ~{spp * seconds_per_spp:.0f} s at {pace}" if pace else "") + ")")
        return SppChoice(spp, target, predicted, needed, allowed, floor, None, seconds_per_spp,
                         reason)
    spp = allowed
    predicted = bias_at(spp)
    reason = (f"{what} is not met within --max-time {max_time:g} s: {spp} spp (the most it allows "
              f"at {pace}) sees {percent(predicted)}; {needed} spp (~{needed * seconds_per_spp:.0f} s) "
              f"would see {percent(target)}")
    return SppChoice(spp, target, predicted, needed, allowed, floor, None, seconds_per_spp, reason)


def _round_up(n: int, step: int) -> int:
    return int(-(-int(n) // step) * step)


def choose_spp(settings: Settings, render, scene, integrator, params, reference,
               log=None) -> SppChoice:
    """Render the pilot of ``settings.detect`` with the comparison's ``render`` hook, then
    :func:`plan`. ``settings`` as :func:`mitsuba_refs.verdicts.compare.compare` resolved them
    (``same_estimator`` and ``splatting`` set): ``alpha`` and ``processes`` too.

    A target under the reference's floor needs no pilot for the verdict that it cannot be
    met; the pilot still gives the pace and the spp to render.
    """
    detect, alpha, same = settings.detect, settings.alpha, bool(settings.same_estimator)
    splats, processes = bool(settings.splatting), settings.processes
    start = time.perf_counter()
    _, pilot_var = render(scene, integrator, params, detect.pilot_spp, PILOT_SEED,
                          processes=processes)
    seconds = time.perf_counter() - start
    variance = np.asarray(pilot_var, dtype=np.float64)
    if same and np.all(np.isfinite(variance)):
        # the reference's estimator: its per-sample variance is known from 4096 samples a pixel;
        # the pilot's, from 16, may have missed rare paths (never below the reference's)
        ours = variance.sum(axis=(0, 1))
        theirs = np.asarray(reference.var, dtype=np.float64).sum(axis=(0, 1))
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(ours > 0, np.maximum(theirs / ours, 1.0), 1.0)
        variance = variance * scale
    model = mean_test_power(reference, variance, alpha=alpha, same=same, splats=splats)
    if model is None:
        raise RefsInputError(f"--detect: the pilot render ({detect.pilot_spp} spp) has a variance "
                             "that is not finite: no sample count can be chosen from it")
    choice = plan(model, detect.target, int(reference.n),
                  seconds_per_spp=seconds / detect.pilot_spp, max_time=detect.max_time)
    if log is not None:
        log(f"detect: {choice.reason}")
    return choice
