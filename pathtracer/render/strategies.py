"""Bidirectional path tracing strategy by strategy: the image of every (s, t)."""

from __future__ import annotations

import numpy as np

from ..core.rng import RandomStream, sample_keys
from ..emitters.scene_emitters import check_light_paths
from ..integrators.bdpt import BDPTIntegrator
from ..sensors.primary import require_pinhole
from .moments import add_power_sums, mean_and_variance_from_sums, power_sums
from .scheduling import DEFAULT_BATCH
from .splats import replica_count


def render_strategies(scene, integrator: BDPTIntegrator, spp: int, seed: int,
                      weighted: bool = True, batch_size: int = DEFAULT_BATCH) -> dict:
    """The image of every strategy (s, t): ``{(s, t): (mean, variance)}``, (H, W, 3) arrays.

    The samples and their random numbers are those of :func:`pathtracer.render.render`
    (replicas included), so with ``weighted`` the images sum to its image up to float
    rounding. ``variance`` is per sample, from the replicas' spread, as for the render.
    Without ``weighted``, image (s, t) is that strategy's own estimate of the paths of
    s + t - 1 segments (Veach's figure 10.3).
    """
    camera = scene.camera
    require_pinhole(camera, integrator.name)   # the refusals of every splatting render
    check_light_paths(scene)
    n_pixels = camera.width * camera.height
    replicas = replica_count(spp, integrator.replicas)
    per_pixel = spp // replicas
    paths = per_pixel * n_pixels
    sums: dict = {}
    for replica in range(replicas):
        image: dict = {}
        for b0 in range(0, paths, batch_size):
            ids = replica * paths + np.arange(b0, min(paths, b0 + batch_size), dtype=np.int64)
            rng = RandomStream(sample_keys(seed, ids))
            s, t, pixel, value = integrator.contributions(scene, rng, ids % n_pixels,
                                                          weighted)
            for key in set(zip(s.tolist(), t.tolist())):
                rows = (s == key[0]) & (t == key[1])
                total = image.setdefault(key, np.zeros((n_pixels, 3)))
                for c in range(3):
                    total[:, c] += np.bincount(pixel[rows], weights=value[rows, c],
                                               minlength=n_pixels)
        for key, total in image.items():
            add_power_sums(sums.setdefault(key, power_sums(n_pixels)), total / per_pixel)
    shape = (camera.height, camera.width, 3)
    out = {}
    for key, moments in sums.items():
        mean, variance = mean_and_variance_from_sums(moments, replicas)
        variance = variance * per_pixel if replicas > 1 else np.zeros_like(mean)
        out[key] = (mean.reshape(shape), variance.reshape(shape))
    return dict(sorted(out.items()))
