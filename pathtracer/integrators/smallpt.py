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

import inspect

import numpy as np

from ..bsdfs import Dielectric
from ..bsdfs.shading import bsdf_index, dielectric_lobes, sample_bsdf
from ..core.vec import max_component
from ..scene.registry import register
from ..textures.base import Texture
from .base import CameraIntegrator, subset_hit


def surface_colour(bsdf) -> np.ndarray:
    """smallpt's ``obj.c``: the colour whose maximum drives the roulette.

    For a texture, its largest value: smallpt has one colour per object.
    """
    bsdf = getattr(bsdf, "nested", bsdf)
    for name in ("reflectance", "specular_reflectance"):
        value = getattr(bsdf, name, None)
        if value is not None and not inspect.ismethod(value):   # thindielectric's is a method
            if isinstance(value, Texture):
                return value.max_value()
            return np.asarray(value, dtype=float)
    return np.ones(3)


@register("integrator", "smallpt")
class SmallptIntegrator(CameraIntegrator):
    """Beason's algorithm: roulette on max reflectance, glass split while shallow.

    Parameters
    ----------
    split_depth : int
        Glass hits at depth <= split_depth trace both lobes (smallpt: 2).
    rr_depth : int
        Roulette once depth > rr_depth (smallpt: 5).
    """

    name = "smallpt"
    refills = True

    def __init__(self, split_depth: int = 2, **options):
        super().__init__(**options)
        self.split_depth = int(split_depth)

    def options(self):
        return dict(super().options(), split_depth=self.split_depth)

    def radiance(self, scene, rays, rng):
        colour = np.array([surface_colour(b) for b in scene.bsdfs])
        glass = np.array([isinstance(getattr(b, "nested", b), Dielectric) for b in scene.bsdfs])
        paths = self.camera_paths(scene, rays, rng)
        while paths:
            # ---- obj.e ----
            paths.add_radiance(paths.beta * self.emission(scene, paths.hit, paths.wi, paths.depth))

            # ---- Paths that escaped, or whose next segment max_depth forbids, end; ----
            # ---- R.R. once depth > 5: continue with p = max(f), f /= p (others: p = 1) ----
            # (one compaction for both: a path's numbers do not depend on who else is drawn)
            depth = np.broadcast_to(paths.depth + 1, len(paths))   # smallpt's ++depth, per path
            material = bsdf_index(scene, paths.hit)   # a miss reads some BSDF: it ends anyway
            u_rr = paths.rng.next_1d()
            goes_on = paths.hit.valid & (depth < self.depth_limit)
            if self.roulette != "off":
                p = np.where(depth > self.rr_depth, max_component(colour[material]), 1.0)
                survivors = paths.keep(goes_on & (u_rr < p))
                paths.beta = paths.beta / p[survivors, None]
            else:
                survivors = paths.keep(goes_on)
            material, depth = material[survivors], depth[survivors]
            if not paths:
                break

            # ---- DIFF / SPEC / any other BSDF: its own sampling routine ----
            u1, u2, u_lobe = paths.rng.next_1d(), paths.rng.next_2d(), paths.rng.next_1d()
            bs = sample_bsdf(scene, paths.hit, paths.wi, u1, u2, self.hemisphere)
            wo, weight = bs.wo, bs.weight

            # ---- REFR: Re = Fresnel, Tr = 1 - Re ----
            refr = np.flatnonzero(glass[material])
            if len(refr):
                lobes = dielectric_lobes(scene, subset_hit(paths.hit, refr), paths.wi[refr])
                deep = depth[refr] > self.split_depth
                # deep: one lobe, reflection with probability P = .25 + .5 Re
                one, P = refr[deep], 0.25 + 0.5 * lobes.F[deep]
                take_r = (u_lobe[one] < P)[:, None]
                wo[one] = np.where(take_r, lobes.wo_r[deep], lobes.wo_t[deep])
                weight[one] = np.where(take_r, lobes.weight_r[deep] / P[:, None],
                                       lobes.weight_t[deep] / (1 - P)[:, None])
                # shallow: both lobes, radiance(refl) Re + radiance(refr) Tr (splitting)
                both, shallow = refr[~deep], ~deep
                if len(both):
                    parent = paths.split(2, both)    # the children come last, in (refl, refr) pairs
                    wo, weight = wo[parent], weight[parent]
                    children = len(parent) - 2 * len(both)
                    wo[children:] = _pairs(lobes.wo_r[shallow], lobes.wo_t[shallow])
                    weight[children:] = _pairs(lobes.weight_r[shallow], lobes.weight_t[shallow])
            paths.scatter(wo, weight)

            # ---- Paths that carry no light end; the next hit ----
            paths.keep(max_component(paths.beta) > 0)
            paths.next_hit(scene)
        return paths.L


def _pairs(first: np.ndarray, second: np.ndarray) -> np.ndarray:
    """Rows first[0], second[0], first[1], second[1], ... (the children of a split)."""
    return np.stack((first, second), axis=1).reshape(-1, first.shape[1])
