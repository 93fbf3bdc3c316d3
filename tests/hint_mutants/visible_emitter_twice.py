"""A directly visible emitter counted twice: path adds Le of the camera ray's first hit once
before its loop and again in the loop's first pass (the emission step runs on every segment,
the camera's included).

Only what the camera sees directly changes: the light's own pixels are twice as bright.
True cause: the emission seen directly from the camera (max_depth = 1).
"""
import numpy as np
from _zoo import camera_rays, registry  # noqa: F401

from pathtracer.integrators import path

BUG = "Le of the camera ray's hit added twice (before the loop and in its first pass)"
CHECKS = ("path-cornell-box", "path-lights")
CAUSE = "visible_emission"


class MutantPath(path.PathIntegrator):
    def emission(self, scene, hit, wi, depth):
        Le = super().emission(scene, hit, wi, depth)
        twice = np.where(np.asarray(depth) == 0, 2.0, 1.0)
        return Le * np.reshape(twice, (-1, 1) if np.ndim(twice) else ())


INTEGRATORS = registry(MutantPath)
