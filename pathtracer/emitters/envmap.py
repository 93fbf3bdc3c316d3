r"""Mitsuba's ``envmap`` emitter: an image of radiance on the sphere at infinity.

Mapping (Mitsuba 3's latitude-longitude convention, in the emitter's local
frame; ``to_world`` rotates it into the scene):

* :math:`u = \operatorname{atan2}(d_x, -d_z) / 2\pi`, so u = 0 looks along
  -z and u grows towards +x; :math:`v = \arccos(d_y) / \pi`, so the top row
  of the image (v = 0) is straight up (+y), the bottom row straight down;
* pixel column i is centred at :math:`u = (i + \tfrac12) / W` and wraps
  around; pixel row j sits at :math:`v = j / (H - 1)` (the first and last
  rows *are* the poles);
* radiance is interpolated bilinearly between the four nearest pixels and
  multiplied by ``scale``.

Importance sampling: the vertex grid of that interpolant (W + 1 columns,
the first repeated at the end, H rows) weighted by the luminance of each
pixel times :math:`\sin\theta` of its row is a :class:`~pathtracer.core.sampling.Distribution2D`;
a sampled :math:`(x, y)` maps to :math:`(u, v) = (x + \tfrac{1}{2W}, y)` and the
solid-angle density is :math:`p(x, y) / (2 \pi^2 \sin\theta)`, where
:math:`d\omega = 2\pi^2 \sin\theta\, du\, dv`.
"""
from __future__ import annotations

import numpy as np

from ..core.color import LUMINANCE
from ..core.sampling import Distribution2D
from ..io.bitmap import BitmapError, read_bitmap
from ..scene.properties import Props, children, find_file
from ..scene.registry import register
from .base import EnvironmentEmitter, rotation_only

#: Floor on sin(theta) in the density (Mitsuba's: float32 epsilon).
SIN_THETA_MIN = 2.0 ** -24


