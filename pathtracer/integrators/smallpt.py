"""smallpt: Kevin Beason's 99-line path tracer, on any loaded scene.

The lecture's listing, lines 48-73, vectorized::

    radiance(r, depth):
        if miss: return black (here: the environment, if any)
        p = max reflectance of the surface colour f
        if (++depth > 5) if (rand < p) f = f / p  else return obj.e      // R.R.
        DIFF: return obj.e + f * radiance(cosine-sampled ray)
        SPEC: return obj.e + f * radiance(mirror ray)
        REFR: Re = Fresnel, Tr = 1 - Re, P = .25 + .5 Re
              depth > 2 ? (rand < P ? radiance(refl) * Re/P : radiance(refr) * Tr/(1-P))
                        : radiance(refl) * Re + radiance(refr) * Tr            // split

To agree with Mitsuba on the same scene file, the scene's definitions replace
smallpt's hard-wired ones: exact Fresnel instead of Schlick, the 1/eta^2
radiance scaling on refraction, one-sided emitters, and any other BSDF is
sampled by its own routine. Beason's 2x2 sub-pixels, tent filter and clamping
are left out: they belong to his film, not to the estimator.
"""
from __future__ import annotations

import numpy as np

from ..bsdfs import Dielectric
from ..rng import RandomStream
from ..shading import bsdf_index, dielectric_lobes, sample_bsdf
from ..textures import Texture
from .base import Integrator, spawn, subset_hit, trace


def surface_colour(bsdf) -> np.ndarray:
    """smallpt's ``obj.c``: the colour whose maximum drives the roulette.

    For a texture, its largest value: smallpt has one colour per object.
    """
    bsdf = getattr(bsdf, "nested", bsdf)
    for name in ("reflectance", "specular_reflectance"):
        if hasattr(bsdf, name):
            value = getattr(bsdf, name)
            if isinstance(value, Texture):
                return value.max_value()
            return np.asarray(value, dtype=float)
    return np.ones(3)


class SmallptIntegrator(Integrator):
    """Beason's algorithm: roulette on max reflectance, glass split while shallow.

    Parameters
    ----------
    split_depth : int
        Glass hits at depth <= split_depth trace both lobes (smallpt: 2).
    rr_depth : int
        Roulette once depth > rr_depth (smallpt: 5).
    """

    name = "smallpt"

    def __init__(self, split_depth: int = 2, **options):
        super().__init__(**options)
        self.split_depth = int(split_depth)

    def options(self):
        return dict(super().options(), split_depth=self.split_depth)

    def radiance(self, scene, rays, rng):
        n = len(rays)
        L = np.zeros((n, 3))
        if self.max_depth == 0:
            return L
        colour = np.array([surface_colour(b) for b in scene.bsdfs])
        glass = np.array([isinstance(getattr(b, "nested", b), Dielectric) for b in scene.bsdfs])
        row, beta = np.arange(n), np.ones((n, 3))
        d = rays.d
        hit = self.trace_camera(scene, rays)
        depth = 0
        while len(row):
            wi = -d
            np.add.at(L, row, beta * self.emission(scene, hit, wi, depth))     # obj.e

            live = np.flatnonzero(hit.valid & (depth + 1 < self.depth_limit))
            row, beta, wi, hit, rng = row[live], beta[live], wi[live], subset_hit(hit, live), rng.subset(live)
            depth += 1
            material = bsdf_index(scene, hit)
            u_rr = rng.next_1d()
            if self.roulette != "off" and depth > self.rr_depth:         # R.R.
                p = colour[material].max(axis=1)
                keep = np.flatnonzero(u_rr < p)
                beta = beta[keep] / p[keep, None]
                row, wi, material = row[keep], wi[keep], material[keep]
                hit, rng = subset_hit(hit, keep), rng.subset(keep)
            if not len(row):
                break

            # DIFF / SPEC / any other BSDF: its own sampling routine.
            u1, u2, u_lobe = rng.next_1d(), rng.next_2d(), rng.next_1d()
            bs = sample_bsdf(scene, hit, wi, u1, u2, self.hemisphere)
            wo, weight = bs.wo, bs.weight
            # REFR: Beason's lobe choice P = .25 + .5 Re below the split depth ...
            refr = glass[material]
            if refr.any():
                lobes = dielectric_lobes(scene, subset_hit(hit, np.flatnonzero(refr)), wi[refr])
                P = 0.25 + 0.5 * lobes.F
                take_r = u_lobe[refr] < P
                wo[refr] = np.where(take_r[:, None], lobes.wo_r, lobes.wo_t)
                weight[refr] = np.where(take_r[:, None], lobes.weight_r / P[:, None],
                                        lobes.weight_t / (1 - P)[:, None])
            # ... and both lobes at shallow depth (splitting).
            split = (np.flatnonzero(refr & (depth <= self.split_depth)) if depth <= self.split_depth
                     else np.zeros(0, int))
            parts_row, parts_beta, parts_hit, parts_wo, parts_rng = [row], [beta * weight], [hit], [wo], [rng]
            if len(split):
                lobes = dielectric_lobes(scene, subset_hit(hit, split), wi[split])
                whole = np.setdiff1d(np.arange(len(row)), split)
                parts_row, parts_beta = [row[whole]], [beta[whole] * weight[whole]]
                parts_hit, parts_wo, parts_rng = [subset_hit(hit, whole)], [wo[whole]], [rng.subset(whole)]
                children = rng.subset(split).branch(2)
                pair = np.repeat(split, 2)
                parts_row.append(row[pair])
                parts_beta.append(beta[pair] * np.stack((lobes.weight_r, lobes.weight_t), axis=1).reshape(-1, 3))
                parts_hit.append(subset_hit(hit, pair))
                parts_wo.append(np.stack((lobes.wo_r, lobes.wo_t), axis=1).reshape(-1, 3))
                parts_rng.append(children)
            row, beta = np.concatenate(parts_row), np.concatenate(parts_beta)
            wo = np.concatenate(parts_wo)
            hit = _concatenate_hits(parts_hit)
            rng = RandomStream.concatenate(parts_rng)

            keep = np.flatnonzero(beta.max(axis=1) > 0)
            row, beta, rng = row[keep], beta[keep], rng.subset(keep)
            next_rays = spawn(subset_hit(hit, keep), wo[keep])
            d = next_rays.d
            hit = trace(scene, next_rays)
        return L


def _concatenate_hits(hits):
    if len(hits) == 1:
        return hits[0]
    return type(hits[0])(**{k: np.concatenate([getattr(h, k) for h in hits]) for k in vars(hits[0])})
