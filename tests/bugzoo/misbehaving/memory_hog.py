"""Misbehaving submission: memory_hog."""
import numpy as np
from _base import camera_rays, registry  # noqa: F401  (the reference camera)


def radiance(self, scene, rays, rng):
    hog = np.ones((1 << 30,))
    return np.zeros((len(rays), 3)) + hog[0]


INTEGRATORS = registry(radiance)
