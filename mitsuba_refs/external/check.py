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
applicable, with the ratio.
"""
from __future__ import annotations

import glob
import hashlib
import os
import time
from pathlib import Path

import numpy as np

from pathtracer.render.splats import replica_count

from ..errors import RefsInputError
from ..preflight import check_scene, scene_path
from ..reference import config
from ..reference.cache import get_reference
from ..reference.render import reference_settings
from ..verdicts.compare import (
    CONVERGENCE_SEED,
    TEST_SEED,
    Comparison,
    ConvergenceParts,
    compare,
    convergence_requests,
    default_params,
    reference_options,
    write_pictures,
)
from ..verdicts.explain import hints
from .images import ImageError, image_faults, read_image
from .renders import ExternalRenders, RendererFault, replica_moments
from .runner import Runner
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
#: The harness's default timeout of one renderer run, in seconds.
DEFAULT_TIMEOUT = 600.0


def reference_name(scene_file, file_integrator: str, given=None) -> str:
    """The reference estimator: ``given`` (a Mitsuba type or one of our names), else the file's
    own ``<integrator>`` (``file_integrator``); a one-line error for one without a reference here."""
    if given is None:
        given, where = file_integrator, f"{scene_file}: the file's integrator"
    else:
        where = "--reference-integrator"
    if given not in REFERENCES:
        raise RefsInputError(f"{where} {given!r} has no Mitsuba reference here; give one of "
                             f"{', '.join(sorted(REFERENCES))} with --reference-integrator")
    return REFERENCES[given]


def check(scene, *, command=None, images=None, params=None, spp=config.TEST_MAX_SPP,
          alpha=1e-3, convergence=True, bounces=None, out_dir=None, jobs=None,
          timeout=DEFAULT_TIMEOUT, replicas=None, renderer_scene=None, reference=None,
          same_estimator=False, splatting=None, max_depth=None, resolution=None,
          ladder=config.CONVERGENCE_LADDER, ladder_replicas=config.CONVERGENCE_REPLICAS,
          images_spp=None, output_suffix=".exr", seed_offset=0, log=None,
          detect=None) -> Comparison:
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
    spp : int
        Samples of the mean-and-variance render (command).
    alpha : float
        Level of each verdict.
    convergence, bounces : bool
        Run the convergence verdict; localise the bounce (None: on a disagreement, when the
        template passes ``{max_depth}``).
    jobs, timeout : int, float
        Runs at once (default: the cores) and the seconds each may take.
    replicas : int, optional
        ``K`` for variance from replicas (default 8).
    renderer_scene : path, optional
        The file the renderer reads instead of ``scene`` (``{scene}``).
    reference : str, optional
        Reference estimator (Mitsuba type, e.g. ``ptracer``); default: the file's.
    same_estimator : bool
        The renderer runs the reference's estimator: the variance verdict applies.
    splatting : bool, optional
        Its paths splat into many pixels (default: when the reference is a particle tracer).
    max_depth : int, optional
        Longest path for both sides, replacing the file's.
    resolution : (int, int), optional
        Film size for both sides, replacing the file's.
    images_spp : int, optional
        Sample count of images whose header and sidecar give none.
    seed_offset : int
        0: the renderer gets the comparison's own seeds; another value scrambles every seed
        (one bijection per offset), for independent repetitions of one check.
    detect : mitsuba_refs.verdicts.detect.Detect, optional
        ``command`` only: choose ``spp`` from a pilot run so that the mean test sees
        ``detect.target`` (:func:`mitsuba_refs.verdicts.detect.choose_spp`).

    Returns
    -------
    Comparison
        With ``runs`` (one record per renderer run) and ``notes``.
    """
    if (command is None) == (images is None):
        raise RefsInputError("check needs exactly one of --command and --images")
    if detect is not None and command is None:
        raise RefsInputError("--detect goes with --command (images have their sample count)")
    start = time.perf_counter()
    path = scene_path(scene)
    params = {**default_params(scene), **(params or {})}
    check_scene(scene, params)
    options = {"max_depth": int(max_depth)} if max_depth is not None else None
    _, transport, settings = reference_settings(path, params, options, resolution)
    ref_name = reference_name(path, settings.integrator.name, reference)
    splats = ref_name in SPLATTING_REFERENCES if splatting is None else bool(splatting)
    size = settings.resolution
    estimator = dict(reference_name=ref_name, same_estimator=same_estimator, splatting=splats)
    if command is not None:
        result = _check_command(scene, CommandTemplate.parse(command), params, size, transport,
                                estimator, spp=spp, alpha=alpha, convergence=convergence,
                                bounces=bounces, out_dir=out_dir, jobs=jobs, timeout=timeout,
                                replicas=replicas, renderer_scene=renderer_scene or path,
                                options=options, resolution=resolution, ladder=ladder,
                                ladder_replicas=ladder_replicas, suffix=output_suffix, log=log,
                                seed_offset=seed_offset, detect=detect)
        result.renderer = f"command: {command}"
    else:
        result = _check_images(scene, image_files(images), params, size, estimator, alpha=alpha,
                               convergence=convergence, out_dir=out_dir, options=options,
                               resolution=resolution, images_spp=images_spp, log=log)
        result.renderer = f"images: {images if isinstance(images, str) else ' '.join(map(str, images))}"
    if renderer_scene is not None:
        result.notes.append(f"the renderer read {renderer_scene}; its film size ({size[0]}x{size[1]}) "
                            f"was checked, but not that it describes the same scene as {path}")
    if result.runs:
        cpu = sum(run["cpu_seconds"] for run in result.runs)
        wall = sum(run["seconds"] for run in result.runs)
        longest = max(run["seconds"] for run in result.runs)
        result.notes.append(f"{len(result.runs)} renderer runs, {cpu:.1f} CPU-seconds "
                            f"({wall:.1f} s of runs, the longest {longest:.2f} s)")
    result.seconds = time.perf_counter() - start
    return result


