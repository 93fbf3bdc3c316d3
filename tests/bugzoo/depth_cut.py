"""Fixed depth cut: path_bsdf stops every path after 4 segments although max_depth = -1
(unlimited), e.g. ``for depth in range(4)`` instead of Russian roulette.

Bounces 1-3 are right; light of longer paths is missing, the image is too dark.
Expected hint: bias in long paths (a depth cut or roulette without 1/q).
"""
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    registry,
)

from pathtracer.integrators import path_bsdf

BUG = "paths cut after 4 segments"
CHECK = "path_bsdf-cornell-box"
EXPECTED = ("depth cut",)


class Mutant(path_bsdf.PathBSDFIntegrator):
    @property
    def depth_limit(self):
        return min(super().depth_limit, 4)


INTEGRATORS = registry(Mutant)
