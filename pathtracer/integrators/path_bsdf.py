"""Path tracing with BSDF (hemisphere) sampling only.

The lecture's "Path Tracing" slide::

    L(x, w) ~= Le(x, w) + f_r(x, w', w) L(r(x, w'), -w') cos(theta') / p(w')

One direction per vertex, emission picked up wherever a path lands (no shadow
rays, so small lights are found only by chance), Russian roulette to stop::

    L += beta * Le(x_k, -d)
    w ~ p;  beta *= f cos / p;  after rr_depth: continue with q, beta /= q
"""
from __future__ import annotations

from ..bsdfs.shading import sample_bsdf
from ..scene.registry import register
from .base import CameraIntegrator


@register("integrator", "path_bsdf")
class PathBSDFIntegrator(CameraIntegrator):
    """Path tracing that only samples the BSDF."""

    name = "path_bsdf"
    refills = True

    def radiance(self, scene, rays, rng):
        paths = self.camera_paths(scene, rays, rng)
        while paths:
            # ---- Emission wherever a path lands ----
            paths.add_radiance(paths.beta * self.emission(scene, paths.hit, paths.wi, paths.depth))

            # ---- Paths that escaped, or whose next segment max_depth forbids, end ----
            paths.keep(paths.hit.valid & (paths.depth + 1 < self.depth_limit))
            if not paths:
                break

            # ---- BSDF sample: the next direction ----
            bs = sample_bsdf(scene, paths.hit, paths.wi, paths.rng.next_1d(), paths.rng.next_2d(),
                             self.hemisphere)
            paths.scatter(bs.wo, bs.weight, bs.eta)

            # ---- Russian roulette, then the next hit ----
            self.russian_roulette(paths)
            paths.next_hit(scene)
        return paths.L
