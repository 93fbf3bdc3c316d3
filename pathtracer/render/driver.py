"""The render driver: camera samples in bounded batches, mean and variance per pixel.

Work is cut into *units*: a range of pixels times a block of at most
``SAMPLE_BLOCK`` samples of each. A unit's radiance samples form a
(pixels, samples, 3) array; per pixel it yields (n, mean, M2) through sums
shifted by the pixel's first sample of the block (so equal samples give a
variance of exactly zero), and blocks merge in order with Chan's formula.
Random numbers depend only on (seed, pixel, sample index), and a pixel's
samples are reduced in a fixed order, so the image is bit-identical whatever
the batch size and the number of processes.

An integrator whose ``radiance`` refills its paths (marked with
:func:`pathtracer.integrators.wavefront.refills`) receives ``POOL_UNITS`` units at
once and keeps ``batch_size`` paths alive among them
(:meth:`pathtracer.integrators.wavefront.Paths.pool`); the blocks it returns are merged
unit by unit as before, and since a path's numbers and arithmetic do not depend on the
other paths in flight, the image is bit-identical to one unit at a time.

An integrator that *splats* (the light tracer, :mod:`pathtracer.integrators.light`)
has no camera samples: its light paths add to whatever pixel they reach. It is rendered
as ``K`` independent *replicas* (:func:`render_splats`), each with ``spp / K`` light
paths per pixel; the image is their mean and the per-pixel variance comes from their
spread, scaled to one light path per pixel so that ``variance / spp`` is, as for the
other integrators, the variance of the pixel's mean.

A film with a tent or gaussian filter (:mod:`pathtracer.film`) spreads every sample
over the pixels within the filter's radius: a unit then yields filter-weighted sums
over the rows it reaches, added in unit order (the image does not depend on the
number of processes; a different batch size changes only the float64 rounding).
"""

from __future__ import annotations

import copy
import multiprocessing
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from ..core.rng import RandomStream, sample_keys
from ..emitters.dispatch import check_light_paths
from ..integrators import Integrator, make_integrator
from ..integrators.wavefront import pooled
from ..media.homogeneous import has_media
from ..scene.types import Scene
from ..sensors.film import effective_counts, splat
from ..sensors.perspective import camera_rays
from ..shapes import intersect as geometry
from . import workers
from .allocator import keep_freed_memory
from .resources import POOL_UNITS

#: Samples of one pixel reduced together; fixed so results never depend on batching.
SAMPLE_BLOCK = 256
#: Camera paths per batch (bounded memory: about 1 KB per path in flight).
DEFAULT_BATCH = 1 << 15
#: POOL_UNITS (defined with the memory estimate that counts it, in resources): units
#: handed at once to an integrator whose ``radiance`` refills its pool of paths
#: (:func:`pathtracer.integrators.wavefront.refills`); it keeps ``batch_size`` paths
#: alive and pays a batch's roulette tail once per group. The group's camera rays, their
#: random streams and results cost ~200 bytes per camera sample (measured: 274 against
#: 221 MB for a 1024 x 1024, 64 spp render on two processes; docs/performance.md).


