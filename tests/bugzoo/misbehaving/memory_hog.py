"""Misbehaving submission: memory_hog."""
import numpy as np

from _base import registry


def radiance(self, scene, rays, rng):
    hog = np.ones((1 << 30,))
    return np.zeros((len(rays), 3)) + hog[0]


INTEGRATORS = registry(radiance)
