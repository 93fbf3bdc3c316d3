"""Light paths sampled with the radiance BSDF: the light tracer continues its paths with
``sample_bsdf(..., adjoint=False)``, so every refraction scales the light path's weight by
the radiance factor 1/eta'^2, which importance does not have.

Paths that enter and leave closed glass from the same side lose nothing (the two factors
cancel); light that starts inside glass and leaves it is eta^2 = 2.26x too bright: in
``glass-lamp`` the red channel (the lamp inside the glass sphere) only.
Expected hint: the light leaving glass is off by eta^2; the adjoint BSDF.
"""
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    mutate_splat,
    registry,
)

from pathtracer.integrators import light

BUG = "light paths refract with the radiance scaling 1/eta^2 (non-adjoint BSDF)"
CHECK = "light-glass-lamp"
EXPECTED = ("eta^2",)


def _radiance_bsdf(sample_bsdf):
    def buggy(scene, hit, wi, u1, u2, hemisphere="cosine", adjoint=False):
        return sample_bsdf(scene, hit, wi, u1, u2, hemisphere, adjoint=False)
    return buggy


INTEGRATORS = registry(mutate_splat(light.LightIntegrator, light, sample_bsdf=_radiance_bsdf))
