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

A ``null`` BSDF (in a scene without media) is such a Dirac event: ``w = -d``, weight 1,
counted as a bounce of ``max_depth``, and a shadow ray that meets it is blocked, as in
Mitsuba's ``path``.
"""
from __future__ import annotations

import numpy as np

from ..bsdfs.shading import sample_bsdf
from ..core.sampling import power_heuristic
from ..emitters.scene_emitters import pdf_emitter_direction
from ..scene.registry import register
from .base import CameraIntegrator


@register("integrator", "path")
class PathIntegrator(CameraIntegrator):
    """MIS path tracer, Mitsuba's ``path``."""

    name = "path"
    handles_null = True
    refills = True

    def radiance(self, scene, rays, rng):
        paths = self.camera_paths(scene, rays, rng)
        paths.declare(prev_p=rays.o,       # the previous vertex (for the light pdf of a hit)
                      prev_pdf=1.0,        # pdf of the BSDF sample that left it
                      prev_delta=True)     # was that sample Dirac? (the camera counts as one)
        while paths:
            # ---- Emission found by BSDF sampling, weighted against light sampling ----
            Le = self.emission(scene, paths.hit, paths.wi, paths.depth)
            pdf_light = np.where(paths.prev_delta, 0.0, pdf_emitter_direction(
                scene, paths.prev_p, paths.hit, -paths.wi))
            paths.add_radiance(paths.beta * Le * power_heuristic(paths.prev_pdf, pdf_light)[:, None])

            # ---- Paths that escaped, or whose next segment max_depth forbids, end ----
            paths.keep(paths.hit.valid & (paths.depth + 1 < self.depth_limit))
            if not paths:
                break

            # ---- Direct light: a shadow ray, weighted against BSDF sampling ----
            paths.add_radiance(self.sample_direct(scene, paths, mis_weight=power_heuristic))

            # ---- BSDF sample: the next direction ----
            bs = sample_bsdf(scene, paths.hit, paths.wi, paths.rng.next_1d(), paths.rng.next_2d(),
                             self.hemisphere)
            paths.scatter(bs.wo, bs.weight, bs.eta)
            paths.prev_p, paths.prev_pdf, paths.prev_delta = paths.hit.p, bs.pdf, bs.delta

            # ---- Russian roulette, then the next hit ----
            self.russian_roulette(paths)
            paths.next_hit(scene)
        return paths.L
