"""Random numbers reused across samples: path_bsdf gives every path of a batch the same
random stream (as if ``np.random.seed(0)`` were called for every sample), so the samples of a
pixel follow the same bounces and averaging more of them barely reduces the error.

Expected hint: the error does not fall with more samples: same random numbers reused.
"""
import numpy as np
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    registry,
)

from pathtracer.integrators import path_bsdf
from pathtracer.rng import RandomStream

BUG = "one random stream shared by every sample"
CHECK = "path_bsdf-cornell-box"
EXPECTED = ("reused",)


class Mutant(path_bsdf.PathBSDFIntegrator):
    def radiance(self, scene, rays, rng):
        shared = RandomStream(np.full(len(rng), np.uint64(12345)), rng.counter)
        return super().radiance(scene, rays, shared)


INTEGRATORS = registry(Mutant)
