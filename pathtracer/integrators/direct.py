"""Direct illumination only: light reaching the camera after at most one bounce.

The first term pair of the lecture's split L = Le + Ld + Li, with Li dropped::

    L = Le(x, w) + integral over lights of f_r Le G V dA

estimated as Mitsuba's ``direct`` plugin does (one light sample and one BSDF
sample, combined with the power heuristic), so the two agree in variance::

    L  = Le(x_1)                                        directly visible emitter
    L += f cos Le V / p_light * w_light                 shadow ray (smooth BSDFs)
    L += f cos / p_bsdf * Le(x_2) * w_bsdf              BSDF sample that hits a light

A Dirac BSDF sample (mirror, glass) that reaches a light has weight 1. In mean
it equals path tracing with max_depth = 2.
"""
from __future__ import annotations

import numpy as np

from ..emitters import emitted_radiance, pdf_emitter_direction, sample_emitter
from ..sampling import power_heuristic
from ..shading import eval_bsdf, has_smooth, sample_bsdf
from .base import Integrator, spawn, subset_hit, trace


class DirectIntegrator(Integrator):
    """Direct lighting with MIS (Mitsuba's ``direct`` with one sample of each kind)."""

    name = "direct"

    def radiance(self, scene, rays, rng):
        n = len(rays)
        L = np.zeros((n, 3))
        if self.max_depth == 0:
            return L
        hit = self.trace_camera(scene, rays)
        wi = -rays.d
        if not self.hide_emitters:
            L += emitted_radiance(scene, hit, wi)
        if self.max_depth == 1:
            return L
        row = np.flatnonzero(hit.valid)
        hit, wi, rng = subset_hit(hit, row), wi[row], rng.subset(row)

        light = sample_emitter(scene, hit, rng.next_1d(), rng.next_2d())
        f_light, pdf_bsdf = eval_bsdf(scene, hit, wi, light.wo, self.hemisphere)
        w_light = np.where(light.delta, 1.0, power_heuristic(light.pdf, pdf_bsdf))
        use = has_smooth(scene, hit) & (light.pdf > 0)
        L[row] += np.where(use[:, None], f_light * light.weight * w_light[:, None], 0.0)

        bs = sample_bsdf(scene, hit, wi, rng.next_1d(), rng.next_2d(), self.hemisphere)
        ok = np.flatnonzero(np.any(bs.weight > 0, axis=1))
        next_rays = spawn(subset_hit(hit, ok), bs.wo[ok])
        light_hit = trace(scene, next_rays)
        Le = emitted_radiance(scene, light_hit, -next_rays.d)
        pdf_light = np.where(bs.delta[ok], 0.0,
                             pdf_emitter_direction(scene, hit.p[ok], light_hit, next_rays.d))
        w_bsdf = power_heuristic(bs.pdf[ok], pdf_light)
        L[row[ok]] += bs.weight[ok] * Le * w_bsdf[:, None]
        return L
