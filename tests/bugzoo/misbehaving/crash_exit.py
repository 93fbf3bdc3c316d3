"""Misbehaving submission: crash_exit."""
import os

from _base import camera_rays, registry  # noqa: F401  (the reference camera)


def radiance(self, scene, rays, rng):
    os._exit(3)


INTEGRATORS = registry(radiance)
