"""Path tracing with shadow rays and BSDF sampling combined by MIS (the default).

The lecture's last advice, "use MIS at least for direct illumination", applied
at every vertex. It is the same estimator as Mitsuba 3's ``path`` plugin, so
the two agree in per-pixel variance as well as in mean.

At vertex x_k reached with throughput beta along direction d from x_{k-1}::

    L += beta * Le(x_k, -d) * w_bsdf           w_bsdf = p_bsdf^2 / (p_bsdf^2 + p_light^2)
    (x_l, p_light) ~ uniform emitter, then area / cone sampling on it
    L += beta * f(x_k, -d, w_l) cos / p_light * Le * V * w_light
                                               w_light = p_light^2 / (p_light^2 + p_bsdf^2)
    (w, p_bsdf) ~ BSDF;  beta *= f cos / p_bsdf;  eta *= eta_crossed
    after rr_depth segments: continue with q = min(max(beta) eta^2, 0.95), beta /= q

Emission reached through a Dirac (specular) bounce, or seen directly from the
camera, has w_bsdf = 1; a Dirac light (point) has w_light = 1. Next-event
estimation only happens on BSDFs with a smooth lobe.
"""
from __future__ import annotations

import numpy as np

from ..emitters import pdf_emitter_direction, sample_emitter
from ..sampling import power_heuristic
from ..shading import eval_bsdf, has_smooth, sample_bsdf
from .base import Integrator, spawn, subset_hit, trace


class PathIntegrator(Integrator):
    """MIS path tracer, Mitsuba's ``path``."""

    name = "path"

    def radiance(self, scene, rays, rng):
        n = len(rays)
        L = np.zeros((n, 3))
        if self.max_depth == 0:
            return L
        row = np.arange(n)                      # result row of each live path
        beta, eta = np.ones((n, 3)), np.ones(n)
        prev_p = rays.o.copy()                  # previous vertex, for the light pdf
        prev_pdf, prev_delta = np.ones(n), np.ones(n, dtype=bool)
        d = rays.d
        hit = self.trace_camera(scene, rays)
        depth = 0
        while len(row):
            wi = -d
            # Emission found by BSDF sampling, weighted against light sampling.
            Le = self.emission(scene, hit, wi, depth)
            pdf_light = np.where(prev_delta, 0.0, pdf_emitter_direction(scene, prev_p, hit, d))
            L[row] += beta * Le * power_heuristic(prev_pdf, pdf_light)[:, None]

            live = np.flatnonzero(hit.valid & (depth + 1 < self.depth_limit))
            row, beta, eta, wi = row[live], beta[live], eta[live], wi[live]
            hit, rng = subset_hit(hit, live), rng.subset(live)
            if not len(row):
                break

            # Shadow ray towards a sampled light, weighted against BSDF sampling.
            light = sample_emitter(scene, hit, rng.next_1d(), rng.next_2d())
            f_light, pdf_bsdf = eval_bsdf(scene, hit, wi, light.wo, self.hemisphere)
            w_light = np.where(light.delta, 1.0, power_heuristic(light.pdf, pdf_bsdf))
            use = has_smooth(scene, hit) & (light.pdf > 0)
            L[row] += np.where(use[:, None], beta * f_light * light.weight * w_light[:, None], 0.0)

            # Continue the path by sampling the BSDF.
            bs = sample_bsdf(scene, hit, wi, rng.next_1d(), rng.next_2d(), self.hemisphere)
            beta, eta = beta * bs.weight, eta * bs.eta
            prev_p, prev_pdf, prev_delta = hit.p, bs.pdf, bs.delta
            depth += 1

            throughput_max = beta.max(axis=1)
            survive, beta = self.roulette_survivors(beta, eta, depth, rng.next_1d())
            keep = np.flatnonzero(survive & (throughput_max > 0))
            row, beta, eta = row[keep], beta[keep], eta[keep]
            prev_p, prev_pdf, prev_delta = prev_p[keep], prev_pdf[keep], prev_delta[keep]
            rng = rng.subset(keep)
            next_rays = spawn(subset_hit(hit, keep), bs.wo[keep])
            d = next_rays.d
            hit = trace(scene, next_rays)
        return L
