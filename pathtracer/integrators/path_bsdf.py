"""Path tracing with BSDF (hemisphere) sampling only.

The lecture's "Path Tracing" slide::

    L(x, w) ~= Le(x, w) + f_r(x, w', w) L(r(x, w'), -w') cos(theta') / p(w')

One direction per vertex, emission picked up wherever a path lands (no shadow
rays, so small lights are found only by chance), Russian roulette to stop::

    L += beta * Le(x_k, -d)
    w ~ p;  beta *= f cos / p;  after rr_depth: continue with q, beta /= q
"""
from __future__ import annotations

import numpy as np

from ..shading import sample_bsdf
from .base import Integrator, spawn, subset_hit, trace


class PathBSDFIntegrator(Integrator):
    """Path tracing that only samples the BSDF."""

    name = "path_bsdf"

    def radiance(self, scene, rays, rng):
        n = len(rays)
        L = np.zeros((n, 3))
        if self.max_depth == 0:
            return L
        row, beta, eta = np.arange(n), np.ones((n, 3)), np.ones(n)
        d = rays.d
        hit = self.trace_camera(scene, rays)
        depth = 0
        while len(row):
            wi = -d
            L[row] += beta * self.emission(scene, hit, wi, depth)

            live = np.flatnonzero(hit.valid & (depth + 1 < self.depth_limit))
            row, beta, eta, wi = row[live], beta[live], eta[live], wi[live]
            hit, rng = subset_hit(hit, live), rng.subset(live)
            if not len(row):
                break

            bs = sample_bsdf(scene, hit, wi, rng.next_1d(), rng.next_2d(), self.hemisphere)
            beta, eta = beta * bs.weight, eta * bs.eta
            depth += 1

            throughput_max = beta.max(axis=1)
            survive, beta = self.roulette_survivors(beta, eta, depth, rng.next_1d())
            keep = np.flatnonzero(survive & (throughput_max > 0))
            row, beta, eta, rng = row[keep], beta[keep], eta[keep], rng.subset(keep)
            next_rays = spawn(subset_hit(hit, keep), bs.wo[keep])
            d = next_rays.d
            hit = trace(scene, next_rays)
        return L
