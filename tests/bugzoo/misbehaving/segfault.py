"""Misbehaving submission: segfault."""
import ctypes

from _base import camera_rays, registry  # noqa: F401  (the reference camera)


def radiance(self, scene, rays, rng):
    ctypes.string_at(0)


INTEGRATORS = registry(radiance)
