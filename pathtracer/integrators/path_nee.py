"""Path tracing with shadow rays (next-event estimation), no MIS.

The lecture's "Path Tracing Algorithm" slide::

    color shade(point x, normal n) {
        for all lights                    // direct illumination
            Ld += contribution from light;
        w' = random direction in hemisphere above n;    // indirect illumination
        Li += brdf * shade(trace(x, w')) * dot(n, w') / p(w');
        if last bounce not specular       // prevent double-counting
            return Ld + Li;
        return Le + Ld + Li;
    }

Iteratively, with "for all lights" estimated by one uniformly chosen light::

    L += beta * Le(x_k)        only if k = 0 (camera ray) or the last bounce was specular
    L += beta * f cos Le V / p_light          on BSDFs with a smooth lobe
    w ~ BSDF;  beta *= f cos / p;  roulette

Emission reached after a smooth bounce is not counted: the shadow ray of the
previous vertex already estimated it. Counting it too is the classic bug.
"""
from __future__ import annotations

import numpy as np

from ..emitters import sample_emitter
from ..shading import eval_bsdf, has_smooth, sample_bsdf
from .base import Integrator, spawn, subset_hit, trace


class PathNEEIntegrator(Integrator):
    """Path tracing with shadow rays and the "last bounce not specular" rule."""

    name = "path_nee"

    def radiance(self, scene, rays, rng):
        n = len(rays)
        L = np.zeros((n, 3))
        if self.max_depth == 0:
            return L
        row, beta, eta = np.arange(n), np.ones((n, 3)), np.ones(n)
        last_specular = np.ones(n, dtype=bool)      # the camera counts as specular
        d = rays.d
        hit = self.trace_camera(scene, rays)
        depth = 0
        while len(row):
            wi = -d
            Le = self.emission(scene, hit, wi, depth)
            L[row] += np.where(last_specular[:, None], beta * Le, 0.0)

            live = np.flatnonzero(hit.valid & (depth + 1 < self.depth_limit))
            row, beta, eta, wi = row[live], beta[live], eta[live], wi[live]
            hit, rng = subset_hit(hit, live), rng.subset(live)
            if not len(row):
                break

            # Direct illumination: one shadow ray to a uniformly chosen light.
            light = sample_emitter(scene, hit, rng.next_1d(), rng.next_2d())
            f_light, _ = eval_bsdf(scene, hit, wi, light.wo, self.hemisphere)
            smooth = has_smooth(scene, hit)
            L[row] += np.where((smooth & (light.pdf > 0))[:, None], beta * f_light * light.weight, 0.0)

            # Indirect illumination: continue along a sampled direction.
            bs = sample_bsdf(scene, hit, wi, rng.next_1d(), rng.next_2d(), self.hemisphere)
            beta, eta = beta * bs.weight, eta * bs.eta
            last_specular = bs.delta
            depth += 1

            throughput_max = beta.max(axis=1)
            survive, beta = self.roulette_survivors(beta, eta, depth, rng.next_1d())
            keep = np.flatnonzero(survive & (throughput_max > 0))
            row, beta, eta, rng = row[keep], beta[keep], eta[keep], rng.subset(keep)
            last_specular = last_specular[keep]
            next_rays = spawn(subset_hit(hit, keep), bs.wo[keep])
            d = next_rays.d
            hit = trace(scene, next_rays)
        return L
