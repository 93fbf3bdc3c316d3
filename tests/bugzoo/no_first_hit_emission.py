"""Emission missed on the first hit: the MIS path tracer only adds Le at vertices reached by
a bounce, so light sources seen directly by the camera are black.

Only bounce 1 (directly visible emitters) is wrong.
Expected hint: directly visible light / emission on the first hit.
"""
import numpy as np
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    registry,
)

from pathtracer.integrators import base, path

BUG = "Le not added when the camera ray hits a light"
CHECK = "path-cornell-box"
EXPECTED = ("first hit",)


def _skip_first(emitted_radiance):
    calls = {"n": 0}

    def buggy(scene, hit, wi):
        calls["n"] += 1
        value = emitted_radiance(scene, hit, wi)
        return np.zeros_like(value) if calls["n"] == 1 else value
    return buggy


class Mutant(path.PathIntegrator):
    def radiance(self, scene, rays, rng):
        from _mutate import patched
        # Emission at a hit is computed in base.Integrator.emission, for every integrator.
        with patched(base, emitted_radiance=_skip_first(base.emitted_radiance)):
            return super().radiance(scene, rays, rng)


INTEGRATORS = registry(Mutant)
