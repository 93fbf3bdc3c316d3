"""Misbehaving submission: sys_exit."""
import sys

from _base import registry


def radiance(self, scene, rays, rng):
    sys.exit(0)


INTEGRATORS = registry(radiance)
