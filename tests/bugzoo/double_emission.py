"""Emission counted twice with shadow rays: path_nee adds Le wherever a path lands, also
after a diffuse bounce whose shadow ray already counted that light (the slide's "if last
bounce not specular" rule is missing).

Direct light is about twice too bright, only in the integrator with shadow rays.
Expected hint: emission counted twice.
"""
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    mutate,
    registry,
)

from pathtracer.integrators import path_nee

BUG = "Le added after every bounce although the shadow ray already counted it"
CHECK = "path_nee-cornell-box"
EXPECTED = ("twice",)


def _always_specular(sample_bsdf):
    def buggy(*args, **kwargs):
        bs = sample_bsdf(*args, **kwargs)
        bs.delta = bs.delta | True      # "last bounce specular" everywhere: Le always counted
        return bs
    return buggy


INTEGRATORS = registry(mutate(path_nee.PathNEEIntegrator, path_nee, sample_bsdf=_always_specular))
