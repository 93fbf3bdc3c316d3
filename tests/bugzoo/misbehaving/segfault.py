"""Misbehaving submission: segfault."""
import ctypes

from _base import registry


def radiance(self, scene, rays, rng):
    ctypes.string_at(0)


INTEGRATORS = registry(radiance)
