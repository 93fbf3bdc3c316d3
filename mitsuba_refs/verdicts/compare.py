"""One comparison of a ``pathtracer`` integrator with Mitsuba 3 on one scene file.

Four verdicts, each from :mod:`mitsuba_refs.stats`:

* mean: our image at ``TEST_MAX_SPP`` against the reference (4096 spp),
  tile-aggregated z test;
* variance: only where Mitsuba runs the same estimator (``path``,
  ``path_bsdf``, ``path_nee``, ``direct``), per-sample variance ratio;
* convergence: MSE against the reference over the spp ladder
  ``CONVERGENCE_LADDER``, every level rendering the same number of samples
  (``CONVERGENCE_REPLICAS`` independent replicas at the top level, 4x as many
  per 4x fewer spp; slope -1 in log-log, RMSE(N)/RMSE(4N) = 2, no bias floor);
* first diverging bounce: the mean test at max_depth = 1, 2, 3 against the
  per-bounce references, naming the first depth that disagrees.

Our renders and the reference use the same XML file and parameters.
"""
from __future__ import annotations

import dataclasses
import functools
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pathtracer import load_scene, render
from pathtracer.integrators import INTEGRATORS
from pathtracer.render.driver import SCENE_OPTIONS

from ..reference import config
from ..reference.cache import get_reference, scene_hash
from ..reference.render import bounce_reference, resolve_scene, xml_defaults
from ..reference.rfilter import pixel_value_counts, reference_correlation
from ..report.wording import bounce_verdict, convergence_verdict, mean_line, status_text, variance_verdict
from ..stats import (
    MeanTestOptions,
    VarianceTestOptions,
    compare_means,
    compare_variances,
    convergence_law,
    image_mse_parts,
    rare_errors_dominate,
    reference_mse_floor,
)
from ..stats.mean import VARIANCE_BOUND
from ..stats.variance import TooFewTiles
from .detect import choose_spp, comparison_bound
from .explain import hints
from .hooks import RecordingRuns, WithOptions, mean_of

#: spp ladder of the convergence test and its replicas at the top level (defined in config,
#: so that the command line's parser does not import the statistics).
CONVERGENCE_LADDER = config.CONVERGENCE_LADDER
CONVERGENCE_REPLICAS = config.CONVERGENCE_REPLICAS
#: The replicas double (at every level) while rare bright paths carry the mean MSE
#: (stats.rare_errors_dominate), up to this many times the first count.
CONVERGENCE_MAX_GROWTH = 16
#: Our integrators whose Mitsuba reference runs the same estimator (variance comparable).
SAME_ESTIMATOR = ("path", "path_bsdf", "path_nee", "direct", "light", "volpath")
#: Integrators whose paths splat into many pixels: pixels are correlated across the image,
#: so the mean test leaves out its whole-image components (docs/statistics.md, section 8).
SPLATTING = tuple(name for name, cls in INTEGRATORS.items() if cls.splats)
#: Mean-only integrators are compared with the Mitsuba estimator closest to theirs.
#: The tile test pools both sides' variances; against a much smoother estimator, a
#: tile where rare light hits happened not to occur (estimated variance 0) would look
#: significant. smallpt samples BSDFs only, recursive uses shadow rays without MIS.
#: ``volpathmis`` has Mitsuba's estimator of that name, weighted per path, not per flight.
CLOSEST_ESTIMATOR = {"smallpt": "path_bsdf", "recursive": "path_nee", "volpath_phase": "volpath",
                     "volpathmis": "volpathmis"}
