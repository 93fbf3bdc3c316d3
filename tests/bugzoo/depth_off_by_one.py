"""max_depth off by one: path_nee continues while ``depth < max_depth`` instead of
``depth + 1 < max_depth``, so its paths have one segment more than max_depth allows (at
max_depth = 3 it adds the second indirect bounce).

Invisible at max_depth = -1 (unlimited); graded at max_depth = 3, where the image is too
bright, and where its render at max_depth = d matches Mitsuba's at d + 1.
Expected hint: max_depth off by one.
"""
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    registry,
)

from pathtracer.integrators import path_nee

BUG = "one path segment more than max_depth"
CHECK = "path_nee-lights"
EXPECTED = ("off by one",)


class Mutant(path_nee.PathNEEIntegrator):
    @property
    def depth_limit(self):
        # The loop stops when depth + 1 >= depth_limit: one more segment than asked for.
        return super().depth_limit + (1 if self.max_depth > 0 else 0)


INTEGRATORS = registry(Mutant)
