"""Russian roulette without 1/q: paths survive with probability q but their throughput is
not divided by q, so long paths lose energy.

Bounces 1-3 are right (roulette starts at depth 5); the full image is too dark.
Expected hint: bias from roulette without dividing by its probability (or a depth cut).
"""
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    registry,
)

from pathtracer.integrators import path

BUG = "survivors of Russian roulette not divided by the survival probability"
CHECK = "path-cornell-box"
EXPECTED = ("roulette",)


class Mutant(path.PathIntegrator):
    def roulette_survivors(self, beta, eta, depth, u):
        survive, _ = super().roulette_survivors(beta, eta, depth, u)
        return survive, beta


INTEGRATORS = registry(Mutant)
