"""Shadow-ray transmittance with the distance squared: volpath's shadow rays attenuate by
exp(-sigma_t d^2) instead of exp(-sigma_t d) (d: the length of the ray inside the fog).

The fog's cube is smaller than one unit across, so d^2 < d: light through the fog along
shadow rays is too bright (the fog's own single scattering and the floor in its shadow).
True cause: the transmittance along shadow rays.
"""
import numpy as np
from _zoo import camera_rays, mutate, patched, registry  # noqa: F401

from pathtracer.integrators import volpath
from pathtracer.media import homogeneous as media

BUG = "shadow rays attenuated by exp(-sigma_t d^2)"
CHECKS = ("volpath-media",)
CAUSE = "shadow_transmittance"


def _squared(sample_free_flight):
    def buggy(scene, medium, channel, t_surface, u):
        inside = medium >= 0
        return sample_free_flight(scene, medium, channel,
                                  np.where(inside, t_surface ** 2, t_surface), u)
    return buggy


def _squared_transmittance(shadow_transmittance):
    def buggy(*args, **kwargs):
        with patched(media, sample_free_flight=_squared(media.sample_free_flight)):
            return shadow_transmittance(*args, **kwargs)
    return buggy


INTEGRATORS = registry(mutate(volpath.VolPathIntegrator, volpath,
                              shadow_transmittance=_squared_transmittance))
