r"""Synthetic skewed "renders" for calibrating the statistics (no rendering, no I/O).

A pixel's radiance sample is a Bernoulli mixture, the shape of a path that sometimes hits
a small light:

.. math::  X = B\,V + \varepsilon,\quad B\sim\mathrm{Bernoulli}(p),\ \varepsilon\sim N(\mu, s^2)

with per-pixel :math:`p, V, \mu, s` (``V`` per channel, ``B`` shared by the channels, as one
path carries all three).  Black tiles have :math:`p=\mu=s=0` (exactly zero samples).

Instead of drawing ``n`` samples per pixel, the *sufficient statistics* (mean and unbiased
sample variance) are drawn exactly: :math:`k\sim\mathrm{Bin}(n,p)` hits; the hit and miss group
means of :math:`\varepsilon` are normal; the within-group sum of squares is
:math:`s^2\chi^2_{n-g}` with :math:`g` the number of non-empty groups; and the between-group
part is computed from the group means.  This makes a 4096-spp reference of a 64x64 image
cost as much as a 1-spp one, so calibration can run over hundreds of seeds.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["SkewedScene", "make_scene", "render_stats", "render_means", "image_mse_batch"]


@dataclass(frozen=True, eq=False)
class SkewedScene:
    """Per-pixel parameters of the mixture (arrays (H, W) for p, (H, W, 3) for the rest)."""

    p: np.ndarray
    value: np.ndarray
    mu: np.ndarray
    sd: np.ndarray

    @property
    def expected(self) -> np.ndarray:
        """Exact expected image E[X], shape (H, W, 3)."""
        return self.p[..., None] * self.value + self.mu

    @property
    def per_sample_var(self) -> np.ndarray:
        """Exact per-sample variance Var[X], shape (H, W, 3)."""
        p = self.p[..., None]
        return p * (1 - p) * self.value ** 2 + self.sd ** 2


def make_scene(h: int = 64, w: int = 64, *, seed: int = 0, p_range=(0.01, 0.5), black_fraction: float = 0.2,
               tile: int = 8, noise_rel: float = 0.3) -> SkewedScene:
    """A random scene: smooth-ish hit probabilities in ``p_range`` (log-uniform per 4x4 block),
    light values so that E[X] ~ 1, a background fraction of black 8x8 tiles, and Gaussian
    "indirect" noise with mean 0.3 and sd ``noise_rel``."""
    rng = np.random.default_rng(seed)
    bh, bw = -(-h // 4), -(-w // 4)
    logp = rng.uniform(np.log(p_range[0]), np.log(p_range[1]), size=(bh, bw))
    p = np.exp(np.kron(logp, np.ones((4, 4))))[:h, :w]
    color = rng.uniform(0.5, 1.0, size=(h, w, 3))
    value = color * 0.7 / p[..., None]
    mu = np.full((h, w, 3), 0.3) * color
    sd = np.full((h, w, 3), noise_rel) * color
    th, tw = -(-h // tile), -(-w // tile)
    black = rng.random((th, tw)) < black_fraction
    mask = np.kron(black, np.ones((tile, tile), dtype=bool))[:h, :w]
    p = np.where(mask, 0.0, p)
    value = np.where(mask[..., None], 0.0, value)
    mu = np.where(mask[..., None], 0.0, mu)
    sd = np.where(mask[..., None], 0.0, sd)
    return SkewedScene(p=p, value=value, mu=mu, sd=sd)


def render_stats(scene: SkewedScene, n: int, n_seeds: int, rng: np.random.Generator, *,
                 scale=1.0, extra_var=0.0, noise_scale=1.0):
    """Draw per-pixel (mean, unbiased variance) of ``n`` samples for ``n_seeds`` independent renders.

    Parameters
    ----------
    scale : float or array (H, W, 3)
        Multiplicative bias on every sample (1 = unbiased).
    extra_var : float or array (H, W, 3)
        Variance of extra zero-mean Gaussian noise added to every sample (mean unchanged).
    noise_scale : float
        Scales the Gaussian ("indirect") part only, e.g. 0.9 mimics roulette without 1/q.

    Returns
    -------
    mean, var : ndarrays (n_seeds, H, W, 3)
    """
    h, w = scene.p.shape
    S = n_seeds
    k = rng.binomial(n, np.broadcast_to(scene.p, (S, h, w)))[..., None].astype(np.float64)
    V = scene.value
    mu, sd = scene.mu * noise_scale, scene.sd * noise_scale
    shape = (S, h, w, 3)
    km = n - k
    with np.errstate(divide="ignore", invalid="ignore"):
        eh = mu + sd * rng.standard_normal(shape) / np.sqrt(np.maximum(k, 1))
        em = mu + sd * rng.standard_normal(shape) / np.sqrt(np.maximum(km, 1))
    xh = V + eh
    xm = em
    mean = (k * xh + km * xm) / n
    groups = (k > 0).astype(np.float64) + (km > 0)
    within = sd ** 2 * rng.chisquare(np.maximum(n - groups, 1e-12), size=shape) * (n - groups > 0)
    between = k * (xh - mean) ** 2 + km * (xm - mean) ** 2
    ss = within + between
    extra = np.broadcast_to(np.asarray(extra_var, dtype=np.float64), (h, w, 3))
    if np.any(extra > 0):
        g = rng.standard_normal(shape)
        ss = (np.sqrt(ss) + np.sqrt(extra) * g) ** 2 + extra * rng.chisquare(n - 2, size=shape)
        mean = mean + np.sqrt(extra / n) * rng.standard_normal(shape)
    var = ss / (n - 1)
    scale = np.asarray(scale, dtype=np.float64)
    return mean * scale, var * scale ** 2


def render_means(scene: SkewedScene, n, n_seeds: int, rng: np.random.Generator, *, scale=1.0,
                 correlated: bool = False) -> np.ndarray:
    """Per-pixel means only, shape (n_seeds, H, W, 3).  ``correlated=True`` reuses one sample
    ``n`` times (random numbers reused), so the mean never converges."""
    h, w = scene.p.shape
    shape = (n_seeds, h, w, 3)
    m = 1 if correlated else int(n)
    k = rng.binomial(m, np.broadcast_to(scene.p, (n_seeds, h, w)))[..., None]
    eps = scene.mu + scene.sd * rng.standard_normal(shape) / np.sqrt(m)
    return (k * scene.value / m + eps) * np.asarray(scale, dtype=np.float64)


def image_mse_batch(test_means: np.ndarray, ref_mean: np.ndarray, ref_var: np.ndarray, ref_n) -> np.ndarray:
    """Vectorised :func:`mitsuba_refs.stats.convergence.image_mse` over a leading batch axis."""
    d = test_means - ref_mean
    return (d ** 2).mean(axis=tuple(range(1, d.ndim))) - float(np.mean(ref_var / ref_n))
