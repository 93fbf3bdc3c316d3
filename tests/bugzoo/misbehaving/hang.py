"""Misbehaving submission: hang."""
import time

from _base import registry


def radiance(self, scene, rays, rng):
    while True:
        time.sleep(0.01)


INTEGRATORS = registry(radiance)
