"""The cosine counted twice in the shadow ray: path_nee multiplies eval_bsdf's value, which
is already f cos theta, by cos theta again.

Direct light is too dark, more where light arrives at grazing angles (walls) than under the
light (the floor's middle).
True cause: the BSDF value of the shadow ray (its cosine).
"""
import numpy as np
from _zoo import camera_rays, mutate, registry  # noqa: F401

from pathtracer.integrators import base, path_nee
from pathtracer.vec import dot

BUG = "shadow ray's f cos multiplied by cos again"
CHECKS = ("path_nee-cornell-box",)
CAUSE = "bsdf_eval"


def _extra_cosine(eval_bsdf):
    def buggy(scene, hit, wi, wo, *args, **kwargs):
        value, pdf = eval_bsdf(scene, hit, wi, wo, *args, **kwargs)
        return value * np.abs(dot(hit.sh_n, wo))[:, None], pdf
    return buggy


INTEGRATORS = registry(mutate(path_nee.PathNEEIntegrator, base, eval_bsdf=_extra_cosine))