#: Each replica image is split into INTERLEAVE x INTERLEAVE interleaved sub-lattices
#: (pixel (i, j) -> lattice (i mod s, j mod s)). Pixels are independent, so the
#: sub-lattices are independent pseudo-replicas that all see the whole image: the
#: mean MSE is unchanged and its uncertainty gets K * s^2 - 1 degrees of freedom
#: instead of K - 1, which is what gives the test power at a small alpha.
INTERLEAVE = 4
#: Lowest convergence level of a tent or gaussian film (ratio estimator, see convergence_test).
FILTERED_MIN_SPP = 4
#: A filtered film's renders are cut into BLOCKS x BLOCKS contiguous blocks (_spatial_blocks).
BLOCKS = 4
#: Seeds of our renders: far from each other and from the references' seeds.
TEST_SEED = 1000
CONVERGENCE_SEED = 2000
#: Mitsuba estimator of the per-bounce references: ``path``, but ``volpath`` for the
#: volumetric integrators (``path`` ignores media).
BOUNCE_REFERENCE = {"volpath": "volpath", "volpath_phase": "volpath", "volpathmis": "volpath"}
#: Depths for per-bounce localisation; ``direct`` stops at 2 by construction.
BOUNCE_DEPTHS = config.PER_BOUNCE_DEPTHS


def reference_integrator(name: str) -> str:
    """The Mitsuba estimator a comparison uses: the same one, or the closest (mean only)."""
    return name if name in SAME_ESTIMATOR else CLOSEST_ESTIMATOR.get(name, "path")


def default_params(scene: str) -> dict:
    """The test film size of a built-in scene (the committed references' resolution)."""
    if scene in config.BUILTIN_SCENES or scene in config.FEATURE_SCENES or scene in config.GRADING_SCENES:
        width, height = config.test_resolution(scene)
        return {"width": width, "height": height}
    return {}


@dataclass
class Comparison:
    """Verdicts of one comparison; ``agree`` is True when every test run passed."""

    scene: str
    integrator: str
    params: dict
    spp: int
    mean: object
    variance: object = None
    convergence: object = None
    convergence_mse: list = None
    ladder: tuple = CONVERGENCE_LADDER
    bounce: tuple = None
    bounce_results: dict = None
    pictures: dict = field(default_factory=dict)
    seconds: float = 0.0
    hints: list = field(default_factory=list)
    rendered: str = ""
    #: Whether the test side runs the reference's estimator (the variance verdict applies).
    same_estimator: bool = None
    #: Who rendered the test side, in words ("pathtracer path", "command: ./smallpt ...").
    renderer: str = ""
    #: The reference's cache key and the Mitsuba estimator that rendered it.
    reference_key: str = ""
    reference_integrator: str = ""
    #: One dict per render of the test side (check: external runs): seed, spp, seconds, ...
    runs: list = field(default_factory=list)
    #: Lines the report adds below the verdicts (e.g. what check could not verify).
    notes: list = field(default_factory=list)
    #: The images the verdicts were drawn from, (H, W, 3) float arrays: test_mean,
    #: test_variance (per sample), reference_mean, reference_variance. Not serialised.
    arrays: dict = field(default_factory=dict, repr=False)
    #: The smallest global bias the mean test detects (stats.detectable.DetectableBias), and
    #: what --detect chose (detect.SppChoice); None when not computed / not asked.
    detectable: object = None
    detect: object = None
    #: Why the variance test did not run although it applies ("" otherwise).
    variance_skipped: str = ""

    @property
    def agree(self) -> bool:
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
        text = self.variance_skipped or "not applicable (Mitsuba has no run of this estimator; mean only)"
        test, ref = self.arrays.get("test_variance"), self.arrays.get("reference_variance")
        if test is not None and ref is not None and np.sum(ref) > 0:
            ratio = float(np.sum(test) / np.sum(ref))
            text += f"; the per-sample variance is {ratio:.2f}x the reference's"
        return text

    def report(self) -> str:
        """A few lines a student can read."""
        lines = [f"{self.integrator} on {self.scene} ({self.spp} spp): {status_text(self)}",
                 f"  mean:        {mean_line(self)}"]
        if self.rendered:
            lines.insert(1, f"  rendered:    {self.rendered}")
        if self.variance is not None:
            lines.append(f"  variance:    {variance_verdict(self.variance)}")
        elif self.variance_skipped:
            lines.append(f"  variance:    {self.variance_skipped}")
        elif self.compares_variance:
            lines.append("  variance:    not compared (both images are noiseless)")
        else:
            lines.append(f"  variance:    {self.variance_not_applicable()}")
        if self.convergence is not None:
            lines.append(f"  convergence: {convergence_verdict(self.convergence)}")
        if self.bounce is not None:
            lines.append(f"  bounces:     {self.bounce[1]}")
        for hint in self.hints:
            lines.append(f"  likely cause: {hint}")
        for note in self.notes:
            lines.append(f"  note:        {note}")
        for name, path in self.pictures.items():
            lines.append(f"  picture ({name}): {path}")
        lines.append(f"  ({self.seconds:.1f} s)")
        return "\n".join(lines)


