r"""Mitsuba's ``thinlens`` sensor: a perspective camera with a lens of finite aperture
(depth of field).

The film position gives the point :math:`p_{near}` on the near plane as for the
perspective camera (:mod:`pathtracer.sensors.perspective`); the point it sees in focus
lies on the plane :math:`z = d_f` (``focus_distance``, default ``far_clip``):
:math:`p_f = p_{near}\, d_f / z_{near}`. A uniform point of the lens disk
(concentric map, radius ``aperture_radius``) :math:`p_a = (r x, r y, 0)` sends the ray

.. math:: d = \frac{p_f - p_a}{\lVert p_f - p_a \rVert}, \qquad
          o = p_a + d\, \frac{z_{near}}{d_z}, \qquad t_{max} = \frac{z_{far} - z_{near}}{d_z},

in camera space, then through ``to_world`` (Mitsuba's ``ThinLensCamera::sample_ray``).
Points on the focal plane are sharp; elsewhere the lens blurs them over a circle of
confusion. The weight of every ray is 1 (uniform lens and film sampling, the importance
divided by its own pdf), so the estimator is the perspective camera's, averaged over the
lens.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.rays import Rays
from ..core.sampling import square_to_uniform_disk_concentric
from ..core.vec import normalize
from ..scene.properties import Props
from ..scene.registry import register
from .perspective_sensor import Camera, no_principal_point_offset, read_perspective

#: Mitsuba replaces a zero aperture by float32's epsilon (with a warning).
MIN_APERTURE = float(np.finfo(np.float32).eps)


@dataclass
class ThinLensCamera(Camera):
    """The thin-lens sensor: the perspective camera's fields, the lens radius and the
    distance of the plane in focus."""

    aperture_radius: float = MIN_APERTURE
    focus_distance: float = 1e4

    kind = "thinlens"
    pinhole = False

    def near_points(self, pixel: np.ndarray, u_film: np.ndarray) -> np.ndarray:
        """Camera-space points (n, 3) on the near plane of the samples' film positions."""
        s_x = (pixel % self.width + u_film[:, 0]) / self.width
        s_y = (pixel // self.width + u_film[:, 1]) / self.height
        tan_half = np.tan(np.radians(self.x_fov) / 2)
        return self.near_clip * np.stack((
            (1 - 2 * s_x) * tan_half, (1 - 2 * s_y) * tan_half * self.height / self.width,
            np.ones_like(s_x)), axis=1)

    def lens_rays(self, pixel: np.ndarray, u_film: np.ndarray, u_lens: np.ndarray) -> Rays:
        """The rays of film positions ``u_film`` in their pixels through lens points
        ``u_lens`` (n, 2, uniform in the unit square)."""
        near_p = self.near_points(pixel, u_film)
        focus_p = near_p * (self.focus_distance / self.near_clip)
        lens = self.aperture_radius * square_to_uniform_disk_concentric(u_lens)
        aperture_p = np.column_stack((lens, np.zeros(len(lens))))
        d_cam = normalize(focus_p - aperture_p)
        inv_z = 1.0 / d_cam[:, 2]
        near_t, far_t = self.near_clip * inv_z, self.far_clip * inv_z
        linear, origin = self.to_world[:3, :3], self.to_world[:3, 3]
        d = d_cam @ linear.T
        o = aperture_p @ linear.T + origin + d * near_t[:, None]
        return Rays(o, d, far_t - near_t)

    def sample_rays(self, pixel: np.ndarray, u_film: np.ndarray, rng) -> Rays:
        """Primary rays: the lens point takes the samples' next two random numbers."""
        return self.lens_rays(pixel, u_film, rng.next_2d())


@register("sensor", "thinlens")
def create(props: Props) -> tuple[Camera, int, int]:
    """The perspective sensor's parameters, ``aperture_radius`` (required) and
    ``focus_distance`` (default ``far_clip``)."""
    plugin = props.plugin
    frame, spp, seed = read_perspective(props)
    no_principal_point_offset(props.plugin, props)
    far = frame["far_clip"]
    if not props.has("aperture_radius"):
        raise plugin.error("a thinlens sensor needs aperture_radius (as in Mitsuba)")
    radius = props.float("aperture_radius", None)
    if not radius >= 0.0:
        raise plugin.error(f"aperture_radius must be >= 0, got {radius:g}", props.line("aperture_radius"))
    focus = props.float("focus_distance", far)
    if not focus > 0.0:
        raise plugin.error(f"focus_distance must be > 0, got {focus:g}", props.line("focus_distance"))
    props.ignore("shutter_open", "shutter_close")
    props.finish()
    camera = ThinLensCamera(**frame, aperture_radius=max(radius, MIN_APERTURE),
                            focus_distance=focus)
    return camera, spp, seed
