"""Differences of convention: when a disagreement is one, which, and the proof.

A renderer can be right in its own conventions and disagree with Mitsuba: lights in other
units, a white balance, an encoded or clamped output, a flipped image, one shifted by a
pixel or half of one, a path length counted differently, another reconstruction filter or
field-of-view axis, pixel samples at the pixel centre. On a disagreement of the mean,
:func:`find_convention` tries the
inverse of each such convention on the test image (:mod:`mitsuba_refs.stats.conventions`) and
runs the *same* mean test again (same reference, same alpha, same components and options).
It names a convention only when both hold:

* the corrected image agrees with the reference (p > alpha), and
* the correction explains the error: the tiles' chi-square (the mean squared tile z, 1 for
  two agreeing images) falls by at least :data:`EXPLAIN_RATIO` to the noise.

The second guards against naming by chance among ~17 corrections: a plain bias barely
rejected could agree after a correction that changes almost nothing (a shift of a smooth
image); requiring the correction to remove most of a strong error leaves only a correction
that moves the image onto the reference. Corrections with a parameter fitted to the data
(per-channel gains, the ceiling of a clamp) are tried only where the data show the
convention's signature (gains that differ between channels, pixels sitting at one ceiling),
so that a light 5 % too bright is never "white balance". docs/external.md ("Differences of
convention") gives the measured rates of correct and false names.

Images are corrected one by one before their moments are taken (``moments_of``): a
nonlinear decoding of a mean of replicas is not the mean of the decoded replicas.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Callable

import numpy as np

from ..reference.rfilter import pixel_value_counts, reference_correlation
from ..report.wording import convention_text
from ..stats import conventions as conv
from ..stats.mean import MeanAgreement, MeanTestOptions, compare_means
from . import convention_references as refs
from .explain import Hint

__all__ = ["MeanTestSetup", "Correction", "ConventionFinding", "corrections", "find_convention",
           "ConventionHint", "with_convention", "EXPLAIN_RATIO"]

#: How far a correction must bring the tiles' chi-square down (mean squared z, 1 under
#: agreement) to explain an error: from at least this many times the noise to the noise.
EXPLAIN_RATIO = 4.0
#: Per-channel gains are tried only when two channels' gains differ by this many standard
#: errors and by this fraction: equal gains are one global factor, not a white balance.
GAIN_SPREAD_Z = 5.0
MIN_GAIN_SPREAD = 0.02
#: A clamp may leave out at most this fraction of the pixels.
MAX_CLAMPED = 0.25
#: Another filter, the pixel centres or half a pixel are tried only when the image mean is
#: within this of Mitsuba's: each keeps the mean, up to the border of the film and, at few
#: samples per pixel, the bias of the film's weighted average (+1.0 to +1.2 % for 8-spp
#: replicas of the Cornell box and smallpt with a tent or gaussian filter).
FILTER_MEAN_CHANGE = 0.03
#: Replicas assumed behind a test image when the clamp's margin is judged (check's default:
#: a replica has spp / 8 samples; with variance channels this is conservative).
CLAMP_REPLICAS = 8
#: A pixel whose reference lies within this many of a replica's standard deviations of the
#: ceiling may have been clamped in some replicas only: it is left out too.
CLAMP_MARGIN_SD = 4.0

Moments = Callable[[Callable], tuple]


@dataclass(frozen=True)
class MeanTestSetup:
    """The mean test of a comparison, to be run again on corrected images.

    Attributes
    ----------
    reference : Reference
        Mitsuba's image (``mean``, ``var``, ``n``).
    spp : int
        Samples per pixel of the test image.
    alpha, max_var_ratio, image_components, options
        As :func:`mitsuba_refs.stats.mean.compare_means` took them for the verdict.
    """

    reference: object
    spp: int
    alpha: float
    max_var_ratio: float | None
    image_components: bool
    options: MeanTestOptions

    @classmethod
    def of(cls, verdict: MeanAgreement, reference, spp: int, heavy_tail_guard: bool):
        """The setup that gave ``verdict`` (its alpha, components and bound) on ``reference``."""
        return cls(reference, int(spp), verdict.alpha, verdict.max_var_ratio,
                   "image" in verdict.scale_p_values,
                   MeanTestOptions(tile=verdict.tile, ci_level=verdict.ci_level,
                                   pixel_correlation=reference_correlation(reference),
                                   same_estimator=bool(heavy_tail_guard)))

    def run(self, mean, variance, mask=None, reference=None) -> MeanAgreement:
        """The mean test of ``(mean, variance)`` against ``reference`` (default: the setup's),
        the pixels of ``mask`` left out on both sides."""
        ref = reference or self.reference
        options = self.options
        if reference is not None:      # another film filter correlates pixels otherwise
            options = dataclasses.replace(options, pixel_correlation=reference_correlation(ref))
        return compare_means(conv.masked(mean, mask), conv.masked(variance, mask), self.spp,
                             conv.masked(ref.mean, mask), conv.masked(ref.var, mask), ref.n,
                             alpha=self.alpha, max_var_ratio=self.max_var_ratio,
                             image_components=self.image_components, options=options)


@dataclass(frozen=True)
class Correction:
    """One convention's inverse.

    Attributes
    ----------
    convention : str
        Its id: ``factor``, ``channel_gains``, ``srgb``, ``gamma``, ``clamp``,
        ``flip_vertical``, ``flip_horizontal``, ``shift``, ``half_shift``, ``bounces``,
        ``filter``, ``centre_samples`` or ``fov_axis``.
    value : float, tuple or None
        Its parameter: the factor, the gains, the ceiling, the shift (dy, dx) in pixels, the
        depth, the filter's type, the share of samples at the pixel centre, the
        field-of-view axis.
    transform : callable or None
        ``(mean, variance or None) -> (mean, variance or None)`` for one image; None: the
        image is left as it is.
    mask : (H, W) bool array or None
        Pixels the corrected comparison leaves out (on both sides).
    reference : Reference or None
        Another reference to compare with (``bounces``, ``half_shift``, ``filter``,
        ``centre_samples``, ``fov_axis``; :mod:`.convention_references`); None: the
        comparison's.
    """

    convention: str
    value: object = None
    transform: Callable | None = None
    mask: np.ndarray | None = None
    reference: object = None


@dataclass(frozen=True)
class ConventionFinding:
    """A named convention: which, with what value, and the numbers that show it.

    Attributes
    ----------
    convention, value
        As in :class:`Correction`.
    p_value : float
        The corrected image's mean test.
    chi_square_before, chi_square_after : float
        The tiles' chi-square (mean squared z) before and after the correction.
    masked_fraction : float
        Share of the pixels the corrected comparison left out.
    alternatives : tuple of str
        Other conventions whose correction also agreed and explained the error.
    """

    convention: str
    value: object
    p_value: float
    chi_square_before: float
    chi_square_after: float
    masked_fraction: float = 0.0
    alternatives: tuple = ()

    def record(self) -> dict:
        """The finding as plain JSON values (the results record's ``convention``)."""
        value = self.value
        if isinstance(value, (tuple, list, np.ndarray)):
            value = [float(v) for v in value]
        elif value is not None and not isinstance(value, str):
            value = float(value)
        return {"convention": self.convention, "value": value, "p_value": float(self.p_value),
                "chi_square_before": float(self.chi_square_before),
                "chi_square_after": float(self.chi_square_after),
                "masked_fraction": float(self.masked_fraction),
                "alternatives": list(self.alternatives)}


def _scaled(factors):
    """Divide means by ``factors`` (a number or per channel) and variances by their square."""
    def transform(mean, variance):
        return mean / factors, None if variance is None else variance / np.square(factors)
    return transform


def _decoded(decode, slope):
    def transform(mean, variance):
        return decode(mean), None if variance is None else np.square(slope(mean)) * variance
    return transform


def _moved(function):
    def transform(mean, variance):
        return function(mean), None if variance is None else function(variance)
    return transform


def _gains_correction(mean, variance, setup: MeanTestSetup):
    """Per-channel gains, when the channels' gains differ (else None)."""
    ref = setup.reference
    gains = conv.channel_gains(mean, variance, setup.spp, ref.mean, ref.var, ref.n,
                               setup.options.tile)
    if not (np.all(np.isfinite(gains.gains)) and np.all(gains.gains > 0)):
        return None
    if not (gains.spread_z >= GAIN_SPREAD_Z and gains.spread >= MIN_GAIN_SPREAD):
        return None
    return Correction("channel_gains", tuple(float(g) for g in gains.gains),
                      _scaled(gains.gains))


def _clamp_correction(mean, setup: MeanTestSetup):
    """A clamp at the image's ceiling, when pixels sit at one whose reference is brighter."""
    ceiling = conv.clamp_ceiling(mean)
    if not math.isfinite(ceiling):
        return None
    ref = setup.reference
    at_ceiling = mean >= ceiling * (1 - conv.CEILING_TOLERANCE)
    if not float(ref.mean[at_ceiling].mean()) > ceiling:     # Mitsuba is not brighter there
        return None
    replica_spp = max(setup.spp // CLAMP_REPLICAS, 1)
    noise = CLAMP_MARGIN_SD * np.sqrt(np.maximum(ref.var, 0.0) / replica_spp)
    mask = conv.clamp_mask(mean, ref.mean, ceiling, noise)
    if mask.mean() > MAX_CLAMPED:
        return None
    return Correction("clamp", ceiling, None, mask)


def corrections(mean, variance, setup: MeanTestSetup) -> list[Correction]:
    """The conventions worth trying on a test image ``(mean, variance)`` (its moments before
    any correction); a path length one bounce shorter is tried apart
    (:func:`with_convention`), as it may need a reference rendered."""
    out = [Correction("factor", k, _scaled(k)) for k in conv.GLOBAL_FACTORS]
    gains = _gains_correction(mean, variance, setup)
    if gains is not None:
        out.append(gains)
    out += [Correction("srgb", None, _decoded(conv.srgb_decode, conv.srgb_decode_slope)),
            Correction("gamma", conv.GAMMA, _decoded(conv.gamma_decode, conv.gamma_decode_slope))]
    clamp = _clamp_correction(mean, setup)
    if clamp is not None:
        out.append(clamp)
    out += [Correction("flip_vertical", None, _moved(lambda x: conv.flipped(x, True))),
            Correction("flip_horizontal", None, _moved(lambda x: conv.flipped(x, False)))]
    for dy, dx in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        # The renderer's image is Mitsuba's moved by (dy, dx): moved back by (-dy, -dx).
        _, valid = conv.shifted(mean[..., 0], -dy, -dx)
        out.append(Correction("shift", (dy, dx),
                              _moved(lambda x, dy=dy, dx=dx: conv.shifted(x, -dy, -dx)[0]),
                              ~valid))
    for dy, dx in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        out.append(_half_shift_correction(setup.reference, dy, dx))
    return out


def _half_shift_correction(reference, dy: int, dx: int) -> Correction:
    """The renderer's image is Mitsuba's moved by half a pixel in direction ``(dy, dx)``: its
    pixel ``p`` sees the halves of ``p`` and of ``p - (dy, dx)``, so the reference is moved
    instead (the test image cannot be un-averaged)."""
    mean, variance, valid = conv.half_shifted(reference.mean, reference.var, dy, dx)
    moved = SimpleNamespace(mean=mean, var=variance, n=reference.n,
                            metadata=getattr(reference, "metadata", {}))
    return Correction("half_shift", (dy / 2, dx / 2), None, ~valid, moved)


def find_convention(moments_of: Moments, verdict: MeanAgreement, setup: MeanTestSetup,
                    candidates=None) -> ConventionFinding | None:
    """The convention that explains a disagreeing mean ``verdict``, or None.

    Parameters
    ----------
    moments_of : callable
        ``moments_of(transform)``: the test's (mean, per-sample variance) with ``transform``
        applied to each of its images (None: as they are).
    verdict : MeanAgreement
        The mean test that disagreed.
    setup : MeanTestSetup
        How it was run, to run it again.
    candidates : list of Correction, optional
        The corrections to try (default: every one :func:`corrections` offers).
    """
    if verdict.agree:
        return None
    before = conv.tile_chi_square(verdict.z_tiles)
    mean, variance = moments_of(None)
    found = []
    if candidates is None:
        candidates = corrections(mean, variance, setup)
    for correction in candidates:
        fixed = (mean, variance) if correction.transform is None else moments_of(correction.transform)
        if not np.all(np.isfinite(fixed[0])):
            continue
        again = setup.run(*fixed, mask=correction.mask, reference=correction.reference)
        after = conv.tile_chi_square(again.z_tiles)
        if again.agree and conv.explains(before, after, EXPLAIN_RATIO):
            share = 0.0 if correction.mask is None else float(np.mean(correction.mask))
            found.append(ConventionFinding(correction.convention, correction.value,
                                           again.p_value, before, after, share))
    if not found:
        return None
    best = min(found, key=lambda f: f.chi_square_after)
    others = tuple(f"{f.convention} ({f.value})" if isinstance(f.value, str) else f.convention
                   for f in found if f is not best)
    return dataclasses.replace(best, alternatives=others)


class ConventionHint(Hint):
    """A hint naming a convention; ``finding`` is its :meth:`ConventionFinding.record`."""

    finding: dict = {}

    def __new__(cls, finding: ConventionFinding):
        self = super().__new__(cls, convention_text(finding), (f"convention_{finding.convention}",))
        self.finding = finding.record()
        return self

    def __reduce__(self):
        return (_rebuilt_hint, (str(self), self.causes, self.finding))


def _rebuilt_hint(text, causes, finding):
    hint = Hint.__new__(ConventionHint, text, causes)
    hint.finding = finding
    return hint


def _centre_corrections(reference, centre, render_spp) -> list[Correction]:
    """Corrections for pixel samples at the pixel centre: the first sample of each render
    (a fraction ``1 / render_spp`` of them) or every sample. The test image's expectation is
    then ``(1 - f) B + f C`` for Mitsuba's box image ``B`` and its image of the centres ``C``
    (:func:`~mitsuba_refs.verdicts.convention_references.centre_references`), compared with
    the noise of both."""
    fractions = sorted({1.0 / render_spp, 1.0} if render_spp else {1.0})
    counts = pixel_value_counts(centre)[..., None]       # C's variance is var / n_eff
    out = []
    for f in fractions:
        mixed = SimpleNamespace(
            mean=(1 - f) * reference.mean + f * centre.mean,
            var=(1 - f) ** 2 * reference.var + f ** 2 * centre.var * (reference.n / counts),
            n=reference.n, metadata=getattr(reference, "metadata", {}))
        out.append(Correction("centre_samples", f, None, None, mixed))
    return out


def _near_half_shift(moments_of: Moments, verdict: MeanAgreement, setup: MeanTestSetup):
    """The direction ``(dy, dx)`` whose half-pixel correction by neighbours' averages
    (:func:`_half_shift_correction`) explains most of the error without agreeing: where the
    averages are wrong (sharp edges within a pixel), Mitsuba's reference moved exactly
    decides. None when no direction comes near."""
    before = conv.tile_chi_square(verdict.z_tiles)
    mean, variance = moments_of(None)
    best, best_after = None, math.inf
    for dy, dx in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        correction = _half_shift_correction(setup.reference, dy, dx)
        after = conv.tile_chi_square(setup.run(mean, variance, mask=correction.mask,
                                               reference=correction.reference).z_tiles)
        if after < best_after:
            best, best_after = (dy, dx), after
    return best if conv.explains(before, best_after, EXPLAIN_RATIO) else None


def _film_candidates(result, moments_of, setup, settings, log) -> list[Correction]:
    """What keeps the image mean and needs Mitsuba's references of copies of the file:
    another filter, a half-pixel shift measured exactly."""
    reference = setup.reference
    candidates = [Correction("filter", value, None, None, ref) for value, ref
                  in refs.optional(refs.filtered_references, result, settings, reference, log)]
    direction = _near_half_shift(moments_of, result.mean, setup)
    if direction is not None:
        candidates += [Correction("half_shift", value, None, None, ref) for value, ref
                       in refs.optional(refs.half_shift_references, result, settings, reference,
                                        log, direction=direction)]
    return candidates


def _centre_candidates(result, setup, settings, log, render_spp) -> list[Correction]:
    """Samples at the pixel centres, against Mitsuba's image of the centres (which can move
    the image mean far: a small bright light the centres miss)."""
    reference = setup.reference
    return [correction for _, centre
            in refs.optional(refs.centre_references, result, settings, reference, log)
            for correction in _centre_corrections(reference, centre, render_spp)]


def with_convention(result, moments_of: Moments, reference, settings, log=None,
                    render_spp: int | None = None):
    """``result`` (a :class:`~mitsuba_refs.verdicts.compare.Comparison`) with a convention that
    explains its disagreeing mean first among its hints (unchanged when none does).

    The reference one bounce shorter is fetched (rendered when not cached) only when no other
    convention explains the error and the image is too dark, as a missing bounce makes it;
    the references with another filter and moved by half a pixel only when nothing else
    explains it and the image mean is within :data:`FILTER_MEAN_CHANGE` of Mitsuba's, as
    each keeps it; then the image of the pixel centres; those with another field-of-view
    axis last.
    ``render_spp``: the samples of one of the test's renders (a renderer that puts the
    first sample of every render at the pixel centre puts ``1 / render_spp`` there).
    """
    verdict = result.mean
    if not isinstance(verdict, MeanAgreement) or verdict.agree:
        return result
    guard = settings.same_estimator if settings.heavy_tail_guard is None else settings.heavy_tail_guard
    setup = MeanTestSetup.of(verdict, reference, result.spp, bool(guard))
    finding = find_convention(moments_of, verdict, setup)
    if finding is None and verdict.rel_bias_ci[1] < 0:
        finding = find_convention(moments_of, verdict, setup, [
            Correction("bounces", depth, None, None, shorter) for depth, shorter
            in refs.optional(refs.fewer_bounces_reference, result, settings, reference, log)])
    if finding is None and abs(verdict.rel_bias) <= FILTER_MEAN_CHANGE:   # these keep it
        finding = find_convention(moments_of, verdict, setup, _film_candidates(
            result, moments_of, setup, settings, log))
    if finding is None:
        finding = find_convention(moments_of, verdict, setup, _centre_candidates(
            result, setup, settings, log, render_spp))
    if finding is None:
        finding = find_convention(moments_of, verdict, setup, [
            Correction("fov_axis", axis, None, None, ref) for axis, ref
            in refs.optional(refs.fov_axis_references, result, settings, reference, log)])
    if finding is None:
        return result
    return dataclasses.replace(result, hints=[ConventionHint(finding), *result.hints])
