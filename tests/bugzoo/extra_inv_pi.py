"""An extra 1/pi in the diffuse BRDF: path_nee evaluates the BRDF for its shadow rays as
rho / pi^2 (the 1/pi applied twice).

Direct light (bounce 2) is darker by a factor near pi.
Expected hint: darker by a factor near pi, an extra 1/pi.
"""
import numpy as np
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    mutate,
    registry,
)

from pathtracer.integrators import base, path_nee

BUG = "diffuse BRDF divided by pi twice in the shadow-ray term"
CHECK = "path_nee-cornell-box"
EXPECTED = ("1/pi",)


def _extra_pi(eval_bsdf):
    def buggy(*args, **kwargs):
        value, pdf = eval_bsdf(*args, **kwargs)
        return value / np.pi, pdf
    return buggy


# The shadow ray's BSDF value is evaluated in base.Integrator.sample_direct.
INTEGRATORS = registry(mutate(path_nee.PathNEEIntegrator, base, eval_bsdf=_extra_pi))
