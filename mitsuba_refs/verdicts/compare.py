"""One comparison of a ``pathtracer`` integrator with Mitsuba 3 on one scene file.

Four verdicts, each from :mod:`mitsuba_refs.stats`:

* mean: our image at ``TEST_MAX_SPP`` against the reference (4096 spp),
  tile-aggregated z test;
* variance: only where Mitsuba runs the same estimator (``path``,
  ``path_bsdf``, ``path_nee``, ``direct``), per-sample variance ratio; not applicable,
  saying why, for an external renderer whose error falls faster than N^-1/2 (its samples
  are not independent within a pixel: ``Settings.judge_independence``);
* convergence: MSE against the reference over the spp ladder
  ``CONVERGENCE_LADDER``, every level rendering the same number of samples
  (``CONVERGENCE_REPLICAS`` independent replicas at the top level, 4x as many
  per 4x fewer spp; the error must fall at least as N^-1/2, MSE slope -1 in log-log,
  RMSE(N)/RMSE(4N) = 2, with no bias floor: one-sided, as stratified samples fall faster);
* first diverging bounce: the mean test at max_depth = 1, 2, 3 against the
  per-bounce references, naming the first depth that disagrees.

Our renders and the reference use the same XML file and parameters. What is rendered and how
it is judged is one :class:`mitsuba_refs.settings.Settings`. The convergence test lives in
:mod:`.convergence`, the scene cache in :mod:`.scenes`, the estimators' rules in
:mod:`.estimators`, the text report in :mod:`mitsuba_refs.report.text`.
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pathtracer.core.progress import Progress

from ..reference import config
from ..reference.cache import get_reference
from ..reference.render import bounce_reference
from ..reference.rfilter import reference_correlation
from ..report.text import comparison_report, rendered_settings
from ..report.wording import VARIANCE_NO_ESTIMATOR, bounce_verdict, variance_not_independent
from ..settings import Settings, settings_of
from ..stats import MeanTestOptions, VarianceTestOptions, compare_means, compare_variances
from ..stats.convergence import ConvergenceResult
from ..stats.detectable import DetectableBias
from ..stats.mean import MeanAgreement
from ..stats.variance import TooFewTiles, VarianceAgreement
from .convergence import CONVERGENCE_LADDER, LadderPlan, convergence_ladder, convergence_test, level_replicas
from .detect import SppChoice, choose_spp, comparison_bound
from .estimators import BOUNCE_REFERENCE, SAME_ESTIMATOR, SPLATTING, resolved
from .explain import hints
from .hooks import RecordingRuns, WithOptions
from .rounds import MeanRounds, mean_test_keywords, render_until_decided
from .scenes import default_params, reference_options, render_ours, scene_defaults

__all__ = ["Comparison", "FaultyImages", "compare", "localise_bounce", "write_pictures",
           "TEST_SEED", "BOUNCE_DEPTHS", "COMPARE_ALIASES"]

#: Seed of our mean-and-variance render (the bounce renders: TEST_SEED + depth): far from the
#: convergence seeds (CONVERGENCE_SEED) and from the references' seeds.
TEST_SEED = 1000
#: Depths for per-bounce localisation; ``direct`` stops at 2 by construction.
BOUNCE_DEPTHS = config.PER_BOUNCE_DEPTHS
#: compare's older keyword names -> the Settings fields they set.
COMPARE_ALIASES = {"reference_name": "reference"}


class FaultyImages:
    """The mean verdict of a renderer whose images hold NaN, Inf or negative radiance."""

    agree = False
    p_value = 0.0

    def __init__(self, lines, alpha):
        self.faults, self.alpha = list(lines), alpha    # the line: report.wording.mean_verdict


@dataclass(frozen=True)
class Comparison:
    """Verdicts of one comparison, built once; ``agree`` is True when every test run passed.

    Attributes
    ----------
    scene, integrator, params, spp
        What was compared: the scene, the test side's name, the scene parameters, and the
        samples per pixel of its mean-and-variance render.
    mean, variance, convergence
        The verdicts (variance and convergence None where they did not run).
    convergence_mse, ladder
        The convergence test's MSEs and the spp levels it used.
    bounce, bounce_results
        The first diverging bounce (depth, text) and the mean verdict at each depth.
    pictures, seconds, hints, notes
        Diagnostic PNGs {name: path}, the comparison's seconds, the likely causes, and lines
        the report adds below the verdicts (e.g. what check could not verify).
    rendered, renderer, reference_key, reference_integrator
        What both sides rendered (film, light transport), who rendered the test side, in words
        ("pathtracer path", an external renderer's name: ``--name`` or the short form of its
        command), the reference's cache key and the Mitsuba estimator that rendered it.
    command : str
        An external renderer's command template, or the images it was judged from ("" for ours).
    same_estimator : bool or None
        Whether the test side runs the reference's estimator (the variance verdict applies).
    runs : list of dict
        One record per render of the test side: purpose, seed, spp, seconds, ...
    arrays : dict
        The images the verdicts were drawn from, (H, W, 3) float arrays: test_mean,
        test_variance (per sample), reference_mean, reference_variance. Not serialised.
    detectable, detect
        The smallest global bias the mean test detects, and what ``detect`` chose; None when
        not computed / not asked.
    variance_skipped : str
        Why there is no variance verdict when the reason is not that Mitsuba has no run of
        the estimator ("" otherwise): too few noisy tiles, samples that are not independent
        within a pixel (``Settings.judge_independence``), no ``--same-estimator`` (check).
    not_run : dict
        Why the ``"convergence"`` or ``"bounces"`` verdict was not run, where the reason is not
        an option of the command (images rendered elsewhere cannot be rendered again).
    rounds : MeanRounds or None
        With a tolerance: how the mean verdict was decided in rounds (its outcome replaces
        ``mean.agree``; ``mean`` is then the equal-means test of the final images, kept for
        the tiles, pictures and causes).
    """

    scene: str | Path
    integrator: str
    params: dict
    spp: int
    mean: MeanAgreement | FaultyImages | None
    variance: VarianceAgreement | None = None
    convergence: ConvergenceResult | None = None
    convergence_mse: list | np.ndarray | None = None
    ladder: tuple[int, ...] = CONVERGENCE_LADDER
    bounce: tuple[int | None, str] | None = None
    bounce_results: dict[int, MeanAgreement] | None = None
    pictures: dict[str, str] = field(default_factory=dict)
    seconds: float = 0.0
    hints: list[str] = field(default_factory=list)
    rendered: str = ""
    same_estimator: bool | None = None
    renderer: str = ""
    command: str = ""
    reference_key: str = ""
    reference_integrator: str = ""
    runs: list[dict] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    arrays: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    detectable: DetectableBias | None = None
    detect: SppChoice | None = None
    variance_skipped: str = ""
    not_run: dict[str, str] = field(default_factory=dict)
    rounds: MeanRounds | None = None

    @property
    def outcome(self) -> str:
        """AGREES, DISAGREES or INCONCLUSIVE: DISAGREES when any verdict disagrees,
        INCONCLUSIVE when none does but the mean is undecided (docs/statistics.md, section 9)."""
        others = [] if self.variance is None else [self.variance.agree]
        if self.convergence is not None:
            others.append(self.convergence.passed)
        if self.rounds is None:
            return "AGREES" if self.mean.agree and all(others) else "DISAGREES"
        if isinstance(self.mean, FaultyImages) or self.rounds.outcome == "DISAGREES" \
                or not all(others):
            return "DISAGREES"
        return self.rounds.outcome

    @property
    def agree(self) -> bool:
        if self.rounds is not None:
            return self.outcome == "AGREES"
        parts = [self.mean.agree]
        if self.variance is not None:
            parts.append(self.variance.agree)
        if self.convergence is not None:
            parts.append(self.convergence.passed)
        return all(parts)

    @property
    def compares_variance(self) -> bool:
        """Whether the test side runs the reference's estimator (variances comparable)."""
        if self.same_estimator is not None:
            return self.same_estimator
        return self.integrator in SAME_ESTIMATOR

    def variance_not_applicable(self) -> str:
        """Why there is no variance verdict, with the ratio where both images have one."""
        text = self.variance_skipped or VARIANCE_NO_ESTIMATOR
        test, ref = self.arrays.get("test_variance"), self.arrays.get("reference_variance")
        if test is not None and ref is not None and np.sum(ref) > 0:
            ratio = float(np.sum(test) / np.sum(ref))
            text += f"; the per-sample variance is {ratio:.2f}x the reference's"
        return text

    def report(self) -> str:
        """A few lines a student can read (:func:`mitsuba_refs.report.text.comparison_report`)."""
        return comparison_report(self)


