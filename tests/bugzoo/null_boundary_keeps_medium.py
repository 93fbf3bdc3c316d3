"""Medium ignored at index-matched boundaries: a path that crosses a null BSDF (eta = 1,
the fog's boundary) keeps the medium it was in; the medium is updated only where a real
BSDF lobe was sampled (reflection, refraction at a dielectric).

Camera paths never enter the fog of an index-matched cube: it vanishes from the image
(shadow rays, a building block, still see it: its shadow stays on the floor).
Expected hint: medium tracking at null boundaries.
"""
import numpy as np
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    mutate,
    registry,
)

from pathtracer.integrators import volpath_phase
from pathtracer.media import null_event

BUG = "the medium is not updated when a path crosses a null (index-matched) boundary"
CHECK = "volpath_phase-media"
EXPECTED = ("null boundar",)


def _not_at_null(next_medium):
    def buggy(scene, hit, medium, d):
        crossed_null = null_event(scene, hit, -d, d)      # a straight crossing of a null lobe
        return np.where(crossed_null, medium, next_medium(scene, hit, medium, d))
    return buggy


INTEGRATORS = registry(mutate(volpath_phase.VolPathPhaseIntegrator, volpath_phase,
                              next_medium=_not_at_null))
