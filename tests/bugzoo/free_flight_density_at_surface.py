"""Free-flight pdf wrong: when the sampled distance falls beyond the next surface, the
throughput is divided by the *density* sigma_t exp(-sigma_t s) of stopping there instead
of the *probability* exp(-sigma_t s) of getting that far (beta *= T(s) / (sigma_t T(s))).

Every path segment that leaves the fog through its boundary (or sees a wall through it) is
scaled by 1 / sigma_t = 1 / 1.5: the walls seen through the fog and everything the fog
lights are too dark. Expected hint: the free-flight pdf (probability of reaching the surface).
"""
import numpy as np
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    mutate,
    registry,
)

from pathtracer.integrators import volpath, volpath_phase

BUG = "surface reached through a medium divided by the free-flight density, not its probability"
CHECK = "volpath-media"
EXPECTED = ("free-flight",)


def _density_at_surface(sample_free_flight):
    def buggy(scene, medium, channel, t_surface, u):
        flight = sample_free_flight(scene, medium, channel, t_surface, u)
        rows = np.flatnonzero((medium >= 0) & ~flight.scattered)
        sigma_t = np.array([m.sigma_t for m in scene.media]).reshape(-1, 3)
        sigma_c = sigma_t[medium[rows], channel[rows]]
        flight.weight[rows] /= sigma_c[:, None]
        return flight
    return buggy


# The segment loop (radiance) is volpath_phase's, which volpath inherits.
INTEGRATORS = registry(mutate(volpath.VolPathIntegrator, volpath_phase,
                              sample_free_flight=_density_at_surface))
