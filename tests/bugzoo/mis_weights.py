"""MIS weights that do not sum to one: direct lighting weights shadow-ray samples with the
power heuristic but adds the emission found by BSDF sampling with weight 1, so for a
direction both strategies can produce, w_light + w_bsdf > 1.

Direct light (bounce 2) is too bright where both strategies find the light.
Expected hint: MIS weights do not sum to one.
"""
import numpy as np
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    registry,
)

from pathtracer.emitters import emitted_radiance, sample_emitter
from pathtracer.integrators import direct
from pathtracer.integrators.base import spawn, subset_hit, trace
from pathtracer.sampling import power_heuristic
from pathtracer.shading import eval_bsdf, has_smooth, sample_bsdf

BUG = "BSDF-sampled emission added with MIS weight 1"
CHECK = "direct-cornell-box"
EXPECTED = ("mis",)


class Mutant(direct.DirectIntegrator):
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
        w_bsdf = np.ones(len(ok))          # the bug: power_heuristic(bs.pdf, pdf_light) missing
        L[row[ok]] += bs.weight[ok] * Le * w_bsdf[:, None]
        return L


INTEGRATORS = registry(Mutant)