def render_ours(scene, integrator, params, spp, seed, processes=None, resolution=None,
                **options):
    """Our render of ``scene`` with ``params`` (film size ``resolution`` if given):
    (mean, variance)."""
    result = render(loaded_scene(scene, params, resolution), integrator, spp=spp, seed=seed,
                    processes=processes, progress=False, **options)
    return result.mean, result.variance


def reference_options(options) -> dict | None:
    """The light-transport options among our render ``options`` (max_depth, rr_depth,
    hide_emitters): the reference is rendered with them too."""
    chosen = {k: v for k, v in (options or {}).items() if k in SCENE_OPTIONS and v is not None}
    return chosen or None


def scene_defaults(scene) -> dict:
    """The scene file's ``<default name=... value=...>`` declarations, {name: value}."""
    return xml_defaults(resolve_scene(scene))


def loaded_scene(scene, params, resolution=None):
    """``pathtracer.load_scene(scene, resolution=..., **params)``, reused while the files are unchanged.

    The convergence test renders a scene up to hundreds of times; loading it (and building
    a mesh's BVH) once saves most of the time on the 82k-triangle scene.
    """
    try:
        content = scene_hash(scene)
    except (OSError, ValueError):
        return load_scene(scene, resolution=resolution, **params)  # the loader reports what is wrong
    return _load_scene_cached(str(scene), content,
                              tuple(sorted((str(k), str(v)) for k, v in params.items())),
                              None if resolution is None else tuple(resolution))


@functools.lru_cache(maxsize=4)
def _load_scene_cached(scene, content, params, resolution):
    return load_scene(scene, resolution=resolution, **dict(params))


