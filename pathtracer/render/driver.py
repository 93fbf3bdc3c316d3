"""The render driver: the integrator and options a render uses, and ``render`` itself.

A render cuts its camera samples into units (:mod:`.scheduling`), computes each unit's
samples in a job (:mod:`.jobs`) and merges their per-pixel moments (:mod:`.moments`).
Random numbers depend only on (seed, pixel, sample index), and a pixel's samples are
reduced in a fixed order, so the image is bit-identical whatever the batch size and the
number of processes.

An integrator whose ``radiance`` refills its paths (``refills = True``,
:attr:`pathtracer.integrators.base.Integrator.refills`) receives ``POOL_UNITS`` units at
once and keeps ``batch_size`` paths alive among them
(:meth:`pathtracer.integrators.wavefront.Paths.pool`); the blocks it returns are merged
unit by unit, as for any integrator, and since a path's numbers and arithmetic do not
depend on the other paths in flight, the image is bit-identical to one unit at a time.

An integrator that *splats* (the light tracer, :mod:`pathtracer.integrators.light`)
has no camera samples: it is rendered as independent replicas (:mod:`.splats`).
"""

from __future__ import annotations

import copy
import os
import time

from ..integrators import Integrator, make_integrator
from ..media.homogeneous import has_media
from ..scene.errors import SceneError
from ..scene.load import load_scene
from ..scene.types import Scene
from ..sensors.film import effective_counts
from ..sensors.perspective import camera_rays
from ..shapes import intersect
from .allocator import keep_freed_memory
from .jobs import CameraJob, FilteredJob, sample_grid_size
from .moments import film_sums, filtered_mean_and_variance, mean_and_variance, merge_sums, pixel_statistics
from .resources import POOL_UNITS
from .result import RenderResult
from .scheduling import group_units, plan_units, run_units
from .sizes import render_batch
from .splats import render_splats

#: POOL_UNITS (defined with the memory estimate that counts it, in resources): units
#: handed at once to an integrator whose ``radiance`` refills its pool of paths
#: (:attr:`pathtracer.integrators.base.Integrator.refills`); it keeps ``batch_size`` paths
#: alive and pays a batch's roulette tail once per group. The group's camera rays, their
#: random streams and results cost ~200 bytes per camera sample (measured: 274 against
#: 221 MB for a 1024 x 1024, 64 spp render on two processes; docs/performance.md).

#: Options of the scene file's ``<integrator>`` that describe the light transport to compute
#: (path length, roulette, visible emitters) rather than one estimator: they apply to every
#: integrator that renders the file, as the Mitsuba references apply them to every estimator.
SCENE_OPTIONS = ("max_depth", "rr_depth", "hide_emitters")


def transport_options(spec, **options) -> dict:
    """The light-transport options (:data:`SCENE_OPTIONS`) a render of a file uses.

    The file's ``<integrator>`` values (literal or ``$param``), replaced by those of
    ``options`` that are not None; options neither sets keep the integrators' defaults,
    which are Mitsuba's (max_depth -1, rr_depth 5, hide_emitters false). The reference
    side gives Mitsuba exactly these values.

    Parameters
    ----------
    spec : IntegratorSpec
        ``scene.integrator`` (or :func:`pathtracer.scene.settings.scene_settings`'s).
    **options
        Render options; only :data:`SCENE_OPTIONS` are read.
    """
    out = {k: spec.params[k] for k in SCENE_OPTIONS if k in spec.params}
    out.update({k: v for k, v in options.items() if k in SCENE_OPTIONS and v is not None})
    return out


def integrator_for(scene: Scene, integrator=None, **options) -> Integrator:
    """The integrator to use: an instance, a name, or the scene file's ``<integrator>``.

    The file's ``<integrator>`` parameters all apply when it is the one used; otherwise
    its :data:`SCENE_OPTIONS` do. Options given here override those of the file.
    """
    spec = scene.integrator
    same = integrator is None or (isinstance(integrator, str) and integrator == spec.name)
    params = dict(spec.params) if same else {}
    params.update(transport_options(spec))
    params.update({k: v for k, v in options.items() if v is not None})
    if isinstance(integrator, Integrator):
        chosen = _with_options(integrator, params)
    else:
        chosen = make_integrator(integrator or spec.name, **params)
    if has_media(scene) and not chosen.handles_media:
        _refuse_media(scene, chosen)
    return chosen


