"""Mitsuba's ``perspective`` sensor: primary rays for a batch of pixel samples.

A pixel sample (column + u, row + v), u, v uniform in [0, 1), becomes the film
position s = ((column + u) / W, (row + v) / H). In camera space (+z forward,
+y up, +x to the *left* of the image) the point on the plane z = 1 is

    x = (1 - 2 s_x) tan(x_fov / 2),   y = (1 - 2 s_y) tan(x_fov / 2) / aspect,

(s moved by the principal point offset, when the file gives one),

the ray starts where it crosses the near plane and ends at the far plane,
exactly as Mitsuba's ``PerspectiveCamera::sample_ray``.
"""
from __future__ import annotations

import numpy as np

# Rays is also a name of this module: the student contract imports it from here
# (``from pathtracer.camera import Rays``, autograder/contract.py).
from ..core.rays import Rays
from ..core.vec import normalize
from .perspective_sensor import Camera


def camera_rays(camera: Camera, pixel: np.ndarray, u_film: np.ndarray) -> Rays:
    """Primary rays through pixels ``pixel`` (flat index row * W + column).

    Parameters
    ----------
    camera : Camera
    pixel : (n,) int
        Flat pixel indices, row 0 at the top of the image.
    u_film : (n, 2) float
        Uniform position of the sample inside its pixel.
    """
    width, height = camera.width, camera.height
    offset_x, offset_y = camera.principal_point     # Mitsuba's principal_point_offset
    s_x = (pixel % width + u_film[:, 0]) / width + offset_x
    s_y = (pixel // width + u_film[:, 1]) / height + offset_y
    tan_half = np.tan(np.radians(camera.x_fov) / 2)
    d_cam = np.stack((
        (1 - 2 * s_x) * tan_half,
        (1 - 2 * s_y) * tan_half * height / width,
        np.ones_like(s_x)), axis=1)
    d_cam = normalize(d_cam)
    # Clip distances are along the optical axis: t = clip / cos(angle to axis).
    inv_z = 1.0 / d_cam[:, 2]
    near_t, far_t = camera.near_clip * inv_z, camera.far_clip * inv_z
    rotation, origin = camera.to_world[:3, :3], camera.to_world[:3, 3]
    d = normalize(d_cam @ rotation.T)
    o = origin + d * near_t[:, None]
    return Rays(o, d, far_t - near_t)


