"""Splats in the mirrored row: the light tracer's camera connection counts image rows from
the bottom (camera space +y up) where the film counts them from the top, so every splat of
row r lands in row H - 1 - r.

The image is upside down.
Expected hint: splats in the wrong pixel (the image matches Mitsuba's flipped upside down).
"""
import numpy as np
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    mutate_splat,
    registry,
)

from pathtracer.integrators import light

BUG = "splat row counted from the bottom of the image"
CHECK = "light-glass-lamp"
EXPECTED = ("upside down",)


def _flipped_rows(connect_to_camera):
    def buggy(camera, p):
        connection = connect_to_camera(camera, p)
        row, column = np.divmod(connection.pixel, camera.width)
        flipped = (camera.height - 1 - row) * camera.width + column
        connection.pixel = np.where(connection.pixel >= 0, flipped, -1)
        return connection
    return buggy


INTEGRATORS = registry(mutate_splat(light.LightIntegrator, light, connect_to_camera=_flipped_rows))
