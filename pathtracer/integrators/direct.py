"""Direct illumination only: light reaching the camera after at most one bounce.

The first term pair of the lecture's split L = Le + Ld + Li, with Li dropped::

    L = Le(x, w) + integral over lights of f_r Le G V dA

estimated as Mitsuba's ``direct`` plugin does: N = ``emitter_samples`` light
samples and M = ``bsdf_samples`` BSDF samples per camera ray, combined with
Veach's multi-sample MIS (power heuristic on the sample-count-weighted
densities, pbrt's ``n_a p_a``)::

    L  = Le(x_1)                                           directly visible emitter
    L += sum_{i<N} f cos Le V / p_light * w_light / N      shadow rays (smooth BSDFs)
    L += sum_{j<M} f cos / p_bsdf * Le(x_2) * w_bsdf / M   BSDF samples that hit a light

    w_light = (N p_light)^2 / ((N p_light)^2 + (M p_bsdf)^2)
    w_bsdf  = (M p_bsdf)^2  / ((M p_bsdf)^2  + (N p_light)^2)

(Mitsuba scales both densities by N / (N + M) and M / (N + M); the common
factor cancels.) A Dirac BSDF sample (mirror, glass) that reaches a light has
weight 1 / M. A sample of a Dirac *light* (point light) has weight 1 and no
1 / N: Mitsuba 3.9.1 does this, so with N > 1 point lights count N times;
we reproduce it because the references are Mitsuba's (with the default
N = M = 1 the estimate is unbiased). With N = 0 only BSDF samples are used
(weight 1 / M), with M = 0 only light samples. In mean it equals path
tracing with max_depth = 2.

The light samples come first, then the BSDF samples, each drawing
(1d, 2d) numbers in turn, so N = M = 1 consumes random numbers exactly as
the single-sample estimator did.
"""
from __future__ import annotations

import numpy as np

from ..bsdfs.shading import sample_bsdf
from ..core.sampling import power_heuristic
from ..emitters.scene_emitters import emitted_radiance, pdf_emitter_direction
from ..scene.registry import register
from .base import CameraIntegrator, spawn, subset_hit, trace


@register("integrator", "direct")
class DirectIntegrator(CameraIntegrator):
    """Direct lighting with multi-sample MIS (Mitsuba's ``direct``).

    Parameters
    ----------
    emitter_samples, bsdf_samples : int, optional
        Light and BSDF samples per camera ray (Mitsuba's defaults: 1 each,
        or ``shading_samples``).
    shading_samples : int, optional
        Sets both counts at once; cannot be combined with them.
    **options
        The :class:`Integrator` options (``max_depth``, ``hide_emitters``...).
    """

    name = "direct"

    def __init__(self, emitter_samples: int | None = None, bsdf_samples: int | None = None,
                 shading_samples: int | None = None, **options):
        super().__init__(**options)
        if shading_samples is not None and (emitter_samples is not None
                                            or bsdf_samples is not None):
            raise ValueError("give either shading_samples or emitter_samples/bsdf_samples, "
                             "not both")
        both = 1 if shading_samples is None else int(shading_samples)
        self.emitter_samples = both if emitter_samples is None else int(emitter_samples)
        self.bsdf_samples = both if bsdf_samples is None else int(bsdf_samples)
        if min(self.emitter_samples, self.bsdf_samples) < 0:
            raise ValueError("emitter_samples and bsdf_samples must be >= 0")
        if self.emitter_samples + self.bsdf_samples == 0:
            raise ValueError("need at least one emitter or BSDF sample")

    def options(self) -> dict:
        """The base options plus the two sample counts."""
        return dict(super().options(), emitter_samples=self.emitter_samples,
                    bsdf_samples=self.bsdf_samples)

    def radiance(self, scene, rays, rng):
        paths = self.camera_paths(scene, rays, rng)
        if not paths:                                       # max_depth = 0
            return paths.L

        # ---- Le: a directly visible emitter ----
        paths.add_radiance(self.emission(scene, paths.hit, paths.wi, paths.depth))

        # ---- Rays that escaped end, and all of them if max_depth = 1 ----
        paths.keep(paths.hit.valid & (paths.depth + 1 < self.depth_limit))
        if not paths:
            return paths.L

        # ---- N shadow rays, then M BSDF samples, each MIS-weighted ----
        for _ in range(self.emitter_samples):
            paths.add_radiance(self.sample_direct(scene, paths, mis_weight=self.light_weight))
        for _ in range(self.bsdf_samples):
            reached, contribution = self.bsdf_sample(scene, paths)
            paths.add_radiance(contribution, rows=reached)
        return paths.L

    def light_weight(self, pdf_light, pdf_bsdf) -> np.ndarray:
        """MIS weight of one of the N light samples (w_light / N above)."""
        # Scaling both densities by the sample counts is exact for N = M = 1
        # (x 0.5 is a power of two), keeping the single-sample images bit-identical.
        total = self.emitter_samples + self.bsdf_samples
        return power_heuristic(pdf_light * (self.emitter_samples / total),
                               pdf_bsdf * (self.bsdf_samples / total)) / self.emitter_samples

    def bsdf_sample(self, scene, paths) -> tuple[np.ndarray, np.ndarray]:
        """One MIS-weighted BSDF sample: the paths whose sample reached a light
        (indices into ``paths``) and their contributions."""
        hit, wi, rng = paths.hit, paths.wi, paths.rng
        bs = sample_bsdf(scene, hit, wi, rng.next_1d(), rng.next_2d(), self.hemisphere)
        ok = np.flatnonzero(np.any(bs.weight > 0, axis=1))
        next_rays = spawn(subset_hit(hit, ok), bs.wo[ok])
        light_hit = trace(scene, next_rays)
        Le = emitted_radiance(scene, light_hit, -next_rays.d)
        pdf_light = np.where(bs.delta[ok], 0.0,
                             pdf_emitter_direction(scene, hit.p[ok], light_hit, next_rays.d))
        total = self.emitter_samples + self.bsdf_samples
        w_bsdf = power_heuristic(bs.pdf[ok] * (self.bsdf_samples / total),
                                 pdf_light * (self.emitter_samples / total)) / self.bsdf_samples
        return ok, bs.weight[ok] * Le * w_bsdf[:, None]