@dataclass
class RenderResult:
    """Per-pixel statistics of a render.

    Attributes
    ----------
    mean : (H, W, 3) float64 pixel values (mean of the samples).
    variance : (H, W, 3) float64 unbiased per-sample variance of each pixel.
    spp, seed : int
    integrator : str
    options : dict of the integrator's options.
    seconds : float wall-clock time.
    scene : str the scene's source.
    """

    mean: np.ndarray
    variance: np.ndarray
    spp: int
    seed: int
    integrator: str
    options: dict = field(default_factory=dict)
    seconds: float = 0.0
    scene: str = ""


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
        ``scene.integrator`` (or :func:`pathtracer.scene.scene_settings`'s).
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
    if has_media(scene) and not getattr(chosen, "handles_media", False):
        raise ValueError(f"{scene.source} has participating media or null boundaries, which "
                         f"integrator {chosen.name!r} does not render: use volpath or "
                         "volpath_phase")
    return chosen


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
           processes: int | None = None, batch_size: int = DEFAULT_BATCH,
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
    batch_size : int
        Camera paths per batch. The image does not depend on it.
    progress : bool, optional
        Show a progress bar (default: when stderr is a terminal and the render is long).
    camera : callable, optional
        ``camera(camera, pixel, u_film) -> Rays``, the primary rays (default
        :func:`pathtracer.camera.camera_rays`); the autograder passes a student's camera.
    **options
        Integrator options (max_depth, rr_depth, roulette, hemisphere, ...).
    """
    if not isinstance(scene, Scene):
        from ..scene.load import load_scene
        scene = load_scene(scene)
    integrator = integrator_for(scene, integrator, **options)
    spp = int(scene.spp if spp is None else spp)
    seed = int(scene.seed if seed is None else seed)
    if spp < 1:
        raise ValueError(f"spp must be >= 1, got {spp}")
    n_pixels = scene.camera.width * scene.camera.height
    units = plan_units(n_pixels, spp, batch_size)
    processes = (os.cpu_count() or 1) if processes is None else max(1, int(processes))
    if progress is None:
        progress = sys.stderr.isatty() and n_pixels * spp >= 1 << 20
    geometry.prepare(scene)   # build the BVH once, before workers fork
    keep_freed_memory()       # before the fork too: the workers inherit it
    if getattr(integrator, "splats", False):
        return render_splats(scene, integrator, spp, seed, processes, batch_size, progress)

    start = time.perf_counter()
    groups = [(unit,) for unit in units]
    if pooled(integrator):
        integrator = copy.copy(integrator)      # the caller's integrator stays as it was
        integrator.pool_size = batch_size
        groups = group_units(units, POOL_UNITS, processes)
    job = _Job(scene, integrator, spp, seed, camera or camera_rays)
    if scene.camera.rfilter.is_box:
        stats = run_units(job, groups, pixel_statistics(n_pixels),
                          processes, progress)
        mean, variance = mean_and_variance(stats)
    else:
        sums = run_units(_FilteredJob(job), groups, film_sums(n_pixels), processes, progress,
                         merge=_merge_sums)
        mean, variance = filtered_mean_and_variance(sums, effective_counts(
            scene.camera.rfilter, scene.camera.width, scene.camera.height, spp).reshape(-1, 1))
    shape = (scene.camera.height, scene.camera.width, 3)
    return RenderResult(mean.reshape(shape), variance.reshape(shape), spp, seed, integrator.name,
                        integrator.options(), time.perf_counter() - start, scene.source)


def run_units(job, groups, stats, processes: int, progress: bool, merge=None):
    """Run ``job.run(group)`` for every group of units and merge the blocks it returns (one
    per unit) into ``stats`` (returned).

    ``merge(stats, unit, block)`` defaults to the per-pixel (count, mean, M2) update.

    With ``processes`` > 1 the groups go to forked workers that receive ``job`` at fork
    (inherited, never pickled, no global in this process: renders running concurrently
    in threads cannot swap jobs). Blocks are merged in unit order, so the result does not
    depend on the number of processes or on the grouping. The workers die with this
    process and are killed at once when the render is interrupted
    (:mod:`pathtracer.workers`).
    """
    bar = _progress_bar(sum(map(len, groups)), progress)
    try:
        _run_units(job, groups, stats, processes, bar, merge or _merge)
    finally:
        bar.close()
    return stats


def _run_units(job, groups, stats, processes: int, bar, merge) -> None:
    if processes == 1 or len(groups) == 1:
        for group in groups:
            for unit, block in zip(group, job.run(group)):
                merge(stats, unit, block)
            bar.update(len(group))
    else:
        ctx = multiprocessing.get_context("fork")
        with ProcessPoolExecutor(processes, mp_context=ctx, initializer=_install_job,
                                 initargs=(job, os.getpid())) as pool:
            try:
                with workers.signals_blocked():   # the workers are forked by the first submit
                    results = pool.map(_run_current, groups, chunksize=1)
                for group, blocks in zip(groups, results):
                    for unit, block in zip(group, blocks):
                        merge(stats, unit, block)
                    bar.update(len(group))
            except BaseException:
                # Ctrl-C, SIGTERM or an error: do not wait for the units in flight.
                workers.stop_pool(pool)
                raise


def plan_units(n_pixels: int, spp: int, batch_size: int) -> list[tuple[int, int, int, int]]:
    """Units (pixel_begin, pixel_end, sample_begin, sample_end), sample blocks outermost per pixel range."""
    block = min(spp, SAMPLE_BLOCK)
    pixels_per_unit = max(1, batch_size // block)
    units = []
    for p0 in range(0, n_pixels, pixels_per_unit):
        p1 = min(n_pixels, p0 + pixels_per_unit)
        for s0 in range(0, spp, SAMPLE_BLOCK):
            units.append((p0, p1, s0, min(spp, s0 + SAMPLE_BLOCK)))
    return units


def group_units(units: list, per_group: int, processes: int) -> list[tuple]:
    """Consecutive units in groups of ``per_group``, fewer where the processes would
    otherwise wait: every process gets a group while there are units."""
    size = max(1, min(per_group, -(-len(units) // max(1, processes))))
    return [tuple(units[i:i + size]) for i in range(0, len(units), size)]


class _Job:
    """Everything a worker needs to render a group of units (inherited through fork)."""

    current = None     # the job (any object with ``run(group)``), set in each worker by _install_job

    def __init__(self, scene, integrator, spp, seed, camera=camera_rays):
        self.scene, self.integrator, self.spp, self.seed = scene, integrator, spp, seed
        self.camera = camera

    def run(self, group):
        """Per unit of ``group``, the radiance statistics (count, mean, M2) of its pixels."""
        values, _ = self.samples(group)
        return [block_statistics(v.reshape(p1 - p0, s1 - s0, -1))
                for (p0, p1, s0, s1), v in zip(group, _per_unit(values, group))]

    def samples(self, group):
        """Every camera sample of the units of ``group``, in order, in one radiance call:
        (values (n, channels), film positions (n, 2))."""
        pixel = np.concatenate([np.repeat(np.arange(p0, p1), s1 - s0) for p0, p1, s0, s1 in group])
        sample = np.concatenate([np.tile(np.arange(s0, s1), p1 - p0) for p0, p1, s0, s1 in group])
        rng = RandomStream(sample_keys(self.seed, pixel.astype(np.int64) * self.spp + sample))
        u_film = rng.next_2d()
        return self.estimate(self.camera(self.scene.camera, pixel, u_film), rng), u_film

    def estimate(self, rays, rng):
        """(n, channels) values of the camera rays: the integrator's radiance."""
        return self.integrator.radiance(self.scene, rays, rng)


def _per_unit(rows: np.ndarray, group) -> list[np.ndarray]:
    """``rows`` (one per camera sample of ``group``) cut into the units' parts."""
    ends = np.cumsum([(p1 - p0) * (s1 - s0) for p0, p1, s0, s1 in group])
    return np.split(rows, ends[:-1])


class _FilteredJob:
    """Renders a unit exactly as ``job`` does, then splats it through the film's filter."""

    def __init__(self, job):
        self.job = job

    def run(self, group):
        """Per unit of ``group``, (lo, hi, sum w, sum w f, sum w f^2) over the flat pixel
        range ``lo:hi`` it reaches."""
        values, u_film = self.job.samples(group)
        return [self._splat(unit, v, u) for unit, v, u in
                zip(group, _per_unit(values, group), _per_unit(u_film, group))]

    def _splat(self, unit, values, u_film):
        camera, (p0, p1, s0, s1) = self.job.scene.camera, unit
        pixels, samples = p1 - p0, s1 - s0
        reach = camera.rfilter.reach
        lo = max(0, p0 // camera.width - reach) * camera.width
        hi = min(camera.height, (p1 - 1) // camera.width + reach + 1) * camera.width
        return (lo, hi) + splat(camera.rfilter, camera.width, camera.height, np.arange(p0, p1),
                                u_film.reshape(pixels, samples, 2),
                                values.reshape(pixels, samples, -1), lo, hi)


def replica_count(spp: int, replicas: int) -> int:
    """The number of replicas of a splatting render: the largest divisor of ``spp`` <= ``replicas``."""
    return max(k for k in range(1, min(spp, replicas) + 1) if spp % k == 0)


def render_splats(scene, integrator, spp: int, seed: int, processes: int,
                  batch_size: int = DEFAULT_BATCH, progress: bool = False) -> RenderResult:
    """Render an integrator whose paths splat into the film, as independent replicas.

    ``K = replica_count(spp, integrator.replicas)`` replicas each trace ``spp / K``
    light paths per pixel (``W H spp / K`` in all) and divide their splat sums by
    ``spp / K``. The result's ``mean`` is the mean of the replica images; its
    ``variance`` is their unbiased sample variance times ``spp / K`` (the variance of a
    one-path-per-pixel image: ``variance / spp`` is the variance of ``mean``), with
    ``K - 1`` degrees of freedom per pixel (zero when ``K`` = 1). Light path ``i`` of
    replica ``k`` owns the random stream keyed by ``(seed, k W H spp / K + i)``.

    Raises
    ------
    ValueError
        For a film filter other than the box (a splat would need the filter's
        normalisation) and for emitters light paths cannot start on.
    """
    camera = scene.camera
    if not camera.rfilter.is_box:
        raise ValueError(f"the {integrator.name} integrator splats with the box filter only; "
                         f"the film has {camera.rfilter.describe()}")
    check_light_paths(scene)
    n_pixels = camera.width * camera.height
    replicas = replica_count(spp, integrator.replicas)
    per_pixel = spp // replicas
    paths = per_pixel * n_pixels
    units = [(k, b0, min(paths, b0 + batch_size))
             for k in range(replicas) for b0 in range(0, paths, batch_size)]
    start = time.perf_counter()
    stats = _ReplicaStatistics(n_pixels, per_pixel)
    run_units(_SplatJob(scene, integrator, seed, paths), [(u,) for u in units], stats, processes,
              progress, merge=_ReplicaStatistics.merge)
    mean, variance = stats.result()
    shape = (camera.height, camera.width, 3)
    return RenderResult(mean.reshape(shape), variance.reshape(shape), spp, seed,
                        integrator.name, integrator.options(), time.perf_counter() - start,
                        scene.source)


class _SplatJob:
    """Traces a unit ``(replica, first path, end path)`` of light paths (inherited through fork)."""

    def __init__(self, scene, integrator, seed, paths_per_replica):
        self.scene, self.integrator, self.seed = scene, integrator, seed
        self.paths = paths_per_replica

    def run(self, group):
        """Per unit of ``group``, :meth:`splats`."""
        return [self.splats(unit) for unit in group]

    def splats(self, unit):
        """``(pixels, sums)``: the pixels the unit's splats reached and their (m, 3) sums."""
        replica, b0, b1 = unit
        ids = replica * self.paths + np.arange(b0, b1, dtype=np.int64)
        rng = RandomStream(sample_keys(self.seed, ids))
        if getattr(self.integrator, "camera_subpaths", False):
            # Sample i of a replica starts its camera subpath in pixel i mod (W H).
            camera = self.scene.camera
            pixels = np.arange(b0, b1, dtype=np.int64) % (camera.width * camera.height)
            pixel, value = self.integrator.splat(self.scene, rng, pixels)
        else:
            pixel, value = self.integrator.splat(self.scene, rng)
        touched, inverse = np.unique(pixel, return_inverse=True)
        sums = np.stack([np.bincount(inverse, weights=value[:, c], minlength=len(touched))
                         for c in range(value.shape[1])], axis=1)
        return touched, sums


class _ReplicaStatistics:
    """Per-pixel mean and M2 over complete replica images (units arrive in replica order)."""

    def __init__(self, n_pixels: int, per_pixel: int):
        self.per_pixel = per_pixel
        self.image = np.zeros((n_pixels, 3))
        self.replica = 0
        self.count = 0
        self.mean, self.m2 = np.zeros((n_pixels, 3)), np.zeros((n_pixels, 3))

    def merge(self, unit, block) -> None:
        if unit[0] != self.replica:
            self._close_replica()
            self.replica = unit[0]
        pixels, sums = block
        self.image[pixels] += sums

    def _close_replica(self) -> None:
        """Welford's update with the finished replica's image (splat sums / paths per pixel)."""
        value = self.image / self.per_pixel
        self.count += 1
        delta = value - self.mean
        self.mean += delta / self.count
        self.m2 += delta * (value - self.mean)
        self.image[:] = 0.0

    def result(self) -> tuple[np.ndarray, np.ndarray]:
        """(mean, per-path-per-pixel variance) once every unit is merged."""
        self._close_replica()
        variance = self.m2 / max(self.count - 1, 1) * self.per_pixel
        return self.mean, (variance if self.count > 1 else np.zeros_like(variance))


def film_sums(n_pixels: int, channels: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Empty filter-weighted sums: ``sum w`` (n_pixels,), ``sum w f`` and ``sum w f^2``."""
    return np.zeros(n_pixels), np.zeros((n_pixels, channels)), np.zeros((n_pixels, channels))


def _merge_sums(sums, unit, block) -> None:
    lo, hi, *parts = block
    for total, part in zip(sums, parts):
        total[lo:hi] += part


def filtered_mean_and_variance(sums, n_eff) -> tuple[np.ndarray, np.ndarray]:
    """Pixel value ``sum w f / sum w`` and per-sample variance of a filtered film.

    The variance is the weighted spread ``sum w f^2 / sum w - mean^2`` made unbiased with
    the pixel's effective sample count ``n_eff`` (:func:`pathtracer.film.effective_counts`):
    times ``n_eff / (n_eff - 1)``, which is ``n / (n - 1)`` for the box filter. Spreads
    within float64 rounding of zero (every sample equal) are set to exactly zero.
    """
    weight, wf, wf2 = sums
    w = np.maximum(weight, np.finfo(float).tiny)[:, None]
    mean, second = wf / w, wf2 / w
    spread = second - mean * mean
    spread[spread <= 16 * np.finfo(float).eps * np.abs(second)] = 0.0
    n_eff = np.asarray(n_eff, dtype=np.float64)
    return mean, spread * (n_eff / np.maximum(n_eff - 1, 1e-300))


def _install_job(job, parent_pid):
    workers.init_worker(parent_pid)
    _Job.current = job


def _run_current(group):
    return _Job.current.run(group)


def block_statistics(x: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
    """(n, mean, M2) per pixel of samples ``x`` shaped (pixels, n, 3).

    Sums are shifted by each pixel's first sample, so identical samples give
    M2 = 0 exactly and the mean equals the sample exactly.
    """
    n = x.shape[1]
    shift = x[:, :1, :]
    centred = np.ascontiguousarray((x - shift).transpose(0, 2, 1))   # (pixels, 3, n)
    s1 = centred.sum(axis=2)
    s2 = (centred * centred).sum(axis=2)
    mean = shift[:, 0, :] + s1 / n
    m2 = np.maximum(s2 - s1 * s1 / n, 0.0)
    return n, mean, m2


def pixel_statistics(n_pixels: int, channels: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Empty running statistics: count (n_pixels, 1) and mean, M2 as (2, n_pixels, channels)."""
    return np.zeros((n_pixels, 1)), np.zeros((2, n_pixels, channels))


def mean_and_variance(stats) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel mean and sample variance; M2 becomes the variance in place (no third image)."""
    count, (mean, m2) = stats
    m2 /= np.maximum(count - 1, 1)
    return mean, m2


def _merge(stats, unit, block) -> None:
    """Chan et al.'s parallel update of (count, mean, M2) for the unit's pixels."""
    p0, p1 = unit[0], unit[1]
    n_b, mean_b, m2_b = block
    count, (mean, m2) = stats[0][p0:p1], stats[1][:, p0:p1]
    n_a = count
    total = n_a + n_b
    delta = mean_b - mean
    mean += delta * (n_b / total)
    m2 += m2_b + delta * delta * (n_a * n_b / total)
    count += n_b


class _NoBar:
    def update(self, n=1):
        pass

    def close(self):
        pass


def _progress_bar(total: int, enabled: bool):
    if not enabled:
        return _NoBar()
    from tqdm import tqdm
    return tqdm(total=total, unit="batch", desc="rendering", file=sys.stderr)


class _ClassJob(_Job):
    """Renders one unit of all path classes: (n, 3 K) values per camera ray."""

    def estimate(self, rays, rng):
        """(n, 3 K) values: the path-class integrator's radiance in each of its K classes."""
        return self.integrator.radiance_classes(self.scene, rays, rng)


def render_classes(scene, classes, spp: int = 16, seed: int = 0, processes: int | None = 1,
                   batch_size: int | None = None, progress: bool = False, glossy="G", **options):
    """Render one image per Heckbert path class in a single pass.

    Random numbers are keyed exactly as in :func:`render`, so with the same ``seed`` and
    options the classes are a split of the ``path`` image (of its box-filtered image: the
    classes ignore the film's reconstruction filter).

    Parameters
    ----------
    scene : Scene or str
        A loaded scene, or a path / built-in name passed to ``load_scene``.
    classes : str or list of str
        Path-class expressions, light first (``"LS+DE"``; :mod:`pathtracer.pathclasses`).
    spp, seed, processes, batch_size, progress
        As for :func:`render` (``batch_size`` None: smaller batches for many classes).
    glossy : str
        Letter of rough conductors, or an alpha threshold
        (:class:`~pathtracer.integrators.pathclass.PathClassIntegrator`).
    **options
        Options of the MIS path tracer (max_depth, rr_depth, ...).

    Returns
    -------
    dict
        ``classes`` (list of str), ``mean`` and ``variance`` ((n_classes, H, W, 3) each),
        ``spp``, ``seed``, ``seconds``, ``options``.
    """
    from ..integrators.pathclass import PathClassIntegrator

    if not isinstance(scene, Scene):
        from ..scene.load import load_scene
        scene = load_scene(scene)
    integrator = PathClassIntegrator(classes, glossy=glossy, **options)
    K = len(integrator.classes)
    n_pixels = scene.camera.width * scene.camera.height
    units = plan_units(n_pixels, int(spp), batch_size or max(1024, DEFAULT_BATCH // max(1, K // 2)))
    processes = (os.cpu_count() or 1) if processes is None else max(1, int(processes))
    geometry.prepare(scene)
    start = time.perf_counter()
    stats = run_units(_ClassJob(scene, integrator, int(spp), int(seed)), [(u,) for u in units],
                      pixel_statistics(n_pixels, 3 * K), processes, progress)
    mean, variance = mean_and_variance(stats)
    h, w = scene.camera.height, scene.camera.width

    def per_class(a):
        return a.reshape(h, w, K, 3).transpose(2, 0, 1, 3)

    return dict(classes=integrator.expressions, mean=per_class(mean), variance=per_class(variance),
                spp=int(spp), seed=int(seed), seconds=time.perf_counter() - start,
                options=integrator.options())
