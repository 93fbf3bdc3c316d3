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

from ..emitters import sample_emitter
from ..shading import eval_bsdf, has_smooth, sample_bsdf
from .base import Integrator, spawn, subset_hit, trace


class RecursiveIntegrator(Integrator):
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
        n = len(rays)
        L = np.zeros((n, 3))
        if self.max_depth == 0:
            return L
        row, beta, eta = np.arange(n), np.ones((n, 3)), np.ones(n)
        share = np.ones(n)                          # product of the 1/N of every split
        last_specular = np.ones(n, dtype=bool)
        d = rays.d
        hit = self.trace_camera(scene, rays)
        depth = 0
        while len(row):
            wi = -d
            # Le counts only when the last bounce was specular (or from the camera).
            Le = self.emission(scene, hit, wi, depth)
            np.add.at(L, row, np.where(last_specular[:, None], share[:, None] * beta * Le, 0.0))

            live = np.flatnonzero(hit.valid & (depth + 1 < self.depth_limit))
            row, beta, eta, wi = row[live], beta[live], eta[live], wi[live]
            share = share[live]
            hit, rng = subset_hit(hit, live), rng.subset(live)
            if not len(row):
                break

            # Ld: one shadow ray to every light.
            smooth = has_smooth(scene, hit)
            for emitter in range(scene.num_emitters):
                light = sample_emitter(scene, hit, rng.next_1d(), rng.next_2d(), emitter=emitter)
                f_light, _ = eval_bsdf(scene, hit, wi, light.wo, self.hemisphere)
                contribution = share[:, None] * beta * f_light * light.weight
                np.add.at(L, row, np.where((smooth & (light.pdf > 0))[:, None], contribution, 0.0))

            # Li: N indirect rays, each weighted 1/N.
            copies = self.branches if depth < self.branch_depth else 1
            if copies > 1:
                parent = np.repeat(np.arange(len(row)), copies)
                row, beta, eta, wi = row[parent], beta[parent], eta[parent], wi[parent]
                share = share[parent] / copies
                hit, rng = subset_hit(hit, parent), rng.branch(copies)
            bs = sample_bsdf(scene, hit, wi, rng.next_1d(), rng.next_2d(), self.hemisphere)
            beta, eta = beta * bs.weight, eta * bs.eta
            last_specular = bs.delta
            depth += 1

            throughput_max = beta.max(axis=1)
            survive, beta = self.roulette_survivors(beta, eta, depth, rng.next_1d())
            keep = np.flatnonzero(survive & (throughput_max > 0))
            row, beta, eta, rng = row[keep], beta[keep], eta[keep], rng.subset(keep)
            share = share[keep]
            last_specular = last_specular[keep]
            next_rays = spawn(subset_hit(hit, keep), bs.wo[keep])
            d = next_rays.d
            hit = trace(scene, next_rays)
        return L
