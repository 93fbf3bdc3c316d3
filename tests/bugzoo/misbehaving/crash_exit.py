"""Misbehaving submission: crash_exit."""
import os

from _base import registry


def radiance(self, scene, rays, rng):
    os._exit(3)


INTEGRATORS = registry(radiance)
