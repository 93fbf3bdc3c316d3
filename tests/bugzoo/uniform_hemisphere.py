"""Uniform hemisphere sampling (correctly weighted): path_nee draws indirect directions
uniformly with p = 1/(2 pi). The mean is right, but the cosine of the integrand is not
followed, so the variance is higher than that of Mitsuba's estimator (cosine sampling).

Partial credit: the mean part passes, the variance part fails.
Expected hint: mean right, variance higher: the sampling pdf does not follow the cosine.
"""
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    registry,
)

from pathtracer.integrators import path_nee

BUG = "uniform instead of cosine-weighted hemisphere sampling"
CHECK = "path_nee-cornell-box"
EXPECTED = ("cosine",)
PARTIAL = True


class Mutant(path_nee.PathNEEIntegrator):
    def __init__(self, **options):
        super().__init__(**options)
        self.hemisphere = "uniform"


INTEGRATORS = registry(Mutant)
