"""No emission after a specular bounce: path_nee adds Le only where the camera ray lands,
never after a mirror or glass bounce ("prevent double counting" applied to every bounce,
although a Dirac bounce's vertex sends no shadow ray, so nothing else counts that light).

All-diffuse scenes are unaffected; with a mirror and a glass sphere (cornell-caustics) the
light's reflection in the mirror and the caustic under the glass are missing.
Expected hint: emission after a specular bounce (glass / mirror check).
"""
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    mutate,
    registry,
)

from pathtracer.integrators import path_nee

BUG = "Le never added after a specular bounce"
CHECK = "path_nee-glass"
EXPECTED = ("emission after a specular bounce",)


def _never_specular(sample_bsdf):
    def buggy(*args, **kwargs):
        bs = sample_bsdf(*args, **kwargs)
        bs.delta = bs.delta & False     # "last bounce specular" never true after the camera
        return bs
    return buggy


INTEGRATORS = registry(mutate(path_nee.PathNEEIntegrator, path_nee, sample_bsdf=_never_specular))
