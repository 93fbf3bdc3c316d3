"""Misbehaving submission: hang."""
import time

from _base import camera_rays, registry  # noqa: F401  (the reference camera)


def radiance(self, scene, rays, rng):
    while True:
        time.sleep(0.01)


INTEGRATORS = registry(radiance)
