r"""Mitsuba's ``orthographic`` sensor: parallel rays from a rectangle of the camera plane.

A pixel sample's film position :math:`s = ((c + u) / W, (r + v) / H)` becomes the
camera-space point on the near plane

.. math:: p_{cam} = (1 - 2 s_x,\; (1 - 2 s_y) / a,\; z_{near}), \qquad a = W / H,

so the film covers :math:`[-1, 1] \times [-1/a, 1/a]` of camera space (+x to the left of
the image, +y up, as for the perspective camera). The ray starts at ``to_world p_cam``
along the normalised ``to_world (0, 0, 1)``, for ``far_clip - near_clip`` (Mitsuba's
``OrthographicCamera::sample_ray``). Unlike the perspective camera, ``to_world`` may scale:
that is how a file sizes the visible rectangle.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.rays import Rays
from ..core.vec import normalize
from ..scene.properties import Props, children
from ..scene.registry import register
from .perspective_sensor import SENSOR_CHILDREN, Camera, film_and_sampler, read_clip


@dataclass
class OrthographicCamera(Camera):
    """The orthographic sensor (``x_fov`` is not used: NaN)."""

    kind = "orthographic"
    pinhole = False

    def film_points(self, pixel: np.ndarray, u_film: np.ndarray) -> np.ndarray:
        """Camera-space points (n, 3) on the near plane of the film positions of the samples."""
        s_x = (pixel % self.width + u_film[:, 0]) / self.width
        s_y = (pixel // self.width + u_film[:, 1]) / self.height
        aspect = self.width / self.height
        return np.stack((1.0 - 2.0 * s_x, (1.0 - 2.0 * s_y) / aspect,
                         np.full(len(s_x), self.near_clip)), axis=1)

    def sample_rays(self, pixel: np.ndarray, u_film: np.ndarray, rng=None) -> Rays:
        """Primary rays of the samples (flat pixel indices, positions in the pixel); no
        random numbers beyond ``u_film``."""
        linear, origin = self.to_world[:3, :3], self.to_world[:3, 3]
        o = self.film_points(pixel, u_film) @ linear.T + origin
        d = np.broadcast_to(normalize(linear[:, 2][None, :]), o.shape).copy()
        return Rays(o, d, np.full(len(o), self.far_clip - self.near_clip))


@register("sensor", "orthographic")
def create(props: Props) -> tuple[Camera, int, int]:
    """``to_world`` (scaling allowed), ``near_clip``, ``far_clip``; film and sampler as for
    the perspective sensor."""
    plugin = props.plugin
    kids = children(plugin, SENSOR_CHILDREN)
    width, height, rfilter, spp, seed = film_and_sampler(plugin, kids, props.resolution, props.spp)
    to_world = props.transform("to_world")
    if abs(np.linalg.det(to_world[:3, :3])) < 1e-300:
        raise plugin.error("the orthographic camera's to_world is singular", props.line("to_world"))
    near, far = read_clip(plugin, props)
    props.ignore("shutter_open", "shutter_close")
    props.finish()
    camera = OrthographicCamera(to_world=to_world, x_fov=float("nan"), near_clip=near,
                                far_clip=far, width=width, height=height, rfilter=rfilter)
    return camera, spp, seed
