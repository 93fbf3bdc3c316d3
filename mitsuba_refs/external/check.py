"""``check``: a renderer that is not ours, judged against Mitsuba with the verdicts of ``compare``.

Two ways in, one pipeline out (:func:`mitsuba_refs.verdicts.compare.compare` and its statistics):

* ``command``: the harness runs the user's renderer (:mod:`.runner`, :mod:`.renders`) as
  often as the verdicts need it: one mean-and-variance render at ``spp`` (or ``K`` replicas
  when its images carry no variance), the convergence ladder with equal work per level, and,
  when the template passes ``{max_depth}``, the per-bounce renders on a disagreement.
* ``images``: images the user already has (docs/external.md, "The image contract"). The
  images at the highest sample count give the mean (and variance) verdicts, those at three
  or more sample counts the convergence verdict.

The reference is Mitsuba's rendering of the same scene file with the file's own
``<integrator>`` (or ``reference``). The variance verdict needs the user's word that the
renderer runs the reference's estimator (``same_estimator``); otherwise it is reported as not
applicable, with the ratio and that reason. It is not applicable either when the convergence
verdict finds the error falling faster than N^-1/2: the renderer's samples are then not
independent within a pixel (stratified, low-discrepancy), and no per-sample variance describes
its noise (``Settings.judge_independence``, docs/external.md "Samplers").
"""
from __future__ import annotations

import dataclasses
import glob
import hashlib
import os
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np

from pathtracer.core.names import suggestion
from pathtracer.render.splats import replica_count

from ..errors import RefsInputError
from ..preflight import check_scene, scene_path
from ..reference import config
from ..reference.cache import get_reference
from ..reference.render import reference_settings
from ..report.wording import MEAN_WITH_STRATIFIED_VARIANCE, VARIANCE_NOT_STATED, variance_not_independent
from ..settings import PILOT_SPP, Settings, settings_of
from ..stats.mean import MeanAgreement
from ..stats.sequential import look_totals
from ..verdicts.compare import TEST_SEED, Comparison, FaultyImages, compare, concluded
from ..verdicts.conventions import with_convention
from ..verdicts.convergence import (
    CONVERGENCE_SEED,
    ConvergenceParts,
    LadderPlan,
    convergence_requests,
    level_replicas,
)
from ..verdicts.scenes import default_params, reference_options, scene_defaults
from .images import ImageError, image_faults, read_image
from .naming import checked_name, short_name
from .renders import ExternalRenders, RendererFault, check_independent, replica_moments
from .runner import Runner
from .seeding import SeedRule, SeedSpaceError, seed_rule
from .template import CommandTemplate

#: Mitsuba's integrator type (or our name for its estimator) -> the reference's name here.
REFERENCES = {"path": "path", "volpath": "volpath", "direct": "direct", "ptracer": "light",
              "light": "light", "path_bsdf": "path_bsdf", "path_nee": "path_nee",
              "lecture_path_bsdf": "path_bsdf", "lecture_path_nee": "path_nee"}
#: Reference estimators whose paths splat into many pixels (correlated pixels).
SPLATTING_REFERENCES = ("light",)
#: Fewest replicas (images without variance channels at one sample count) for mean and variance.
MIN_IMAGE_REPLICAS = 8
#: Fewest sample counts for a convergence verdict from images.
MIN_IMAGE_LEVELS = 3
#: The harness's default timeout of one renderer run, in seconds (``Settings.timeout``).
DEFAULT_TIMEOUT = config.DEFAULT_TIMEOUT
#: The largest spp a run is assumed to take with ``--detect``, whose spp the pilot chooses.
DETECT_MAX_SPP = 1 << 16
#: check's older keyword names -> the Settings fields they set (``max_depth`` sets ``options``;
#: ``replicas`` was the variance replicas and is refused: say ``variance_replicas``).
CHECK_ALIASES = {"ladder_replicas": "replicas"}


def reference_name(scene_file, file_integrator: str, given=None) -> str:
    """The reference estimator: ``given`` (a Mitsuba type or one of our names), else the file's
    own ``<integrator>`` (``file_integrator``); a one-line error for one without a reference here."""
    if given is None:
        given, where = file_integrator, f"{scene_file}: the file's integrator"
    else:
        where = "--reference-integrator"
    if given not in REFERENCES:
        raise RefsInputError(f"{where} {given!r} has no Mitsuba reference here; "
                             f"{suggestion(given, REFERENCES)}give one of "
                             f"{', '.join(sorted(REFERENCES))} with --reference-integrator")
    return REFERENCES[given]


