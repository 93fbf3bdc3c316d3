"""Differences of convention: when a disagreement is one, which, and the proof.

A renderer can be right in its own conventions and disagree with Mitsuba: lights in other
units, a white balance, an encoded or clamped output, a flipped image, one shifted by a
pixel or half of one, a path length counted differently, another reconstruction filter or
field-of-view axis. On a disagreement of the mean,
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
import hashlib
import math
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Callable

import numpy as np

from pathtracer.scene.xml_files import scene_files

from ..errors import ReferenceUnavailable, RefsInputError
from ..reference.cache import get_reference
from ..reference.render import resolve_scene
from ..reference.rfilter import reference_correlation
from ..report.wording import convention_text
from ..stats import conventions as conv
from ..stats.mean import MeanAgreement, MeanTestOptions, compare_means
from .explain import Hint
from .scenes import reference_options, scene_defaults

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
#: The film filter the references with another one replace, and those they try instead (the
#: filters whose references Mitsuba renders here: mitsuba_refs.reference.filtered).
BOX_FILTER = '<rfilter type="box"/>'
OTHER_FILTERS = ("gaussian", "tent")
#: What Mitsuba's ``fov_axis`` can mean on a film (``smaller`` and ``larger`` are one of x, y).
FOV_AXES = ("x", "y", "diagonal")
#: Another filter is tried only when the image mean is within this of Mitsuba's: a filter
#: keeps the mean, up to the border of the film and, at few samples per pixel, the bias of
#: the film's weighted average (+1.0 to +1.2 % for 8-spp replicas of the Cornell box and
#: smallpt with a tent or gaussian filter).
FILTER_MEAN_CHANGE = 0.03
#: References a convention needs are rendered (when not cached) only for films of at most
#: this many pixels: a 4096-spp reference of 64 x 64 takes 10-14 s here, one of 512 x 512
#: 64 times as long, too much to spend on a guess; larger films use cached ones only.
MAX_RENDERED_PIXELS = 128 * 128
#: Samples per pixel of the references of a file's copies (another filter or fov axis): a
#: quarter of a committed reference's, a quarter of the time. The mean test counts the
#: reference's noise, so it stays valid; against a 64-spp test its standard error grows by
#: 2 % (sqrt((1 + 1/16) / (1 + 1/64))).
COPY_REFERENCE_SPP = 1024
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
        ``filter`` or ``fov_axis``.
    value : float, tuple or None
        Its parameter: the factor, the gains, the ceiling, the shift (dy, dx) in pixels, the
        depth, the filter's type, the field-of-view axis.
    transform : callable or None
        ``(mean, variance or None) -> (mean, variance or None)`` for one image; None: the
        image is left as it is.
    mask : (H, W) bool array or None
        Pixels the corrected comparison leaves out (on both sides).
    reference : Reference or None
        Another reference to compare with (``bounces``, ``half_shift``, ``filter``,
        ``fov_axis``); None: the comparison's.
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


def fewer_bounces_reference(scene, params, settings, reference, log=None):
    """``(depth - 1, Mitsuba's reference at max_depth depth - 1)`` when the reference's path
    length ``depth`` is bounded and at least 2, else None. The depth reaches Mitsuba as the
    file's ``max_depth`` parameter where it declares one (the committed per-bounce
    references), else as an override (a render of the reference when it is not cached)."""
    depth = int((reference.metadata.get("mitsuba_integrator") or {}).get("max_depth", -1))
    if depth < 2:
        return None
    overrides = dict(reference_options(settings.options) or {})
    depth_params = dict(params)
    if "max_depth" in scene_defaults(scene):
        overrides.pop("max_depth", None)
        depth_params["max_depth"] = depth - 1
    else:
        overrides["max_depth"] = depth - 1
    shorter = get_reference(scene, depth_params, settings.reference, log=log,
                            options=overrides or None, resolution=settings.resolution,
                            render=_may_render(reference))
    return depth - 1, shorter


def _may_render(reference) -> bool:
    """Whether a reference of this film may be rendered for a convention
    (:data:`MAX_RENDERED_PIXELS`)."""
    height, width = reference.mean.shape[:2]
    return height * width <= MAX_RENDERED_PIXELS


def _file_copies(scene, old: str, news) -> list:
    """Copies of the scene file with its one ``old`` text replaced by each of ``news``:
    ``[(new, path), ...]``, written to ``<temp>/mitsuba-refs-conventions`` and named by their
    content (so that their references are found in the cache next time). Empty when the
    file holds ``old`` other than once, or reads other files (a copy elsewhere could not)."""
    path = resolve_scene(scene)
    text = path.read_text()
    if text.count(old) != 1 or scene_files(str(path)):
        return []
    folder = Path(tempfile.gettempdir()) / "mitsuba-refs-conventions"
    folder.mkdir(parents=True, exist_ok=True)
    copies = []
    for new in news:
        changed = text.replace(old, new)
        digest = hashlib.sha256(changed.encode()).hexdigest()[:12]
        copy = folder / f"{path.stem}-{digest}.xml"
        if not copy.exists():
            copy.write_text(changed)
        copies.append((new, copy))
    return copies


def _copied_references(convention, copies, values, params, settings, reference, log):
    """The corrections comparing with Mitsuba's references of the file ``copies``, at
    :data:`COPY_REFERENCE_SPP`."""
    return [Correction(convention, value, None, None,
                       get_reference(str(copy), params, settings.reference,
                                     spp=COPY_REFERENCE_SPP, log=log,
                                     options=reference_options(settings.options),
                                     resolution=settings.resolution,
                                     render=_may_render(reference)))
            for value, (_, copy) in zip(values, copies)]


def filtered_references(scene, params, settings, reference, log=None) -> list[Correction]:
    """Corrections for another reconstruction filter: Mitsuba's references of copies of the
    file with each of :data:`OTHER_FILTERS` in place of its box filter (rendered when not
    cached: one reference each). Only for a file whose film has exactly
    ``<rfilter type="box"/>`` and that reads no other file."""
    copies = _file_copies(scene, BOX_FILTER, [f'<rfilter type="{kind}"/>' for kind in OTHER_FILTERS])
    return _copied_references("filter", copies, OTHER_FILTERS, params, settings, reference, log)


def _effective_axis(axis: str, width: int, height: int) -> str:
    """``x``, ``y`` or ``diagonal``: what Mitsuba's ``fov_axis`` means on this film."""
    if axis == "smaller":
        return "x" if width <= height else "y"
    if axis == "larger":
        return "x" if width >= height else "y"
    return axis