def compare(scene: str, integrator="path", params: dict | None = None,
            settings: Settings | None = None, *, render=render_ours, log=None,
            **keywords) -> Comparison:
    """Compare one integrator with Mitsuba on ``scene``.

    Parameters
    ----------
    scene : str
        Built-in scene name or XML path (the same file Mitsuba renders).
    integrator : str or pathtracer.Integrator
        Ours; an instance (e.g. a student's) is rendered as is and compared
        with the reference of its ``name``.
    params : dict, optional
        Scene parameters (``-D``); built-in scenes default to the test film size.
    settings : mitsuba_refs.settings.Settings, optional
        What is rendered and how it is judged (default ``Settings()``: the command line's
        defaults). Its ``reference``, ``same_estimator`` and ``splatting`` are for a test side
        that is not one of ours (:mod:`mitsuba_refs.external`); by default they follow from
        ``integrator`` (:func:`mitsuba_refs.verdicts.estimators.resolved`).
    render : callable
        ``render(scene, integrator, params, spp, seed, processes=..., max_depth=...)``
        returning (mean, variance); the autograder passes an isolated one.
    log : callable, optional
        Called with progress lines (a reference being rendered, what ``detect`` chose).
    **keywords
        Fields of :class:`~mitsuba_refs.settings.Settings` replacing those of ``settings``
        (``compare(scene, spp=64, convergence=False)``); ``reference_name`` is the older name
        of ``reference``.
    """
    start = time.perf_counter()
    ours = render is render_ours    # an external renderer's runs say their own progress
    name = integrator if isinstance(integrator, str) else integrator.name
    settings = resolved(settings_of(settings, keywords, "compare", COMPARE_ALIASES), name)
    params = {**default_params(scene), **(params or {})}
    reference = get_reference(scene, params, settings.reference, log=log,
                              options=reference_options(settings.options),
                              resolution=settings.resolution)
    if settings.options:
        render = WithOptions(render, settings.options)
    if settings.resolution is not None:
        render = WithOptions(render, {"resolution": tuple(settings.resolution)})

    runs = []    # one dict per render of ours (purpose, seed, spp, seconds): the report's runs
    choice = None if settings.detect is None else choose_spp(
        settings, RecordingRuns(render, runs, "pilot"), scene, integrator, params, reference,
        log=log)
    settings = settings if choice is None else dataclasses.replace(settings, spp=choice.spp)
    spp, alpha, same = settings.spp, settings.alpha, settings.same_estimator
    if log and ours and settings.tolerance is None:
        log(f"compare: {name} at {spp} spp for the mean and variance verdicts")
    # A tent or gaussian film correlates neighbouring pixels (docs/statistics.md).
    correlation = reference_correlation(reference)
    rounds = None
    if settings.tolerance is None:
        mean, variance = RecordingRuns(render, runs, "mean")(scene, integrator, params, spp,
                                                               TEST_SEED, processes=settings.processes)
    else:     # render in rounds until the mean is decided (verdicts.rounds)
        def piece(k):    # an independent, cached piece of the reference: its own seed
            return get_reference(scene, params, settings.reference, seed=config.REF_SEED + k,
                                 log=log, options=reference_options(settings.options),
                                 resolution=settings.resolution)
        mean, variance, spp, rounds, reference = render_until_decided(
            RecordingRuns(render, runs, "mean"), scene, integrator, params, reference, settings,
            correlation, TEST_SEED, log=log, reference_piece=piece)
    mean_test = compare_means(mean, variance, spp, reference.mean, reference.var, reference.n,
                              alpha=alpha, **mean_test_keywords(settings, correlation))
    detectable = comparison_bound(reference, variance, spp, alpha=alpha, same=same,
                                  splats=settings.splatting, guard=settings.heavy_tail_guard)
    variance_test, skipped = None, ""
    if same and (np.any(variance) or np.any(reference.var)):    # else both noiseless
        try:
            variance_test = compare_variances(variance, spp, reference.var, reference.n,
                                              alpha=alpha, mean_a=mean, mean_b=reference.mean,
                                              options=VarianceTestOptions(pixel_correlation=correlation))
        except TooFewTiles as few:    # e.g. max_depth 1: noisy at a few edges only
            skipped = f"not tested: {str(few).split(';')[0]} (a nearly " \
                      "noiseless image; the mean test decides)"
    law, mse, ladder = None, None, CONVERGENCE_LADDER
    if settings.convergence:
        progress = ladder_progress(settings) if log and ours else None
        law, mse = convergence_test(scene, integrator, params, reference, alpha, settings.processes,
                                    RecordingRuns(render, runs, "convergence", progress),
                                    LadderPlan.of(settings))
        if progress is not None:
            progress.close()
        ladder = convergence_ladder(reference, settings.ladder)
    if variance_test is not None and settings.judge_independence and law is not None and law.faster:
        # Stratified samples: a pixel's noise is no per-sample variance over N (stats.convergence).
        variance_test, skipped = None, variance_not_independent(law)
    bounce_results = bounce = None
    mean_disagrees = not mean_test.agree if rounds is None else rounds.outcome == "DISAGREES"
    if settings.bounces or (settings.bounces is None and mean_disagrees):
        if log and ours:
            log("compare: per-bounce renders, to find the first bounce that differs")
        bounce_results = localise_bounce(scene, integrator, params, settings,
                                         RecordingRuns(render, runs, "bounces"), log=log,
                                         reference_name=bounce_reference(settings.reference))
        bounce = bounce_verdict(bounce_results)
    result = Comparison(
        scene, name, params, spp, mean_test, variance=variance_test, convergence=law,
        convergence_mse=mse, ladder=ladder, bounce=bounce, bounce_results=bounce_results,
        rendered=rendered_settings(reference.metadata), same_estimator=same,
        renderer=f"pathtracer {name}", reference_key=str(reference.metadata.get("key", "")),
        reference_integrator=settings.reference, runs=runs,
        notes=[choice.reason] if choice is not None else [],
        arrays={"test_mean": mean, "test_variance": variance,
                "reference_mean": reference.mean, "reference_variance": reference.var},
        detectable=detectable, detect=choice, variance_skipped=skipped, rounds=rounds)
    return concluded(result, settings.out_dir, (mean, variance, reference), start)