def check_settings(settings: Settings | None, keywords: dict) -> Settings:
    """``settings`` with check's keywords: the fields of :class:`~mitsuba_refs.settings.Settings`,
    ``ladder_replicas`` (the older name of ``replicas``) and ``max_depth`` (sets ``options``)."""
    keywords = dict(keywords)
    if "replicas" in keywords:
        raise TypeError("check() no longer takes replicas= (the replicas for variance): say "
                        "variance_replicas=; the convergence ladder's are Settings.replicas")
    if "max_depth" in keywords:
        depth = keywords.pop("max_depth")
        keywords["options"] = {"max_depth": int(depth)} if depth is not None else None
    return settings_of(settings, keywords, "check", CHECK_ALIASES)


class CommandSetup(NamedTuple):
    """What ``check --command`` knows of the renderer's runs before the first one."""

    size: tuple[int, int]
    transport: dict
    renderer_scene: Path
    suffix: str
    name: str


def check(scene, *, command=None, images=None, params=None, settings: Settings | None = None,
          renderer_scene=None, output_suffix=".exr", images_spp=None, log=None,
          **keywords) -> Comparison:
    """Judge an external renderer (``command``) or its images (``images``) against Mitsuba.

    Parameters
    ----------
    scene : str or Path
        Built-in scene name or XML file: what Mitsuba renders.
    command : str, optional
        The renderer's command template (:mod:`mitsuba_refs.external.template`).
    images : str or list, optional
        Image files, or glob patterns of them, rendered elsewhere.
    params : dict, optional
        Scene parameters (``-D``), for Mitsuba and ``{defines}``.
    settings : mitsuba_refs.settings.Settings, optional
        What is rendered and how it is judged (default ``Settings()``). For check: ``spp`` is
        the command's mean-and-variance render; ``bounces`` None localises on a disagreement
        when the template passes ``{max_depth}``; ``reference`` a Mitsuba type (e.g.
        ``ptracer``), default the file's; ``same_estimator`` the user's word that the renderer
        runs it (None: False); ``splatting`` default: when the reference is a particle tracer;
        ``options`` only ``{"max_depth": d}``; ``jobs``, ``timeout``, ``variance_replicas`` and
        ``seed_offset`` the renderer's runs; ``detect`` with ``command`` only; ``name`` the
        renderer's name in the report.
    renderer_scene : path, optional
        The file the renderer reads instead of ``scene`` (``{scene}``).
    output_suffix : str
        The suffix of the renderer's ``{out}`` files.
    images_spp : int, optional
        Sample count of images whose header and sidecar give none.
    log : callable, optional
        Called with progress lines.
    **keywords
        Fields of ``Settings`` replacing those of ``settings``, as ``mitsuba-refs check``'s
        options read: ``check(scene, command=..., same_estimator=True, jobs=4)``. Older names:
        ``ladder_replicas`` (``replicas``), ``max_depth`` (``options={"max_depth": d}``).

    Returns
    -------
    Comparison
        With ``runs`` (one record per renderer run) and ``notes``.
    """
    settings = check_settings(settings, keywords)
    if (command is None) == (images is None):
        raise RefsInputError("check needs exactly one of --command and --images")
    if settings.detect is not None and command is None:
        raise RefsInputError("--detect goes with --command (images have their sample count)")
    start = time.perf_counter()
    path = scene_path(scene)
    given = set(params or {})       # the names -D set, for film_origin
    params = {**default_params(scene), **(params or {})}
    check_scene(scene, params)
    _, transport, file_settings = reference_settings(path, params, settings.options,
                                                     settings.resolution)
    ref_name = reference_name(path, file_settings.integrator.name, settings.reference)
    splats = (ref_name in SPLATTING_REFERENCES if settings.splatting is None
              else bool(settings.splatting))
    # A renderer not ours may stratify its samples: judged from its convergence (Settings).
    settings = dataclasses.replace(settings, reference=ref_name, splatting=splats,
                                   same_estimator=bool(settings.same_estimator),
                                   judge_independence=True)
    size = file_settings.resolution
    if settings.name is not None:
        label = checked_name(settings.name)
    else:
        label = short_name(command) if command is not None else "images"
    if command is not None:
        setup = CommandSetup(size, transport, renderer_scene or path, output_suffix, label)
        result = _check_command(scene, CommandTemplate.parse(command), params, settings, setup, log)
        source = command
    else:
        origin = film_origin(path, params, settings.resolution, given)
        result = _check_images(scene, image_files(images), params, settings, (size, images_spp, origin),
                               log, label)
        source = f"images: {images if isinstance(images, str) else ' '.join(map(str, images))}"
    notes = list(result.notes)
    if renderer_scene is not None:
        notes.append(f"the renderer read {renderer_scene}; its film size ({size[0]}x{size[1]}) "
                     f"was checked, but not that it describes the same scene as {path}")
    if result.runs:
        cpu = sum(run["cpu_seconds"] for run in result.runs)
        wall = sum(run["seconds"] for run in result.runs)
        longest = max(run["seconds"] for run in result.runs)
        notes.append(f"{len(result.runs)} renderer runs, {cpu:.1f} CPU-seconds "
                     f"({wall:.1f} s of runs, the longest {longest:.2f} s)")
    return dataclasses.replace(result, renderer=label, command=source, notes=notes,
                               seconds=time.perf_counter() - start)