def fov_axis_references(scene, params, settings, reference, log=None) -> list[Correction]:
    """Corrections for another field-of-view axis: Mitsuba's references of copies of the file
    whose one ``fov_axis`` is each axis that means something else on this film (x, y,
    diagonal; x and y are the same on a square film). Only for a file with exactly one
    ``<string name="fov_axis" .../>`` that reads no other file."""
    text = resolve_scene(scene).read_text()
    found = re.findall(r'<string name="fov_axis" value="(\w+)"/>', text)
    if len(found) != 1:
        return []
    height, width = reference.mean.shape[:2]
    own = _effective_axis(found[0], width, height)
    others = [axis for axis in FOV_AXES if axis != own
              and not (width == height and {axis, own} == {"x", "y"})]
    old = f'<string name="fov_axis" value="{found[0]}"/>'
    copies = _file_copies(scene, old, [f'<string name="fov_axis" value="{a}"/>' for a in others])
    return _copied_references("fov_axis", copies, others, params, settings, reference, log)


def _optional(fetch, result, settings, reference, log):
    """The references a convention needs (``fetch``), or None when they cannot be had (no
    Mitsuba and nothing cached, a film larger than :data:`MAX_RENDERED_PIXELS` and nothing
    cached, a cache that cannot be written, a film Mitsuba's variant cannot filter): the
    convention is then not tried, and the verdicts stand as they are."""
    try:
        return fetch(result.scene, result.params, settings, reference, log=log)
    except (ReferenceUnavailable, RefsInputError) as missing:
        if log is not None:
            log(f"conventions: not tried ({str(missing).splitlines()[0]})")
        return None


def with_convention(result, moments_of: Moments, reference, settings, log=None):
    """``result`` (a :class:`~mitsuba_refs.verdicts.compare.Comparison`) with a convention that
    explains its disagreeing mean first among its hints (unchanged when none does).

    The reference one bounce shorter is fetched (rendered when not cached) only when no other
    convention explains the error and the image is too dark, as a missing bounce makes it;
    the references with another filter only when nothing else explains it and the image mean
    is within :data:`FILTER_MEAN_CHANGE` of Mitsuba's, as a filter keeps it; those with
    another field-of-view axis last.
    """
    verdict = result.mean
    if not isinstance(verdict, MeanAgreement) or verdict.agree:
        return result
    guard = settings.same_estimator if settings.heavy_tail_guard is None else settings.heavy_tail_guard
    setup = MeanTestSetup.of(verdict, reference, result.spp, bool(guard))
    finding = find_convention(moments_of, verdict, setup)
    if finding is None and verdict.rel_bias_ci[1] < 0:
        shorter = _optional(fewer_bounces_reference, result, settings, reference, log)
        if shorter is not None:
            depth, shorter_reference = shorter
            finding = find_convention(moments_of, verdict, setup,
                                      [Correction("bounces", depth, None, None, shorter_reference)])
    if finding is None and abs(verdict.rel_bias) <= FILTER_MEAN_CHANGE:   # a filter keeps it
        finding = find_convention(moments_of, verdict, setup,
                                  _optional(filtered_references, result, settings, reference, log)
                                  or [])
    if finding is None:
        finding = find_convention(moments_of, verdict, setup,
                                  _optional(fov_axis_references, result, settings, reference, log)
                                  or [])
    if finding is None:
        return result
    return dataclasses.replace(result, hints=[ConventionHint(finding), *result.hints])
