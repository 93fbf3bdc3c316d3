"""Normals not flipped for back faces: path_bsdf offsets every new ray along the surface
normal as it is stored, never flipping it to the side the ray leaves on, so a ray refracted
into the glass starts just *outside* it (and a ray leaving the inside starts inside).

Diffuse scenes are unaffected (rays always leave on the front); glass is wrong.
Expected hint: the dielectric code / back-face normals.
"""
import numpy as np
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    mutate,
    registry,
)

from pathtracer.camera import Rays
from pathtracer.geometry import RAY_EPSILON, max_abs
from pathtracer.integrators import path_bsdf, wavefront

BUG = "ray origins offset along the unflipped normal"
CHECK = "path_bsdf-glass"
EXPECTED = ("back face", "back-face")


def _unflipped(spawn):
    def buggy(hit, wo):
        o = hit.p + ((1.0 + max_abs(hit.p)) * RAY_EPSILON)[:, None] * hit.n
        return Rays(o, wo, np.full(len(wo), np.inf))
    return buggy


# The paths' next rays are spawned in wavefront.Paths.next_hit.
INTEGRATORS = registry(mutate(path_bsdf.PathBSDFIntegrator, wavefront, spawn=_unflipped))