def _check_command(scene, template, params, settings: Settings, setup: CommandSetup, log):
    if settings.bounces and not template.takes_max_depth:
        raise RefsInputError("--bounces always needs {max_depth} in --command: the renderer must "
                             "be told the path length to localise a bounce")
    runner = Runner(settings.jobs or os.cpu_count() or 1, float(settings.timeout))
    depth = int(setup.transport.get("max_depth", -1))
    renders = ExternalRenders(template, runner, setup.renderer_scene, setup.size,
                              film_defines(scene, params, settings.resolution),
                              depth, settings.variance_replicas or 8, setup.suffix, log,
                              run_seeds(settings, setup.size, template.takes_max_depth))
    reference = get_reference(scene, params, settings.reference, log=log,
                              options=reference_options(settings.options),
                              resolution=settings.resolution)
    if settings.detect is None and settings.tolerance is None:
        # with --detect the pilot chooses the spp inside compare(); with --tolerance the rounds
        # ask for theirs one by one (verdicts.rounds)
        renders.plan([renders.request(settings.spp, TEST_SEED)])
    if settings.convergence:
        # With a tolerance the ladder's first look needs only part of its renders.
        first = LadderPlan.of(settings).first_look
        renders.plan([renders.request(n, seed, variance=False) for n, seed
                      in convergence_requests(reference, settings.ladder, first)])
        renders.extend_with(_GrowingLadder(renders, reference, settings.ladder, first,
                                           settings.replicas))
    if template.takes_max_depth:
        renders.plan([renders.request(settings.spp, TEST_SEED + d, d)
                      for d in config.PER_BOUNCE_DEPTHS])
    try:
        result = compare(scene, setup.name, params, dataclasses.replace(
            settings, bounces=settings.bounces if template.takes_max_depth else False),
            render=renders, log=log)
    except RendererFault as fault:
        result = faulty(scene, setup.name, params, settings.spp, fault.lines, settings.alpha)
    finally:
        renders.close()
    count = 1 if renders.has_variance else replica_count(result.spp, settings.variance_replicas or 8)
    result = with_convention(result, _fixed_moments(result.arrays), reference, settings, log,
                             render_spp=max(result.spp // count, 1))
    notes = list(result.notes)
    if renders.has_variance is False:
        notes.append(f"its images carry no variance: mean and variance from {count} "
                     "independent replicas with seeds of their own")
    result = dataclasses.replace(result, runs=[run.record() for run in renders.runs], notes=notes)
    return variance_reasons(result, settings, bool(renders.has_variance))


def variance_reasons(result: Comparison, settings: Settings, own_variance: bool) -> Comparison:
    """``result`` whose missing variance verdict says its real reason, with a note when the mean
    test took the renderer's own per-sample variance (``own_variance``) although its samples
    are not independent within a pixel (docs/external.md, "Samplers")."""
    law, notes = result.convergence, list(result.notes)
    skipped = result.variance_skipped
    if not settings.same_estimator and not skipped:
        skipped = VARIANCE_NOT_STATED
    if own_variance and law is not None and law.faster and isinstance(result.mean, MeanAgreement):
        notes.append(MEAN_WITH_STRATIFIED_VARIANCE)
    return dataclasses.replace(result, variance_skipped=skipped, notes=notes)


def film_defines(scene, params: dict, resolution) -> dict:
    """``{defines}``: the scene parameters, with ``width`` and ``height`` set to ``resolution``
    (``--resolution``) where the scene takes them as parameters (the built-in scenes do), so
    that a renderer given ``{defines}`` renders the film the reference has."""
    if resolution is None:
        return dict(params)
    try:
        declared = scene_defaults(scene)
    except (OSError, ValueError):
        declared = {}
    defines = dict(params)
    for name, value in zip(("width", "height"), resolution):
        if name in params or name in declared:
            defines[name] = int(value)
    return defines


def run_seeds(settings: Settings, size, per_bounce: bool) -> SeedRule:
    """The seed rule of a check's runs (:mod:`mitsuba_refs.external.seeding`): the film, the
    largest spp of a run, at most how many runs the check makes (mean and variance, the
    ``--detect`` pilot, per-bounce renders, the convergence ladder grown to ``max_growth``),
    and ``seed_offset``."""
    replicas = settings.variance_replicas or 8
    rounds = 1 if settings.tolerance is None else len(look_totals(settings.max_spp or settings.spp))
    variance_renders = rounds + (settings.detect is not None) + (len(config.PER_BOUNCE_DEPTHS)
                                                                  if per_bounce else 0)
    runs = replicas * variance_renders
    largest = max(int(settings.spp), int(settings.max_spp or 0),
                  PILOT_SPP if settings.detect is not None else 1)
    if settings.detect is not None:
        largest = max(largest, DETECT_MAX_SPP)
    if settings.convergence:
        # The replicas double until they reach max_growth-fold: at most the next power of 2.
        growth = 1 << (max(1, int(settings.max_growth)) - 1).bit_length()
        runs += sum(level_replicas(tuple(settings.ladder), settings.replicas * growth))
        largest = max(largest, max(settings.ladder))
    try:
        rule = seed_rule(*size, largest, runs, fit=True)
    except SeedSpaceError as error:
        raise RefsInputError(f"check: {error}") from None
    return dataclasses.replace(rule, offset=int(settings.seed_offset))


class _GrowingLadder:
    """The convergence test's next batch, for a ladder render nobody planned: the rest of the
    first look's replicas (``top`` of ``replicas`` were planned), then the doubling while rare
    bright paths carry the error (verdicts.convergence.convergence_test)."""

    def __init__(self, renders, reference, ladder, top, replicas):
        self.renders, self.reference, self.ladder = renders, reference, ladder
        self.top, self.replicas = top, replicas

    def __call__(self, request):
        if request.variance or request.seed < CONVERGENCE_SEED:
            return None
        target = self.replicas if self.top < self.replicas else 2 * self.top
        batch = convergence_requests(self.reference, self.ladder, target - self.top, self.top)
        self.top = target
        return [self.renders.request(n, seed, request.max_depth, False) for n, seed in batch]


def faulty(scene, label, params, spp, lines, alpha) -> Comparison:
    """A disagreement saying what was wrong with the renderer's values."""
    return Comparison(scene, label, params, spp, FaultyImages(lines, alpha),
                      hints=["the renderer wrote " + lines[0].split(": ", 1)[-1]])


# ---- images rendered elsewhere ---------------------------------------------------------
def image_files(images) -> list[Path]:
    """The files of ``images`` (paths or glob patterns), sorted; a pattern matching nothing,
    or no file at all, is a one-line error."""
    patterns = [images] if isinstance(images, (str, Path)) else list(images)
    files = []
    for pattern in patterns:
        matches = sorted(glob.glob(str(pattern))) if glob.has_magic(str(pattern)) else [str(pattern)]
        if not matches:
            raise RefsInputError(f"--images {pattern}: no file matches")
        files += [Path(m) for m in matches]
    if not files:
        raise RefsInputError("--images: no image given")
    return files


def film_origin(path, params, resolution, given) -> str:
    """Where a check's film size came from and which option changes it, for the messages
    that quote the size; ``given`` are the names of ``params`` the user set (``-D``)."""
    if resolution is not None:
        return "from --resolution"
    if {"width", "height"} & set(given):
        return "from -D width/height; --resolution WxH replaces it"
    if {"width", "height"} <= set(params):
        return ("the built-in scene's test size, which its committed references have; "
                "--resolution WxH or -D width=W -D height=H renders another")
    return f"the film of {path}; --resolution WxH replaces it"


def read_images(files, size, images_spp=None, origin=None):
    """Read and check every file: same film size as the scene (``origin`` says where that size
    came from), a known sample count, no two identical. Returns the images and their faults
    (lines)."""
    images, faults, seen = [], [], {}
    for file in files:
        try:
            image = read_image(file, spp=images_spp)
        except ImageError as error:
            raise RefsInputError(str(error)) from None
        if image.size != tuple(size):
            where = f" ({origin})" if origin else ""
            raise RefsInputError(f"{file}: the image is {image.size[0]}x{image.size[1]}, the scene's "
                                 f"film is {size[0]}x{size[1]}{where}; to check images of this size "
                                 f"give --resolution {image.size[0]}x{image.size[1]}")
        if image.spp is None:
            raise RefsInputError(f"{file}: no sample count: write a header attribute spp, a sidecar "
                                 f"{file}.json with {{\"spp\": N}}, or pass --spp N (the samples "
                                 "per pixel of every image that gives none)")
        digest = hashlib.sha256(np.ascontiguousarray(image.mean).tobytes()).hexdigest()
        if digest in seen:
            raise RefsInputError(f"{file} and {seen[digest]} are identical: replicas need seeds of "
                                 "their own (identical images are refused, not averaged)")
        seen[digest] = file
        faults += [f"{file}: {fault}" for fault in image_faults(image)]
        images.append(image)
    return images, faults


def mean_and_variance(images):
    """``(mean, per-sample variance, samples)`` from the images at the highest sample count:
    images with variance channels pooled, else at least MIN_IMAGE_REPLICAS replicas."""
    top = max(image.spp for image in images)
    level = [image for image in images if image.spp == top]
    with_variance = [image for image in level if image.variance is not None]
    if with_variance:
        mean = np.mean([image.mean for image in with_variance], axis=0)
        variance = np.mean([image.variance for image in with_variance], axis=0)
        return mean, variance, top * len(with_variance)
    if len(level) < MIN_IMAGE_REPLICAS:
        raise RefsInputError(
            f"{len(level)} image(s) at {top} spp without var.R var.G var.B channels: the mean and "
            f"variance verdicts need the variance channels or >= {MIN_IMAGE_REPLICAS} independent "
            f"replicas at one sample count (docs/external.md)")
    mean, variance = replica_moments([image.mean for image in level], check=False)
    return mean, variance * top, top * len(level)


def film_seeds(scene, count: int, spp: int, params=None, resolution=None) -> SeedRule:
    """The seed rule for ``count`` images of up to ``spp`` samples of ``scene``'s film (or
    ``resolution``): what ``check --seeds-for`` prints, before anything is rendered."""
    path = scene_path(scene)
    params = {**default_params(scene), **(params or {})}
    check_scene(scene, params)
    size = reference_settings(path, params, None, resolution)[2].resolution
    try:
        return seed_rule(*size, spp, count, fit=True)
    except SeedSpaceError as error:
        raise RefsInputError(f"--seeds-for: {error}") from None


def image_seeds(size, images) -> SeedRule:
    """The seed rule of images rendered elsewhere: the film, their largest spp and count."""
    return seed_rule(*size, max(image.spp for image in images), len(images), fit=True)


def seeds_advice(rule: SeedRule) -> str:
    """What seeds to render images with, by ``rule``: multiples of its stride."""
    first = ", ".join(str(seed) for seed in rule.seeds(3))
    return (f"render each image with its own multiple of {rule.stride} as seed ({first}, ...): "
            f"seeds that far apart share no random stream in a {rule.width}x{rule.height} film "
            f"up to {rule.max_spp} spp, whether the renderer adds {{seed}} to a pixel or "
            "sample index (Mitsuba 3's command line), multiplies it by the pixel count "
            "(Mitsuba 3's render(seed=)) or hashes it")


def check_images_independent(files, images, size) -> None:
    """Refuse images of one sample count of which two share their noise at the same pixel or
    at a pixel offset (:func:`mitsuba_refs.external.renders.check_independent`), saying which
    seeds to use instead."""
    try:
        advice = seeds_advice(image_seeds(size, images))
    except SeedSpaceError:     # a film too large for seeds apart under every scheme
        advice = "render each image with random streams hashed from its seed and the pixel"
    for spp in sorted({image.spp for image in images}):
        level = [(file, image) for file, image in zip(files, images) if image.spp == spp]
        if len(level) >= 3:
            names = [str(file) + (f" (seed {image.seed})" if image.seed is not None else "")
                     for file, image in level]
            check_independent(np.stack([image.mean for _, image in level]), names=names,
                              advice=advice)


def _check_images(scene, files, params, settings: Settings, film, log, label="images"):
    """The verdicts of images rendered elsewhere; ``film`` = (the scene's film size, the sample
    count of images that give none, where that size came from)."""
    images, faults = read_images(files, *film)
    if faults:
        return faulty(scene, label, params, max(i.spp for i in images), faults, settings.alpha)
    check_images_independent(files, images, film[0])
    mean, variance, samples = mean_and_variance(images)
    start = time.perf_counter()
    result = compare(scene, label, params, dataclasses.replace(
        settings, spp=samples, convergence=False, bounces=False, out_dir=None),
        render=lambda *args, **kwargs: (mean, variance), log=log)
    # compare() found or built the reference: this is the cached file, read once more.
    reference = get_reference(scene, params, settings.reference, log=log,
                              options=reference_options(settings.options),
                              resolution=settings.resolution)
    levels = sorted({image.spp for image in images})
    notes, law, mse, ladder = list(result.notes), None, None, result.ladder
    not_run = {"bounces": "not run: images rendered elsewhere cannot be rendered again at "
                          "max_depth 1, 2, 3 (check --command with {max_depth} can)"}
    if not settings.convergence:
        not_run["convergence"] = "not run (--no-convergence)"
    elif len(levels) < MIN_IMAGE_LEVELS:
        not_run["convergence"] = (f"not run: the images have {len(levels)} sample count(s), it "
                                  f"needs >= {MIN_IMAGE_LEVELS} (docs/external.md)")
    if settings.convergence and len(levels) >= MIN_IMAGE_LEVELS:
        parts = ConvergenceParts.of(reference, levels)
        mse = [sum((parts.mse(i.mean) for i in images if i.spp == n), []) for n in parts.ladder]
        law, mse = parts.verdict(mse, reference, settings.alpha)
        ladder = parts.ladder
    elif settings.convergence:
        notes.append(f"convergence not judged: the images have {len(levels)} sample "
                     f"count(s), it needs >= {MIN_IMAGE_LEVELS}")
    notes.append(f"{len(images)} images; mean and variance from {samples} samples per pixel")
    variance_test, skipped = result.variance, result.variance_skipped
    if variance_test is not None and law is not None and law.faster:
        # Judged here, as compare() judges a ladder it rendered (verdicts/compare.py).
        variance_test, skipped = None, variance_not_independent(law)
    result = dataclasses.replace(result, runs=[], convergence=law, convergence_mse=mse,
                                 ladder=ladder, notes=notes, variance=variance_test,
                                 variance_skipped=skipped, not_run=not_run)    # nothing was rendered here
    own = any(image.variance is not None for image in images
              if image.spp == max(i.spp for i in images))
    result = variance_reasons(result, settings, own)
    result = concluded(result, settings.out_dir, (mean, variance, reference), start)
    return with_convention(result, _image_moments(images, (mean, variance)), reference, settings,
                           log, render_spp=max(image.spp for image in images))


def _fixed_moments(arrays):
    """``moments_of`` (:func:`~mitsuba_refs.verdicts.conventions.find_convention`) of one test
    image: a correction applies to its mean and per-sample variance."""
    def moments_of(transform):
        mean, variance = arrays["test_mean"], arrays["test_variance"]
        return (mean, variance) if transform is None else transform(mean, variance)
    return moments_of


def _image_moments(images, moments):
    """``moments_of`` of images rendered elsewhere, whose uncorrected ``(mean, variance)`` are
    ``moments``: a correction applies to each image before their moments are taken (a decoded
    mean of replicas is not the mean of decoded replicas). Corrected replicas are not checked
    for independence again: the images were, and a nonlinear decoding can make a few pixels
    carry their standardised correlation (:func:`mean_and_variance` does not check)."""
    def moments_of(transform):
        if transform is None:
            return moments
        fixed = [dataclasses.replace(image, **dict(zip(("mean", "variance"), transform(
            image.mean, image.variance)))) for image in images]
        return mean_and_variance(fixed)[:2]
    return moments_of
