"""Phase pdf not cancelled: after sampling a direction from the phase function, the
throughput is multiplied by the phase function's value p (as if it were a BSDF's f cos),
without dividing by the pdf it was sampled with (which is p itself: the weight is 1).

Light that reaches the camera after scattering in the fog is scaled by p (~0.1-0.5 per
scattering event for Henyey-Greenstein g = 0.5): the fog is far too dark.
Expected hint: the phase function's value over its pdf is 1.
"""
import numpy as np
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    registry,
)

from pathtracer.integrators import volpath_phase
from pathtracer.integrators.volume import SLOT_DIRECTION, move
from pathtracer.media import phase_sample

BUG = "phase-sampled direction weighted by the phase value p, not p / pdf = 1"
CHECK = "volpath_phase-media"
EXPECTED = ("pdf cancels",)


class MutantVolPathPhase(volpath_phase.VolPathPhaseIntegrator):
    def in_medium(self, scene, paths, rows, t, segment, L):
        x = paths.o[rows] + t[:, None] * paths.d[rows]
        paths.depth[rows] += 1
        wo, pdf = phase_sample(scene, paths.medium[rows], -paths.d[rows],
                               self.uniform(paths, segment, SLOT_DIRECTION, 2)[rows])
        paths.beta[rows] *= pdf[:, None]          # the bug: beta *= p, without / pdf
        move(paths, rows, x, np.zeros_like(x), wo)
        return (paths.depth[rows] < self.depth_limit) & (pdf > 0)


INTEGRATORS = registry(MutantVolPathPhase)
