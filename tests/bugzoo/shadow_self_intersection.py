"""Shadow-ray self-intersection: path_nee traces the shadow ray from the hit point itself
(no offset along the normal) all the way to the light (not stopped short of it), so the
ray often hits its own surface or the light and the point counts as shadowed.

Direct light (bounce 2) is too dark, in a noisy way.
Expected hint: shadow rays blocked by self-intersection.
"""
import numpy as np
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    mutate,
    registry,
)

from pathtracer import geometry
from pathtracer.integrators import base, path_nee

BUG = "shadow rays start on the surface and end on the light: they hit themselves"
CHECK = "path_nee-cornell-box"
EXPECTED = ("self-intersection",)


def _no_offset(sample_emitter):
    def buggy(scene, hit, u_choice, u, test_visibility=True, emitter=None):
        sample = sample_emitter(scene, hit, u_choice, u, test_visibility=False, emitter=emitter)
        live = np.flatnonzero(np.any(sample.weight > 0, axis=1) & np.isfinite(sample.dist))
        if len(live):
            p = hit.p[live].astype(np.float32).astype(np.float64)   # float32 positions
            blocked = geometry.occluded(scene, p, sample.wo[live], sample.dist[live])
            sample.weight[live[blocked]] = 0.0
        return sample
    return buggy


# Shadow rays are sampled in base.Integrator.sample_direct.
INTEGRATORS = registry(mutate(path_nee.PathNEEIntegrator, base, sample_emitter=_no_offset))
