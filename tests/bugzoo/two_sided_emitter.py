"""Two-sided emitters: path_bsdf counts an area light's radiance on both of its sides,
although Mitsuba's area lights emit only on the side their normal faces.

The Cornell box light hangs 1 cm below the ceiling facing down; its back lights the ceiling
around it, which becomes too bright (top of the image).
Expected hint: emitters are one-sided.
"""
import numpy as np
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    mutate,
    registry,
)

from pathtracer.integrators import base, path_bsdf
from pathtracer.integrators.base import subset_hit
from pathtracer.vec import dot

BUG = "area lights emit on both sides"
CHECK = "path_bsdf-cornell-box"
EXPECTED = ("one-sided",)


def _two_sided(emitted_radiance):
    def buggy(scene, hit, wi):
        flipped = subset_hit(hit, np.arange(len(wi)))
        sign = np.where(dot(hit.sh_n, wi) < 0, -1.0, 1.0)
        flipped.sh_n = hit.sh_n * sign[:, None]
        return emitted_radiance(scene, flipped, wi)
    return buggy


# Emission at a hit is computed in base.Integrator.emission, for every integrator.
INTEGRATORS = registry(mutate(path_bsdf.PathBSDFIntegrator, base, emitted_radiance=_two_sided))
