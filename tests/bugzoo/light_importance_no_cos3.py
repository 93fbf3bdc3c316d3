"""Camera importance without the cos^3: the light tracer weights its splats with
We = 1 / A (the film's area density on the plane at distance 1) instead of the solid-angle
importance We = 1 / (A cos^3 theta).

Every splat away from the optical axis is too dark, by cos^3 theta (x0.64 in the corners of
``glass-lamp``'s 4:3 film).
Expected hint: camera importance; the ratio follows cos theta.
"""
import numpy as np
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    mutate_splat,
    registry,
)

from pathtracer.integrators import light

BUG = "camera importance 1 / A instead of 1 / (A cos^3 theta)"
CHECK = "light-glass-lamp"
EXPECTED = ("importance",)


def _without_cos3(connect_to_camera):
    def buggy(camera, p):
        connection = connect_to_camera(camera, p)
        forward = camera.to_world[:3, 2] / np.linalg.norm(camera.to_world[:3, 2])
        cos = np.clip(-(connection.wi @ forward), 0.0, 1.0)
        connection.importance = connection.importance * cos ** 3
        return connection
    return buggy


INTEGRATORS = registry(mutate_splat(light.LightIntegrator, light, connect_to_camera=_without_cos3))
