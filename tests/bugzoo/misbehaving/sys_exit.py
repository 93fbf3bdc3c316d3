"""Misbehaving submission: sys_exit."""
import sys

from _base import camera_rays, registry  # noqa: F401  (the reference camera)


def radiance(self, scene, rays, rng):
    sys.exit(0)


INTEGRATORS = registry(radiance)
