"""Recursive Monte Carlo ray tracing: N indirect rays per hit, plus shadow rays.

The lecture's "Monte Carlo Ray Tracing Algorithm" slide::

    color shade(point x, normal n) {
        for all lights                          // direct illumination
            Ld += contribution from light;
        for all N indirect sample rays          // indirect illumination
            w' = random direction in hemisphere above n;
            Li += brdf * shade(trace(x, w')) * dot(n, w') / (p(w') * N);
        if last bounce not specular             // prevent double-counting
            return Ld + Li;
        return Le + Ld + Li;
    }

"for all lights" is literal: every emitter gets its own shadow ray. Every hit
above depth ``branch_depth`` spawns ``branches`` indirect rays, each carrying
1/N of the throughput, so the work grows as N^depth (the slide's "exponential
growth"); deeper hits spawn a single ray (path tracing) and Russian roulette
ends the recursion without bias. The recursion is evaluated breadth-first:
all rays of one recursion level form one batch.
"""
from __future__ import annotations

import numpy as np

from ..bsdfs.shading import sample_bsdf
from ..scene.registry import register
from .base import CameraIntegrator


@register("integrator", "recursive")
class RecursiveIntegrator(CameraIntegrator):
    """Recursive ray tracing with ``branches`` indirect rays per hit.

    Parameters
    ----------
    branches : int
        N, the indirect rays per hit while depth < ``branch_depth``.
    branch_depth : int
        Hits at this depth or deeper spawn a single indirect ray.
    """

    name = "recursive"

    def __init__(self, branches: int = 4, branch_depth: int = 2, **options):
        super().__init__(**options)
        if int(branches) < 1:
            raise ValueError(f"branches must be >= 1, got {branches}")
        self.branches = int(branches)
        self.branch_depth = int(branch_depth)

    def options(self):
        return dict(super().options(), branches=self.branches, branch_depth=self.branch_depth)

    def radiance(self, scene, rays, rng):
        paths = self.camera_paths(scene, rays, rng)
        paths.declare(share=1.0,              # the product of the 1/N of every split above
                      last_specular=True)     # was the last bounce Dirac? (the camera counts)
        while paths:
            # ---- Le, only if the last bounce was specular (or from the camera) ----
            Le = self.emission(scene, paths.hit, paths.wi, paths.depth)
            paths.add_radiance(np.where(paths.last_specular[:, None],
                                        paths.share[:, None] * paths.beta * Le, 0.0))

            # ---- Paths that escaped, or whose next segment max_depth forbids, end ----
            paths.keep(paths.hit.valid & (paths.depth + 1 < self.depth_limit))
            if not paths:
                break

            # ---- Ld: one shadow ray to every light ----
            for emitter in range(scene.num_emitters):
                paths.add_radiance(self.sample_direct(
                    scene, paths, beta=paths.share[:, None] * paths.beta, emitter=emitter))

            # ---- Li: N indirect rays, each weighted 1/N ----
            copies = self.branches if paths.depth < self.branch_depth else 1
            if copies > 1:
                paths.split(copies)
                paths.share = paths.share / copies
            bs = sample_bsdf(scene, paths.hit, paths.wi, paths.rng.next_1d(), paths.rng.next_2d(),
                             self.hemisphere)
            paths.scatter(bs.wo, bs.weight, bs.eta)
            paths.last_specular = bs.delta

            # ---- Russian roulette, then the next hit ----
            self.russian_roulette(paths)
            paths.next_hit(scene)
        return paths.L
