"""The full field of view where the half angle belongs: the camera scales its film by
tan(fov) instead of tan(fov / 2), so the image is zoomed out.

True cause: the camera's field of view.
"""
import numpy as np
from _zoo import registry

from pathtracer.camera import Rays
from pathtracer.vec import normalize

BUG = "tan(fov) instead of tan(fov / 2)"
CHECKS = ("camera",)
CAUSE = "camera_fov"


def camera_rays(camera, pixel, u_film):
    width, height = camera.width, camera.height
    s_x = (pixel % width + u_film[:, 0]) / width
    s_y = (pixel // width + u_film[:, 1]) / height
    tan_fov = np.tan(np.radians(camera.x_fov))                         # the bug
    d_cam = np.stack(((1 - 2 * s_x) * tan_fov, (1 - 2 * s_y) * tan_fov * height / width,
                      np.ones_like(s_x)), axis=1)
    d_cam = normalize(d_cam)
    inv_z = 1.0 / d_cam[:, 2]
    near_t, far_t = camera.near_clip * inv_z, camera.far_clip * inv_z
    rotation, origin = camera.to_world[:3, :3], camera.to_world[:3, 3]
    d = normalize(d_cam @ rotation.T)
    return Rays(origin + d * near_t[:, None], d, far_t - near_t)


INTEGRATORS = registry()