class EnvironmentMap(EnvironmentEmitter):
    """Environment emitter with a latitude-longitude radiance image.

    Parameters
    ----------
    image : (H, W, 3) ndarray
        Linear RGB radiance, row 0 at the top (H >= 3, W >= 2).
    scale : float
        Multiplies every radiance value.
    to_world : (4, 4) ndarray
        Emitter-to-world transform (its 3x3 part is used for directions).
    mis_compensation : bool
        Subtract the mean luminance from the sampling weights (Karlik et al.
        2019, as Mitsuba's option), unless the map is nearly constant.
    """

    kind = "envmap"

    def __init__(self, image: np.ndarray, scale: float = 1.0, to_world: np.ndarray | None = None,
                 mis_compensation: bool = False):
        image = np.asarray(image, dtype=np.float64)
        height, width = image.shape[:2]
        self.width, self.height = width, height
        self.scale = float(scale)
        self.to_world = np.eye(4) if to_world is None else np.asarray(to_world, dtype=np.float64)
        self.to_local = np.linalg.inv(self.to_world[:3, :3])
        # Vertex grid of the bilinear interpolant: the first column repeated for the wrap-around.
        self.grid = np.concatenate((image, image[:, :1]), axis=1)
        luminance = self.grid @ LUMINANCE
        if mis_compensation:
            luminance = luminance - _compensation_offset(luminance[:, :-1])
        theta = np.arange(height) * np.pi / (height - 1)
        weight = np.maximum(luminance, 0.0) * np.sin(theta)[:, None]
        self.distribution = Distribution2D(weight)

    # -- mapping ------------------------------------------------------------

    def local_direction(self, d_world: np.ndarray) -> np.ndarray:
        """World directions (n, 3) in the emitter's frame (not renormalised, as Mitsuba)."""
        return d_world @ self.to_local.T

    def direction_to_uv(self, d_local: np.ndarray) -> np.ndarray:
        """Latitude-longitude coordinates (n, 2) of local directions."""
        u = np.arctan2(d_local[:, 0], -d_local[:, 2]) / (2 * np.pi)
        v = np.arccos(np.clip(d_local[:, 1], -1.0, 1.0)) / np.pi
        return np.stack((u, v), axis=1)

    @staticmethod
    def uv_to_direction(uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Local unit directions (n, 3) of (u, v), and sin(theta) of each."""
        theta, phi = uv[:, 1] * np.pi, uv[:, 0] * 2 * np.pi
        sin_theta = np.sin(theta)
        d = np.stack((np.sin(phi) * sin_theta, np.cos(theta), -np.cos(phi) * sin_theta), axis=1)
        return d, sin_theta

    def _half_texel(self) -> float:
        return 0.5 / self.width

    # -- emitter interface ----------------------------------------------------

    def eval(self, d_world: np.ndarray) -> np.ndarray:
        """Radiance (n, 3) arriving from the world directions ``d_world`` (pointing outwards)."""
        return self.lookup(self.direction_to_uv(self.local_direction(d_world)))

    def lookup(self, uv: np.ndarray) -> np.ndarray:
        """Bilinearly interpolated, scaled radiance (n, 3) at latitude-longitude ``uv``."""
        x = np.mod(uv[:, 0] - self._half_texel(), 1.0) * self.width
        y = uv[:, 1] * (self.height - 1)
        ix = np.minimum(x.astype(np.int64), self.width - 1)
        iy = np.clip(y.astype(np.int64), 0, self.height - 2)
        fx, fy = (x - ix)[:, None], (y - iy)[:, None]
        g = self.grid
        top = g[iy, ix] * (1 - fx) + g[iy, ix + 1] * fx
        bottom = g[iy + 1, ix] * (1 - fx) + g[iy + 1, ix + 1] * fx
        return (top * (1 - fy) + bottom * fy) * self.scale

    def sample(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Importance-sample directions from uniform numbers ``u`` (n, 2).

        Returns
        -------
        wo : (n, 3) unit world directions towards the environment.
        pdf : (n,) solid-angle density (0 for a black map).
        radiance : (n, 3) radiance arriving along ``-wo``.
        """
        xy, pdf_xy = self.distribution.sample(u)
        uv = xy + np.array([self._half_texel(), 0.0])
        d_local, sin_theta = self.uv_to_direction(uv)
        pdf = pdf_xy / (np.maximum(sin_theta, SIN_THETA_MIN) * 2 * np.pi ** 2)
        wo = d_local @ self.to_world[:3, :3].T
        return wo, pdf, self.lookup(uv)

    def pdf(self, d_world: np.ndarray) -> np.ndarray:
        """Solid-angle density (n,) with which :meth:`sample` picks the directions ``d_world``."""
        d = self.local_direction(d_world)
        uv = self.direction_to_uv(d)
        xy = np.stack((np.mod(uv[:, 0] - self._half_texel(), 1.0), uv[:, 1]), axis=1)
        sin_theta = np.sqrt(np.maximum(d[:, 0] ** 2 + d[:, 2] ** 2, SIN_THETA_MIN ** 2))
        return self.distribution.pdf(xy) / (sin_theta * 2 * np.pi ** 2)


def _compensation_offset(luminance: np.ndarray) -> float:
    """Mean luminance of the pixels, or 0 when it is within 1 % of the minimum (a flat map)."""
    mean = float(luminance.mean())
    return 0.0 if mean - float(luminance.min()) <= 0.01 * mean else mean


@register("emitter", "envmap")
def create(props: Props):
    """``filename`` (looked up in ``props.folders``), ``scale``, ``to_world`` (a rotation) and
    ``mis_compensation``."""
    plugin = props.plugin
    children(plugin, {})
    if props.has("bitmap"):
        raise plugin.error("\"bitmap\" (a Bitmap object) exists only in Python dictionaries; "
                           "give a filename", props.line("bitmap"))
    if not props.has("filename"):
        raise plugin.error("missing <string name=\"filename\"> (the latitude-longitude image)")
    filename = props.string("filename", None)
    path = find_file(plugin, props, "filename", props.folders)
    try:
        image = read_bitmap(path)
    except BitmapError as error:
        raise plugin.error(str(error), props.line("filename")) from None
    if image.shape[2] == 1:
        image = np.repeat(image, 3, axis=2)
    if image.shape[1] < 2 or image.shape[0] < 3:
        raise plugin.error(f"\"{filename}\": an environment map needs at least 2x3 pixels, "
                           f"got {image.shape[1]}x{image.shape[0]}", props.line("filename"))
    if not np.all(np.isfinite(image)) or np.any(image < 0):
        raise plugin.error(f"\"{filename}\": radiance must be finite and non-negative",
                           props.line("filename"))
    return EnvironmentMap(image, scale=props.float("scale", 1.0),
                          to_world=rotation_only(props),
                          mis_compensation=props.bool("mis_compensation", False))
