"""A BSDF evaluated with its arguments swapped: path's shadow ray calls
eval_bsdf(scene, hit, wo, wi) (the light's direction where the camera's belongs), so the
cosine it returns is the one towards the previous vertex, and the BSDF pdf of the MIS weight
is that of the wrong direction.

Direct light is wrong unevenly (by the ratio of the two cosines).
True cause: the BSDF evaluation (its arguments).
"""
from _zoo import camera_rays, mutate, registry  # noqa: F401

from pathtracer.integrators import base, path

BUG = "eval_bsdf(scene, hit, wo, wi): wi and wo swapped in the shadow ray"
CHECKS = ("path-cornell-box", "path-lights")
CAUSE = "bsdf_eval"


def _swapped(eval_bsdf):
    def buggy(scene, hit, wi, wo, *args, **kwargs):
        return eval_bsdf(scene, hit, wo, wi, *args, **kwargs)
    return buggy


INTEGRATORS = registry(mutate(path.PathIntegrator, base, eval_bsdf=_swapped))