def _check_command(scene, template, params, size, transport, estimator, *, spp, alpha,
                   convergence, bounces, out_dir, jobs, timeout, replicas, renderer_scene,
                   options, resolution, ladder, ladder_replicas, suffix, log, seed_offset,
                   detect=None):
    if bounces and not template.takes_max_depth:
        raise RefsInputError("--bounces always needs {max_depth} in --command: the renderer must "
                             "be told the path length to localise a bounce")
    runner = Runner(jobs or os.cpu_count() or 1, float(timeout))
    depth = int(transport.get("max_depth", -1))
    renders = ExternalRenders(template, runner, renderer_scene, size, params, depth,
                              replicas or 8, suffix, log, seed_offset)
    reference = get_reference(scene, params, estimator["reference_name"], log=log,
                              options=reference_options(options), resolution=resolution)
    if detect is None:      # with --detect the pilot chooses the spp inside compare()
        renders.plan([renders.request(spp, TEST_SEED)])
    if convergence:
        renders.plan([renders.request(n, seed, variance=False)
                      for n, seed in convergence_requests(reference, ladder, ladder_replicas)])
        renders.extend_with(_GrowingLadder(renders, reference, ladder, ladder_replicas))
    if template.takes_max_depth:
        renders.plan([renders.request(spp, TEST_SEED + d, d) for d in config.PER_BOUNCE_DEPTHS])
    try:
        result = compare(scene, _label(template), params, spp=spp, alpha=alpha,
                         convergence=convergence,
                         bounces=bounces if template.takes_max_depth else False,
                         out_dir=out_dir, render=renders, ladder=ladder, replicas=ladder_replicas,
                         options=options, resolution=resolution, log=log, detect=detect,
                         **estimator)
    except RendererFault as fault:
        result = faulty(scene, _label(template), params, spp, fault.lines, alpha)
    finally:
        renders.close()
    result.runs = [run.record() for run in renders.runs]
    if renders.has_variance is False:
        count = replica_count(result.spp, replicas or 8)
        result.notes.append(f"its images carry no variance: mean and variance from {count} "
                            "independent replicas with seeds of their own")
    return result


