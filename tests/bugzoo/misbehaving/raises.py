"""Misbehaving submission: raises."""
import numpy as np

from _base import registry


def radiance(self, scene, rays, rng):
    raise ValueError('student bug: index out of range')


INTEGRATORS = registry(radiance)
