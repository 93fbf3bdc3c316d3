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

from ..bsdfs.shading import sample_bsdf
from ..scene.registry import register
from .base import CameraIntegrator


@register("integrator", "path_nee")
class PathNEEIntegrator(CameraIntegrator):
    """Path tracing with shadow rays and the "last bounce not specular" rule."""

    name = "path_nee"
    refills = True

    def radiance(self, scene, rays, rng):
        paths = self.camera_paths(scene, rays, rng)
        paths.declare(last_specular=True)     # was the last bounce Dirac? (the camera counts)
        while paths:
            # ---- Le, only where no shadow ray counted it: after the camera or a Dirac bounce ----
            Le = self.emission(scene, paths.hit, paths.wi, paths.depth)
            paths.add_radiance(np.where(paths.last_specular[:, None], paths.beta * Le, 0.0))

            # ---- Paths that escaped, or whose next segment max_depth forbids, end ----
            paths.keep(paths.hit.valid & (paths.depth + 1 < self.depth_limit))
            if not paths:
                break

            # ---- Direct illumination: one shadow ray to a uniformly chosen light ----
            paths.add_radiance(self.sample_direct(scene, paths))

            # ---- Indirect illumination: continue along a sampled direction ----
            bs = sample_bsdf(scene, paths.hit, paths.wi, paths.rng.next_1d(), paths.rng.next_2d(),
                             self.hemisphere)
            paths.scatter(bs.wo, bs.weight, bs.eta)
            paths.last_specular = bs.delta

            # ---- Russian roulette, then the next hit ----
            self.russian_roulette(paths)
            paths.next_hit(scene)
        return paths.L