def _refuse_media(scene: Scene, chosen: Integrator) -> None:
    """Refuse ``chosen`` on a scene with media or null boundaries it does not render, at the
    element that needs them (``FILE:LINE: <element>: why``).

    A null boundary without media is rendered by an integrator that ``handles_null`` (Mitsuba's
    ``path`` passes rays through it as a Dirac event of weight 1; shadow rays stop there).
    """
    if not scene.media and chosen.handles_null:
        return
    kind = "medium" if scene.media else "null"
    what = ("a participating medium" if kind == "medium" else
            "a null BSDF (an index-matched boundary)")
    use = "volpath or volpath_phase" if kind == "medium" else "path, volpath or volpath_phase"
    file, line, element = scene.volume_elements.get(kind, (scene.source, None, None))
    raise SceneError(f"integrator {chosen.name!r} does not render {what}: use {use}", file, line,
                     element)


def _with_options(integrator: Integrator, options: dict) -> Integrator:
    """A copy of an integrator instance with some options replaced (never silently ignored)."""
    if not options:
        return integrator
    unknown = [k for k in options if not hasattr(integrator, k)]
    if unknown:
        raise ValueError(f"integrator {integrator.name!r} has no option(s) {', '.join(unknown)}")
    clone = copy.copy(integrator)
    for key, value in options.items():
        setattr(clone, key, type(getattr(integrator, key))(value))
    return clone


def render(scene, integrator=None, spp: int | None = None, seed: int | None = None,
           processes: int | None = None, batch_size: int | None = None,
           progress: bool | None = None, camera=None, **options) -> RenderResult:
    """Render a scene and return per-pixel mean and variance.

    Parameters
    ----------
    scene : Scene or str
        A loaded scene, or a path / built-in name passed to ``load_scene``.
    integrator : str or Integrator, optional
        Defaults to the scene file's integrator. The file's :data:`SCENE_OPTIONS`
        (max_depth, rr_depth, hide_emitters) apply to any integrator, an instance's own
        values included; pass them in ``options`` to override.
    spp, seed : int, optional
        Default to the file's sampler ``sample_count`` and ``seed``.
    processes : int, optional
        Worker processes (default: every core). The image does not depend on it.
    batch_size : int, optional
        Camera paths per batch (default: chosen from the machine's memory,
        :func:`.sizes.render_batch`; a light tracer's is fixed). The image does not depend
        on it.
    progress : bool, optional
        Show the progress on stderr (default: when the render is long): a bar with the time
        left on a terminal, a plain line every few seconds in a pipe.
    camera : callable, optional
        ``camera(camera, pixel, u_film) -> Rays``, the primary rays (default
        :func:`pathtracer.sensors.perspective.camera_rays`); the autograder passes a student's camera.
    **options
        Integrator options (max_depth, rr_depth, roulette, hemisphere, ...).
    """
    if not isinstance(scene, Scene):
        scene = load_scene(scene)
    integrator = integrator_for(scene, integrator, **options)
    spp = int(scene.spp if spp is None else spp)
    seed = int(scene.seed if seed is None else seed)
    if spp < 1:
        raise ValueError(f"spp must be >= 1, got {spp}")
    n_pixels = scene.camera.width * scene.camera.height
    processes = (os.cpu_count() or 1) if processes is None else max(1, int(processes))
    batch_size = batch_size or render_batch(processes, integrator.splats).paths
    units = plan_units(sample_grid_size(scene.camera), spp, batch_size)
    if progress is None:
        progress = n_pixels * spp >= 1 << 20    # lines in a pipe too (pathtracer.core.progress)
    intersect.prepare(scene)   # build the BVH once, before workers fork
    keep_freed_memory()       # before the fork too: the workers inherit it
    if integrator.splats:
        return render_splats(scene, integrator, spp, seed, processes, batch_size, progress)

    start = time.perf_counter()
    groups = [(unit,) for unit in units]
    if integrator.refills:
        integrator = copy.copy(integrator)      # the caller's integrator stays as it was
        integrator.pool_size = batch_size
        groups = group_units(units, POOL_UNITS, processes)
    job = CameraJob(scene, integrator, spp, seed, camera or camera_rays)
    if scene.camera.rfilter.is_box:
        stats = run_units(job, groups, pixel_statistics(n_pixels),
                          processes, progress)
        mean, variance = mean_and_variance(stats)
    else:
        sums = run_units(FilteredJob(job), groups, film_sums(n_pixels), processes, progress,
                         merge=merge_sums)
        mean, variance = filtered_mean_and_variance(sums, effective_counts(
            scene.camera.rfilter, scene.camera.width, scene.camera.height, spp).reshape(-1, 1))
    shape = (scene.camera.height, scene.camera.width, 3)
    return RenderResult(mean.reshape(shape), variance.reshape(shape), spp, seed, integrator.name,
                        integrator.options(), time.perf_counter() - start, scene.source)
