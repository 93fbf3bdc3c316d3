"""A shadow ray spawned without an offset: direct traces its shadow rays from the hit point
itself (the origin is not pushed off the surface along the normal; the ray still stops just
short of the light), so some of them hit their own surface.

Measured: the image is off by only +0.2 %, but locally (largest tile |z| = 33, bottom left);
the 64-spp sweep does not resolve it. ``direct`` has no Russian roulette and no paths beyond
max_depth = 2, so no long-path cause applies. True cause: shadow-ray self-intersection.
"""
import numpy as np
from _zoo import camera_rays, mutate, registry  # noqa: F401

from pathtracer.emitters import scene_emitters
from pathtracer.integrators import direct

BUG = "shadow rays start exactly on the surface (no offset along the normal)"
CHECKS = ("direct-cornell-box",)
CAUSE = "self_intersection"


def _no_offset(shadowed):
    def buggy(scene, p, n, wo, dist):
        p32 = np.asarray(p, np.float32).astype(np.float64)    # positions kept in float32
        return shadowed(scene, p32, np.zeros_like(n), wo, dist)
    return buggy


INTEGRATORS = registry(mutate(direct.DirectIntegrator, scene_emitters, shadowed=_no_offset))
