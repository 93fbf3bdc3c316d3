"""Splatting integrators, rendered as independent replicas.

An integrator that *splats* (the light tracer, :mod:`pathtracer.integrators.light`)
has no camera samples: its light paths add to whatever pixel they reach. It is rendered
as ``K`` independent *replicas* (:func:`render_splats`), each with ``spp / K`` light
paths per pixel; the image is their mean and the per-pixel variance comes from their
spread, scaled to one light path per pixel so that ``variance / spp`` is, as for the
other integrators, the variance of the pixel's mean.
"""

from __future__ import annotations

import time

import numpy as np

from ..core.rng import RandomStream, sample_keys
from ..emitters.scene_emitters import check_light_paths
from ..sensors.primary import require_pinhole
from .moments import add_sample
from .result import RenderResult
from .scheduling import DEFAULT_BATCH, run_units


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
    require_pinhole(camera, integrator.name)
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
        if self.integrator.camera_subpaths:
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
        self.count = add_sample(self.count, self.mean, self.m2, self.image / self.per_pixel)
        self.image[:] = 0.0

    def result(self) -> tuple[np.ndarray, np.ndarray]:
        """(mean, per-path-per-pixel variance) once every unit is merged."""
        self._close_replica()
        variance = self.m2 / max(self.count - 1, 1) * self.per_pixel
        return self.mean, (variance if self.count > 1 else np.zeros_like(variance))
