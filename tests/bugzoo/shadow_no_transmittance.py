"""Shadow rays without transmittance: volpath's shadow rays pass null (index-matched)
boundaries but ignore the medium they cross (Tr = 1 instead of exp(-sigma_t d), a visibility
test where an attenuation is needed).

Everything lit through the fog is too bright: the fog itself (its single scattering sees the
light unattenuated) and the floor in the fog's shadow. volpath_phase has no shadow rays and
stays right. Expected hint: the transmittance along shadow rays.
"""
import numpy as np
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    mutate,
    patched,
    registry,
)

from pathtracer.integrators import volpath
from pathtracer.media import homogeneous as media

BUG = "shadow rays ignore the media they cross (transmittance 1 through the fog)"
CHECK = "volpath-media"
EXPECTED = ("transmittance along shadow rays",)


def _vacuum_flight(sample_free_flight):
    def buggy(scene, medium, channel, t_surface, u):
        return sample_free_flight(scene, np.full_like(medium, -1), channel, t_surface, u)
    return buggy


def _without_media(shadow_transmittance):
    def buggy(*args, **kwargs):
        # Null boundaries still let the ray through; no medium attenuates it.
        with patched(media, sample_free_flight=_vacuum_flight(media.sample_free_flight)):
            return shadow_transmittance(*args, **kwargs)
    return buggy


INTEGRATORS = registry(mutate(volpath.VolPathIntegrator, volpath,
                              shadow_transmittance=_without_media))