class _GrowingLadder:
    """The convergence test's next, doubled batch, for a ladder render nobody planned."""

    def __init__(self, renders, reference, ladder, replicas):
        self.renders, self.reference, self.ladder = renders, reference, ladder
        self.top = replicas

    def __call__(self, request):
        if request.variance or request.seed < CONVERGENCE_SEED:
            return None
        batch = convergence_requests(self.reference, self.ladder, self.top, self.top)
        self.top *= 2
        return [self.renders.request(n, seed, request.max_depth, False) for n, seed in batch]


def _label(template: CommandTemplate) -> str:
    """The renderer's name in the verdict lines: its program's file name."""
    first = template.text.split()[0] if template.text.split() else "renderer"
    return os.path.basename(first) or "renderer"


class FaultyImages:
    """The mean verdict of a renderer whose images hold NaN, Inf or negative radiance."""

    agree = False
    p_value = 0.0

    def __init__(self, lines, alpha):
        self.faults, self.alpha = list(lines), alpha    # the line: report.wording.mean_verdict


def faulty(scene, label, params, spp, lines, alpha) -> Comparison:
    """A disagreement saying what was wrong with the renderer's values."""
    result = Comparison(scene, label, params, spp, FaultyImages(lines, alpha))
    result.hints = ["the renderer wrote " + lines[0].split(": ", 1)[-1]]
    return result


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


def read_images(files, size, images_spp=None):
    """Read and check every file: same film size as the scene, a known sample count, no two
    identical. Returns the images and their faults (lines)."""
    images, faults, seen = [], [], {}
    for file in files:
        try:
            image = read_image(file, spp=images_spp)
        except ImageError as error:
            raise RefsInputError(str(error)) from None
        if image.size != tuple(size):
            raise RefsInputError(f"{file}: the image is {image.size[0]}x{image.size[1]}, the scene's "
                                 f"film is {size[0]}x{size[1]}")
        if image.spp is None:
            raise RefsInputError(f"{file}: no sample count: write a header attribute spp, a sidecar "
                                 f"{file}.json with {{\"spp\": N}}, or pass --spp")
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
    mean, variance = replica_moments([image.mean for image in level])
    return mean, variance * top, top * len(level)


def _check_images(scene, files, params, size, estimator, *, alpha, convergence, out_dir,
                  options, resolution, images_spp, log):
    images, faults = read_images(files, size, images_spp)
    if faults:
        return faulty(scene, "images", params, max(i.spp for i in images), faults, alpha)
    mean, variance, samples = mean_and_variance(images)
    result = compare(scene, "images", params, spp=samples, alpha=alpha, convergence=False,
                     bounces=False, render=lambda *args, **kwargs: (mean, variance),
                     options=options, resolution=resolution, log=log, **estimator)
    result.runs = []                      # nothing was rendered here
    # compare() found or built the reference: this is the cached file, read once more.
    reference = get_reference(scene, params, estimator["reference_name"], log=log,
                              options=reference_options(options), resolution=resolution)
    levels = sorted({image.spp for image in images})
    if convergence and len(levels) >= MIN_IMAGE_LEVELS:
        parts = ConvergenceParts.of(reference, levels)
        mse = [sum((parts.mse(i.mean) for i in images if i.spp == n), []) for n in parts.ladder]
        result.convergence, result.convergence_mse = parts.verdict(mse, reference, alpha)
        result.ladder = parts.ladder
    elif convergence:
        result.notes.append(f"convergence not judged: the images have {len(levels)} sample "
                            f"count(s), it needs >= {MIN_IMAGE_LEVELS}")
    result.notes.append(f"{len(images)} images; mean and variance from {samples} samples per pixel")
    result.hints = hints(result)
    if out_dir is not None:
        result.pictures = write_pictures(result, Path(out_dir), mean, variance, reference)
    return result
