"""Mirrored camera: the film's x axis runs the wrong way (x = (2 s_x - 1) tan(fov/2), as if
camera-space +x pointed to the image's right), so the image is mirrored left-right.

In a left-right symmetric scene nothing changes; in cornell-lights the red wall, the wall
light and the boxes change sides.
Expected hint: the image is mirrored.
"""
from _mutate import registry

from pathtracer.camera import camera_rays as reference_camera

BUG = "film x axis flipped: image mirrored left-right"
CHECK = "camera"
EXPECTED = ("mirrored",)


def camera_rays(camera, pixel, u_film):
    width = camera.width
    column, row = pixel % width, pixel // width
    # s_x -> 1 - s_x: the reference camera through the mirrored film position.
    mirrored = row * width + (width - 1 - column)
    u = u_film.copy()
    u[:, 0] = 1.0 - u[:, 0]
    return reference_camera(camera, mirrored, u)


INTEGRATORS = registry()
