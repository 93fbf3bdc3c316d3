r"""Synthetic renders through a reconstruction filter, for calibrating the statistics.

Each pixel draws ``n`` samples of the mixture of :mod:`mitsuba_refs.stats.simulate`
(:math:`X = B V + N(\mu, s^2)` with the pixel's parameters), at uniform positions inside
the pixel, and the film splats them through the filter exactly as the tracer does
(:func:`pathtracer.sensors.film.splat`, :func:`pathtracer.render.filtered_mean_and_variance`).
Unlike the box-filter simulation this draws every sample (the weights depend on where
each one lands), so it is kept to small images.
"""
from __future__ import annotations

import numpy as np

from pathtracer.render.moments import filtered_mean_and_variance
from pathtracer.sensors.film import ReconstructionFilter, effective_counts, splat

from .simulate import SkewedScene

__all__ = ["render_filtered", "expected_filtered"]


def _samples(scene: SkewedScene, n: int, rng: np.random.Generator):
    h, w = scene.p.shape
    hit = rng.random((h * w, n)) < scene.p.reshape(-1, 1)
    mu, sd = scene.mu.reshape(-1, 1, 3), scene.sd.reshape(-1, 1, 3)
    values = mu + sd * rng.standard_normal((h * w, n, 3))
    values += hit[..., None] * scene.value.reshape(-1, 1, 3)
    return rng.random((h * w, n, 2)), values


def render_filtered(scene: SkewedScene, rfilter: ReconstructionFilter, n: int,
                    rng: np.random.Generator, *, scale=1.0):
    """One filtered render of ``n`` samples per pixel: per-pixel mean and variance (H, W, 3).

    ``scale`` multiplies every sample (a bias); the variance is the per-sample variance
    the tracer reports for a filtered film.
    """
    h, w = scene.p.shape
    u_film, values = _samples(scene, n, rng)
    sums = splat(rfilter, w, h, np.arange(h * w), u_film, values * scale)
    mean, var = filtered_mean_and_variance(sums, effective_counts(rfilter, w, h, n).reshape(-1, 1))
    return mean.reshape(h, w, 3), var.reshape(h, w, 3)


def expected_filtered(scene: SkewedScene, rfilter: ReconstructionFilter) -> np.ndarray:
    """The filtered image a render converges to, ``E[sum w X] / E[sum w]``, (H, W, 3).

    Exact for the mixture: a sample's expected value is its pixel's ``E[X]`` wherever it
    lands, so this is the expected image averaged with each pixel's expected weights.
    """
    h, w = scene.p.shape
    steps = 32
    u = (np.arange(steps) + 0.5) / steps
    grid = np.stack(np.meshgrid(u, u), axis=-1).reshape(1, -1, 2)        # (1, steps^2, 2)
    u_film = np.broadcast_to(grid, (h * w, steps * steps, 2))
    values = np.broadcast_to(scene.expected.reshape(-1, 1, 3), (h * w, steps * steps, 3))
    weight, wf, _ = splat(rfilter, w, h, np.arange(h * w), u_film, values)
    return (wf / weight[:, None]).reshape(h, w, 3)
