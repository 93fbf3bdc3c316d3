"""Uniform hemisphere directions divided by the cosine pdf: the path tracer with MIS draws
directions uniformly on the hemisphere but weights (and MIS-weights) them as if they were
cosine-distributed (p = cos/pi instead of 1/(2 pi)).

The estimator is biased: grazing directions get the weight of frequent ones.
Expected hint: the BSDF sampling weight / pdf does not match how directions are drawn.
"""
import numpy as np
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    mutate,
    registry,
)

from pathtracer.integrators import path
from pathtracer.vec import dot

BUG = "directions drawn uniformly, weighted with the cosine pdf"
CHECK = "path-cornell-box"
EXPECTED = ("pdf",)


def _uniform_as_cosine(sample_bsdf):
    def buggy(scene, hit, wi, u1, u2, hemisphere="cosine"):
        bs = sample_bsdf(scene, hit, wi, u1, u2, "uniform")
        cos = np.maximum(dot(bs.wo, hit.sh_n), 0.0)
        smooth = ~bs.delta & (bs.pdf > 0)
        # uniform weight is 2 cos f/(...) = rho * 2 cos; the cosine-pdf weight would be rho
        fix = np.where(smooth & (cos > 0), 1.0 / np.maximum(2.0 * cos, 1e-300), 1.0)
        bs.weight = bs.weight * fix[:, None]
        bs.pdf = np.where(smooth, cos / np.pi, bs.pdf)
        return bs
    return buggy


INTEGRATORS = registry(mutate(path.PathIntegrator, path, sample_bsdf=_uniform_as_cosine))