def compare(scene: str, integrator="path", params: dict | None = None, *,
            spp: int = config.TEST_MAX_SPP, alpha: float = 1e-3, convergence: bool = True,
            bounces: bool | None = None, out_dir=None, processes=None, render=render_ours,
            ladder=CONVERGENCE_LADDER, replicas=CONVERGENCE_REPLICAS,
            max_growth=CONVERGENCE_MAX_GROWTH, options=None, resolution=None,
            log=None, reference_name=None, same_estimator=None,
            splatting=None, detect=None, heavy_tail_guard=None) -> Comparison:
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
    spp : int
        Samples per pixel of our mean/variance render (at most TEST_MAX_SPP
        for the committed references to be 64x as precise).
    alpha : float
        Significance level of each of the tests.
    convergence : bool
        Run the convergence-law test.
    bounces : bool, optional
        Localise the first diverging bounce (default: only when the mean disagrees).
    out_dir : path, optional
        Where diagnostic pictures go (written for every failed test).
    render : callable
        ``render(scene, integrator, params, spp, seed, processes=..., max_depth=...)``
        returning (mean, variance); the autograder passes an isolated one.
    ladder, replicas, max_growth
        spp levels (4x steps) of the convergence test, its independent replicas at the
        top level (equal work per level: :func:`level_replicas`) and the most its renders
        may grow while rare paths dominate (:func:`convergence_test`).
    options : dict, optional
        Integrator options passed to every render of ours (e.g. branches); those that
        set the light transport (max_depth, rr_depth, hide_emitters) go to the reference too.
    resolution : (int, int), optional
        Film size replacing the file's on both sides.
    reference_name, same_estimator, splatting : optional
        For a test side that is not one of ours (:mod:`mitsuba_refs.external`): the reference
        estimator (our name for it, e.g. ``light`` for Mitsuba's ``ptracer``), whether the test
        side runs that same estimator (then the variance verdict applies), and whether its
        paths splat into many pixels. By default all three follow from ``integrator``.
    detect : mitsuba_refs.verdicts.detect.Detect, optional
        Choose ``spp`` from a pilot render so that the mean test sees ``detect.target``
        (:func:`mitsuba_refs.verdicts.detect.choose_spp`); replaces ``spp``.
    heavy_tail_guard : bool, optional
        The mean test's ``same_estimator`` guard (:mod:`mitsuba_refs.stats.mean`): on for the
        same estimator unless False (the grader's: its power was measured without it).
    """
    start = time.perf_counter()
    name = integrator if isinstance(integrator, str) else integrator.name
    params = {**default_params(scene), **(params or {})}
    ref_name = reference_name or reference_integrator(name)
    same = name in SAME_ESTIMATOR if same_estimator is None else bool(same_estimator)
    splats = name in SPLATTING if splatting is None else bool(splatting)
    guard = same if heavy_tail_guard is None else bool(heavy_tail_guard)
    reference = get_reference(scene, params, ref_name, log=log, options=reference_options(options),
                              resolution=resolution)
    if options:
        render = WithOptions(render, options)
    if resolution is not None:
        render = WithOptions(render, {"resolution": tuple(resolution)})

    runs = []    # one dict per render of ours (purpose, seed, spp, seconds): the report's runs
    choice = None if detect is None else choose_spp(
        detect, RecordingRuns(render, runs, "pilot"), scene, integrator, params, reference,
        alpha=alpha, same=same, splats=splats, processes=processes, log=log)
    spp = spp if choice is None else choice.spp
    mean, variance = RecordingRuns(render, runs, "mean")(scene, integrator, params, spp, TEST_SEED,
                                                           processes=processes)
    # Same estimator on both sides: a test-side variance far above the reference's is
    # itself wrong, so it may not hide a bias (stats.mean.VARIANCE_BOUND).
    bound = VARIANCE_BOUND if same else None
    # A tent or gaussian film correlates neighbouring pixels (docs/statistics.md).
    correlation = reference_correlation(reference)
    result = Comparison(scene, name, params, spp,
                        compare_means(mean, variance, spp, reference.mean, reference.var,
                                      reference.n, alpha=alpha, max_var_ratio=bound,
                                      image_components=not splats,
                                      options=MeanTestOptions(pixel_correlation=correlation, same_estimator=guard)))
    result.detectable = comparison_bound(reference, variance, spp, alpha=alpha, same=same,
                                         splats=splats, guard=guard)
    result.detect = choice
    result.notes += [choice.reason] if choice is not None else []
    result.rendered = rendered_settings(reference.metadata)
    result.reference_key = str(reference.metadata.get("key", ""))
    result.reference_integrator = ref_name
    result.renderer = f"pathtracer {name}"
    result.same_estimator = same
    result.arrays = {"test_mean": mean, "test_variance": variance,
                     "reference_mean": reference.mean, "reference_variance": reference.var}
    if same and (np.any(variance) or np.any(reference.var)):    # else both noiseless
        try:
            result.variance = compare_variances(variance, spp, reference.var, reference.n,
                                                alpha=alpha, mean_a=mean, mean_b=reference.mean,
                                                options=VarianceTestOptions(pixel_correlation=correlation))
        except TooFewTiles as few:    # e.g. max_depth 1: noisy at a few edges only
            result.variance_skipped = f"not tested: {str(few).split(';')[0]} (a nearly " \
                                      "noiseless image; the mean test decides)"
    if convergence:
        result.convergence, result.convergence_mse = convergence_test(
            scene, integrator, params, reference, alpha, processes,
            RecordingRuns(render, runs, "convergence"), ladder, replicas, max_growth)
        result.ladder = convergence_ladder(reference, ladder)
    if bounces or (bounces is None and not result.mean.agree):
        result.bounce_results = localise_bounce(scene, integrator, name, params, spp, alpha,
                                                processes, RecordingRuns(render, runs, "bounces"),
                                                log, options, resolution,
                                                bounce_reference(ref_name), splats)
        result.bounce = bounce_verdict(result.bounce_results)
    result.runs = runs
    result.hints = hints(result)
    if out_dir is not None:
        result.pictures = write_pictures(result, Path(out_dir), mean, variance, reference)
    result.seconds = time.perf_counter() - start
    return result


def rendered_settings(metadata: dict) -> str:
    """What both sides rendered, from the reference's metadata: film size and light transport
    (Mitsuba's defaults, which are also ours, where the file and the overrides set nothing)."""
    nested = metadata.get("mitsuba_integrator", {})
    transport = {"max_depth": -1, "rr_depth": 5, "hide_emitters": False}
    transport.update({k: v for k, v in nested.items() if k in transport})
    if nested.get("type") == "direct":
        transport = {k: v for k, v in transport.items() if k == "hide_emitters"}
    text = ", ".join(f"{k}={str(v).lower() if isinstance(v, bool) else v}"
                     for k, v in transport.items())
    return f"{metadata.get('width')}x{metadata.get('height')} on both sides; {text}"


def check_convergence(scene: str, integrator="path", params: dict | None = None, *,
                      alpha: float = 1e-3, ladder=CONVERGENCE_LADDER,
                      replicas=CONVERGENCE_REPLICAS, processes=None, render=render_ours,
                      options=None, resolution=None, log=None):
    """The convergence-law test alone (see :func:`compare`).

    Returns
    -------
    (ConvergenceResult, list of per-level MSE arrays)
    """
    name = integrator if isinstance(integrator, str) else integrator.name
    params = {**default_params(scene), **(params or {})}
    reference = get_reference(scene, params, reference_integrator(name), log=log,
                              options=reference_options(options), resolution=resolution)
    if options:
        render = WithOptions(render, options)
    if resolution is not None:
        render = WithOptions(render, {"resolution": tuple(resolution)})
    return convergence_test(scene, integrator, params, reference, alpha, processes, render,
                            ladder, replicas)


def convergence_seed(level: int, replica: int) -> int:
    """Seed of replica ``replica`` at ladder level ``level`` of the convergence test."""
    return CONVERGENCE_SEED + 100_000 * level + replica


def convergence_requests(reference, ladder, replicas, top=0):
    """``(spp, seed)`` of the renders the convergence test makes when its top level grows from
    ``top`` to ``top + replicas`` replicas (``top`` = 0: its first batch)."""
    ladder = convergence_ladder(reference, ladder)
    done, wanted = level_replicas(ladder, top), level_replicas(ladder, top + replicas)
    return [(n, convergence_seed(j, k)) for j, n in enumerate(ladder)
            for k in range(done[j], wanted[j])]


def level_replicas(ladder, replicas: int) -> list[int]:
    """Independent renders per ladder level: ``replicas`` at the top, and as many below as
    give every level the same number of samples (mitsuba_refs.stats.convergence: with
    rare bright paths, fewer samples at the low levels would flatten the slope)."""
    top = ladder[-1]
    return [replicas * -(-top // n) for n in ladder]


def _spatial_blocks(height: int, width: int) -> list:
    """``BLOCKS x BLOCKS`` contiguous blocks of the image (slices).

    A tent or gaussian film correlates neighbouring pixels, so interleaved sub-lattices are
    not independent; contiguous blocks share only the samples along their borders. Blocks
    see different parts of the image, so they are paired across the ladder's levels (the
    same block at every level) rather than taken as replicas.
    """
    rows = np.array_split(np.arange(height), BLOCKS)
    cols = np.array_split(np.arange(width), BLOCKS)
    return [np.s_[r[0]:r[-1] + 1, c[0]:c[-1] + 1] for r in rows for c in cols]


def convergence_ladder(reference, ladder=CONVERGENCE_LADDER) -> tuple:
    """The spp levels used with this reference: ``ladder``, from FILTERED_MIN_SPP up for a
    tent or gaussian film. A filtered pixel is a ratio (sum w f / sum w) whose error has an
    O(1/N^2) part besides the 1/N law, which steepens the slope at 1 spp (docs/statistics.md).
    """
    if reference_correlation(reference).independent:
        return tuple(ladder)
    return tuple(n for n in ladder if n >= FILTERED_MIN_SPP) or tuple(ladder[-1:])


@dataclass
class ConvergenceParts:
    """What every convergence MSE is measured on, computed once per reference.

    Attributes
    ----------
    ladder : tuple of int
        The levels used (:func:`convergence_ladder`).
    filtered : bool
        A tent or gaussian film: contiguous blocks, paired across levels, instead of
        interleaved sub-lattices taken as replicas.
    lattices, reference_parts, floors : lists
        Per part: its slice, the reference's mean there, the reference's share of its MSE.
    whole : tuple
        The same three for the whole image (the rare-paths rule reads its MSE).
    """

    ladder: tuple
    filtered: bool
    lattices: list
    reference_parts: list
    floors: list
    whole: tuple

    @classmethod
    def of(cls, reference, ladder=CONVERGENCE_LADDER) -> ConvergenceParts:
        """The parts of ``reference`` with the spp levels ``ladder``."""
        filtered = not reference_correlation(reference).independent
        if filtered:
            lattices = _spatial_blocks(*reference.mean.shape[:2])
        else:
            lattices = [np.s_[a::INTERLEAVE, b::INTERLEAVE] for a in range(INTERLEAVE)
                        for b in range(INTERLEAVE)]
        # var / n_eff is each reference pixel's own variance (var / n with a box filter).
        ref_n = pixel_value_counts(reference)
        reference_parts = [np.asarray(reference.mean[part], dtype=np.float64) for part in lattices]
        floors = [reference_mse_floor(reference.var[part], ref_n[part]) for part in lattices]
        whole = ([np.asarray(reference.mean, dtype=np.float64)],
                 [reference_mse_floor(reference.var, ref_n)], [...])
        return cls(convergence_ladder(reference, ladder), filtered, lattices, reference_parts,
                   floors, whole)

    def mse(self, test_mean) -> list:
        """The MSE of ``test_mean`` on every part."""
        return image_mse_parts(test_mean, self.reference_parts, self.floors, self.lattices)

    def image_mse(self, test_mean) -> list:
        """The MSE of ``test_mean`` on the whole image (one value)."""
        return image_mse_parts(test_mean, *self.whole)

    def verdict(self, mse, reference, alpha, rare=False, top=0):
        """The convergence law on per-level MSE lists (one value per render and part);
        ``rare``: rare bright paths still carried the error with ``top`` replicas.

        Returns the :class:`ConvergenceResult` and the MSE arrays (for a filtered film, a
        (blocks, levels) table of each block's mean MSE).
        """
        mse = [np.array(level) for level in mse]
        if self.filtered:   # rows: blocks (each block's mean MSE over its renders), paired
            mse = np.stack([level.reshape(-1, len(self.lattices)).mean(axis=0) for level in mse],
                           axis=1)
        whole_floor = self.whole[1][0]    # the reference's share of the whole image's MSE
        law = convergence_law(np.array(self.ladder), mse, ref_mse_floor=whole_floor,
                              alpha=alpha, image_mean=float(reference.mean.mean()))
        if rare:    # the verdict says it is less reliable (report.wording)
            law = dataclasses.replace(law, rare_replicas=top)
        return law, mse


def convergence_test(scene, integrator, params, reference, alpha, processes, render,
                     ladder=CONVERGENCE_LADDER, replicas=CONVERGENCE_REPLICAS,
                     max_growth=CONVERGENCE_MAX_GROWTH):
    """MSE(N) over the ladder with equal work per level, then the convergence law.

    Starts with ``replicas`` renders at the top level and doubles the renders of every
    level while a few renders carry the lowest level's mean MSE, at most ``max_growth``-fold.
    Returns the :class:`ConvergenceResult` and the MSEs:
    one array per level, with one value per render and sub-lattice; for a tent or gaussian
    film a (blocks, levels) table of each block's mean MSE.
    """
    parts = ConvergenceParts.of(reference, ladder)
    ladder = parts.ladder
    render_mean = getattr(render, "render_mean", None) or mean_of(render)
    mse = [[] for _ in ladder]
    lowest_image_mse = []
    top, batch = 0, replicas
    while True:
        done, wanted = level_replicas(ladder, top), level_replicas(ladder, top + batch)
        for j, n in enumerate(ladder):
            for k in range(done[j], wanted[j]):
                test_mean = render_mean(scene, integrator, params, n, convergence_seed(j, k),
                                        processes=processes)
                mse[j] += parts.mse(test_mean)
                if j == 0:
                    lowest_image_mse += parts.image_mse(test_mean)
        top += batch
        rare = rare_errors_dominate(lowest_image_mse)
        if not rare or top >= replicas * max_growth:
            break
        batch = top
    return parts.verdict(mse, reference, alpha, rare, top)


def localise_bounce(scene, integrator, name, params, spp, alpha, processes, render, log=None,
                    options=None, resolution=None, reference_name=None, splatting=None):
    """Mean agreement with Mitsuba's ``path`` at max_depth = 1, 2, 3: {depth: MeanAgreement}.

    The depth reaches the reference as the ``max_depth`` parameter when the file declares
    one (the committed per-bounce references), else as an integrator override. An
    ``rr_depth`` that cannot act within ``depth`` segments (>= depth, as is the file's own)
    is dropped: both give the estimator without roulette, and the file's is the committed
    reference (the grader's glass checks pass ``rr_depth`` = 8).
    """
    depths = [d for d in BOUNCE_DEPTHS if not (name == "direct" and d > 2)]
    defaults = scene_defaults(scene)
    as_param = "max_depth" in defaults
    file_rr_depth = defaults.get("rr_depth")
    results = {}
    for depth in depths:
        overrides = dict(reference_options(options) or {})
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
                                  options=overrides or None, resolution=resolution)
        mean, variance = render(scene, integrator, params, spp, TEST_SEED + depth,
                                processes=processes, max_depth=depth)
        results[depth] = compare_means(mean, variance, spp, reference.mean, reference.var,
                                       reference.n, alpha=alpha,
                                       image_components=not (name in SPLATTING if splatting is None
                                                             else splatting),
                                       options=MeanTestOptions(pixel_correlation=reference_correlation(reference)))
    return results


def write_pictures(result: Comparison, out_dir: Path, mean, variance, reference) -> dict:
    """Diagnostic PNGs for the failed tests (all tests when everything agrees: none)."""
    # The pictures are drawn with matplotlib (heavy): imported only when there are some to draw.
    from ..report.diagnostics import plot_convergence, plot_mean_comparison, plot_variance_comparison
    out_dir.mkdir(parents=True, exist_ok=True)
    stem = f"{Path(str(result.scene)).stem}-{result.integrator}"
    title = f"{result.integrator} vs Mitsuba on {result.scene}"
    pictures = {"mean": plot_mean_comparison(out_dir / f"{stem}-mean.png", mean, reference.mean,
                                             result.mean, title)}
    if result.variance is not None:
        pictures["variance"] = plot_variance_comparison(out_dir / f"{stem}-variance.png", variance,
                                                        reference.var, result.variance, title)
    if result.convergence is not None:
        pictures["convergence"] = plot_convergence(out_dir / f"{stem}-convergence.png",
                                                   np.array(result.ladder), result.convergence_mse,
                                                   result.convergence, title)
    return {k: str(v) for k, v in pictures.items()}
