"""A depth limit one segment short: path_nee stops a path one segment before max_depth
allows (``if depth + 2 > max_depth: break``), so max_depth = 3 renders Mitsuba's max_depth = 2.

With max_depth = -1 nothing changes; at a finite max_depth the last bounce is missing.
True cause: max_depth off by one.
"""
from _zoo import camera_rays, registry  # noqa: F401

from pathtracer.integrators import path_nee

BUG = "paths end one segment before max_depth"
CHECKS = ("path_nee-lights",)
CAUSE = "depth_off_by_one"


class MutantPathNEE(path_nee.PathNEEIntegrator):
    @property
    def depth_limit(self):
        limit = super().depth_limit
        return limit - 1 if self.max_depth > 0 else limit


INTEGRATORS = registry(MutantPathNEE)
