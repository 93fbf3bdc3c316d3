"""Camera that ignores the film sample: every ray goes through its pixel's centre
(s = (column + 0.5) / W, (row + 0.5) / H) whatever ``u_film`` says.

A pixel's samples then all see the same point: the box filter's average over the pixel
becomes a point sample (aliased edges). In cornell-lights the wall light's edges sit at
0.45 / 0.55 of a pixel, so it is drawn 5 x 5 pixels instead of 4.1 x 4.1.
Expected hint: the film sample (position inside the pixel) is ignored.
"""
import numpy as np
from _mutate import registry

from pathtracer.camera import camera_rays as reference_camera

BUG = "u_film ignored: all rays through the pixel centre"
CHECK = "camera"
EXPECTED = ("film sample",)


def camera_rays(camera, pixel, u_film):
    return reference_camera(camera, pixel, np.full_like(u_film, 0.5))


INTEGRATORS = registry()
