"""The free-flight pdf without sigma_t: volpath_phase weights a scattering event by
T sigma_s / exp(-sigma_t t), the probability of getting that far, instead of dividing by the
density sigma_t exp(-sigma_t t): each scattering is weighted sigma_s instead of the albedo.

True cause: the free-flight pdf.
"""
import numpy as np
from _zoo import camera_rays, mutate, registry  # noqa: F401

from pathtracer.integrators import volpath_phase
from pathtracer.media import homogeneous as media

BUG = "scattering weight T sigma_s / exp(-sigma_t t): the free-flight density lacks sigma_t"
CHECKS = ("volpath_phase-media",)
CAUSE = "free_flight_pdf"


def _without_sigma(sample_free_flight):
    def buggy(scene, medium, channel, t_surface, u):
        flight = sample_free_flight(scene, medium, channel, t_surface, u)
        rows = np.flatnonzero(flight.scattered)
        if len(rows):
            sigma_t, _ = media._coefficients(scene)
            sigma_c = np.take_along_axis(sigma_t[medium[rows]], channel[rows, None], axis=1)
            flight.weight[rows] = flight.weight[rows] * sigma_c
        return flight
    return buggy


INTEGRATORS = registry(mutate(volpath_phase.VolPathPhaseIntegrator, volpath_phase,
                              sample_free_flight=_without_sigma))