def ladder_progress(settings: Settings) -> Progress:
    """The progress of the convergence renders (more when rare errors make the test grow)."""
    renders = sum(level_replicas(settings.ladder, settings.replicas))
    return Progress(renders, f"compare: convergence ladder {','.join(map(str, settings.ladder))}",
                    "renders")


def concluded(result: Comparison, out_dir, images, start: float) -> Comparison:
    """``result`` with its likely causes, its pictures in ``out_dir`` (none when None) drawn
    from ``images`` = (test mean, test variance, reference), and the seconds since ``start``."""
    causes = hints(result)
    pictures = {} if out_dir is None else write_pictures(result, Path(out_dir), *images)
    return dataclasses.replace(result, hints=causes, pictures=pictures,
                               seconds=time.perf_counter() - start)


def write_pictures(result: Comparison, out_dir: Path, mean, variance, reference) -> dict:
    """Diagnostic PNGs for the verdicts (:func:`mitsuba_refs.report.diagnostics.write_pictures`)."""
    # The pictures are drawn with matplotlib (heavy): imported only when there are some to draw.
    from ..report.diagnostics import write_pictures as draw
    return draw(result, out_dir, mean, variance, reference)


def localise_bounce(scene, integrator, params, settings: Settings, render, *,
                    reference_name=None, log=None):
    """Mean agreement with Mitsuba's ``path`` at max_depth = 1, 2, 3: {depth: MeanAgreement}.

    ``settings`` give the renders' ``spp``, ``processes``, ``options`` and ``resolution``, and
    the mean test's ``alpha`` and ``splatting`` (None: from the integrator). The references are
    Mitsuba's ``reference_name`` (default: ``path``, ``volpath`` for a volumetric integrator).

    The depth reaches the reference as the ``max_depth`` parameter when the file declares
    one (the committed per-bounce references), else as an integrator override. An
    ``rr_depth`` that cannot act within ``depth`` segments (>= depth, as is the file's own)
    is dropped: both give the estimator without roulette, and the file's is the committed
    reference (the grader's glass checks pass ``rr_depth`` = 8).
    """
    name = integrator if isinstance(integrator, str) else integrator.name
    splats = name in SPLATTING if settings.splatting is None else settings.splatting
    depths = [d for d in BOUNCE_DEPTHS if not (name == "direct" and d > 2)]
    defaults = scene_defaults(scene)
    as_param = "max_depth" in defaults
    file_rr_depth = defaults.get("rr_depth")
    results = {}
    for depth in depths:
        overrides = dict(reference_options(settings.options) or {})
        if as_param:
            overrides.pop("max_depth", None)
            depth_params = {**params, "max_depth": depth}
        else:
            depth_params, overrides["max_depth"] = dict(params), depth
        if file_rr_depth is not None and int(file_rr_depth) >= depth:
            for given in (depth_params, overrides):
                if "rr_depth" in given and int(given["rr_depth"]) >= depth:
                    del given["rr_depth"]
        reference = get_reference(scene, depth_params,
                                  reference_name or BOUNCE_REFERENCE.get(name, "path"), log=log,
                                  options=overrides or None, resolution=settings.resolution)
        mean, variance = render(scene, integrator, params, settings.spp, TEST_SEED + depth,
                                processes=settings.processes, max_depth=depth)
        results[depth] = compare_means(mean, variance, settings.spp, reference.mean, reference.var,
                                       reference.n, alpha=settings.alpha,
                                       image_components=not splats,
                                       options=MeanTestOptions(pixel_correlation=reference_correlation(reference)))
    return results
