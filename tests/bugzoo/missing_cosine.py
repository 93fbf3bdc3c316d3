"""Missing cosine: the indirect bounce of path_nee weights a sampled direction by f / p,
forgetting the cos(theta) of the rendering equation (beta *= f / p instead of f cos / p).

Direct light (bounce 2, shadow rays) stays right; from bounce 3 on the image is too bright.
Expected hint: the indirect term (bounce 3) is wrong.
"""
import numpy as np
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    mutate,
    registry,
)

from pathtracer.integrators import path_nee
from pathtracer.vec import dot

BUG = "indirect bounce weighted by f/p: the cosine is missing"
CHECK = "path_nee-cornell-box"
EXPECTED = ("indirect",)


def _without_cosine(sample_bsdf):
    def buggy(scene, hit, wi, u1, u2, hemisphere="cosine"):
        bs = sample_bsdf(scene, hit, wi, u1, u2, hemisphere)
        cos = np.abs(dot(bs.wo, hit.sh_n))
        smooth = ~bs.delta & (cos > 1e-6)
        bs.weight = np.where(smooth[:, None], bs.weight / np.where(smooth, cos, 1.0)[:, None],
                             bs.weight)
        return bs
    return buggy


INTEGRATORS = registry(mutate(path_nee.PathNEEIntegrator, path_nee, sample_bsdf=_without_cosine))
