"""Wrong field-of-view axis: the camera applies the horizontal field of view to the vertical
axis (tan(fov/2) on y, the x extent scaled by the aspect ratio), so a 4:3 image is zoomed out.

Expected hint: the camera's field of view / fov axis.
"""
import numpy as np
from _mutate import registry

from pathtracer.camera import Rays
from pathtracer.vec import normalize

BUG = "x field of view applied to the y axis"
CHECK = "camera"
EXPECTED = ("field of view",)


def camera_rays(camera, pixel, u_film):
    width, height = camera.width, camera.height
    s_x = (pixel % width + u_film[:, 0]) / width
    s_y = (pixel // width + u_film[:, 1]) / height
    tan_half = np.tan(np.radians(camera.x_fov) / 2)
    d_cam = np.stack(((1 - 2 * s_x) * tan_half * width / height,     # the bug
                      (1 - 2 * s_y) * tan_half,
                      np.ones_like(s_x)), axis=1)
    d_cam = normalize(d_cam)
    inv_z = 1.0 / d_cam[:, 2]
    near_t, far_t = camera.near_clip * inv_z, camera.far_clip * inv_z
    rotation, origin = camera.to_world[:3, :3], camera.to_world[:3, 3]
    d = normalize(d_cam @ rotation.T)
    return Rays(origin + d * near_t[:, None], d, far_t - near_t)


INTEGRATORS = registry()
