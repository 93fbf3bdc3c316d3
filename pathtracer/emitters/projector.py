r"""Mitsuba's ``projector`` emitter: a pinhole that projects an image into the scene.

The reciprocal of the perspective camera. A point :math:`p` at projector-space
:math:`(x, y, z) = \mathrm{to\_world}^{-1} p` lies on the ray of the image position

.. math:: s = \Bigl(\tfrac12\bigl(1 - \tfrac{x}{z\,t_x}\bigr),\;
                    \tfrac12\bigl(1 - \tfrac{y}{z\,t_y}\bigr)\Bigr),
          \qquad t_x = \tan\tfrac{\mathrm{fov}_x}{2},\; t_y = t_x / a,

``a`` the aspect of the ``irradiance`` texture (its resolution; 1 for a constant). Points
with :math:`z > 0` and :math:`s \in [0, 1]^2` receive, as Mitsuba's
``Projector::sample_direction`` gives it,

.. math:: \frac{\pi\,k\,E(s)}{z^2 \cos\theta}, \qquad \cos\theta = -n \cdot \omega,

with ``k`` = ``scale``, :math:`E` the texture, :math:`n = \mathrm{to\_world}\,(0, 0, 1)`
and :math:`\omega` the unit direction from the point to the projector. On a plane
:math:`z = z_0` facing the projector the irradiance is then :math:`\pi k E(s) / z_0^2`
(the :math:`1/\cos\theta` cancels the plane's cosine): a constant texture lights such a
plane uniformly, as Mitsuba intends. Dirac in position (next-event pdf 1,
never hit by rays).

Light paths (Mitsuba's ``Projector::sample_ray``) leave the pinhole through an image position
drawn by the texture's own ``sample_position`` (uniform for a constant), with density
:math:`p(s)` over the unit square. Position ``s`` is the projector-space direction
:math:`\ell = (t_x (1 - 2 s_x),\, t_y (1 - 2 s_y),\, 1)` on the plane ``z = 1``, whose
image covers :math:`A = 4 t_x t_y`; with :math:`R` the linear part of ``to_world`` and
:math:`v = R\,\ell`, the world direction :math:`v / |v|` has the solid-angle density and
the intensity

.. math:: p(\omega) = \frac{p(s)\,|v|^3}{A\,|\det R|}, \qquad
          I(\omega) = \frac{\pi\,k\,E(s)\,|v|^3}{n \cdot v},

the intensity being the one next-event estimation sees (its weight times the squared
distance), so the ray's weight is :math:`I / p = \pi k E(s) A |\det R| / (p(s)\, n \cdot v)`,
Mitsuba's :math:`\pi k E(s) A / p(s)` for a rigid ``to_world``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.vec import dot, norm, unscale
from ..scene.properties import Props, children
from ..scene.registry import register
from ..sensors.perspective_sensor import read_x_fov
from ..textures.base import Texture
from .base import Emitter, EmitterSample
from .point import at_point


@dataclass
class ProjectorEmitter(Emitter):
    """Mitsuba's ``projector``.

    Attributes
    ----------
    to_world : (4, 4) projector-to-world (+z the optical axis, +x left in the image).
    irradiance : Texture or (3,) array, looked up at the image position ``s``.
    scale : float
    x_fov : float, horizontal field of view in degrees.
    aspect : float, width / height of the irradiance image.
    """

    to_world: np.ndarray
    irradiance: object
    scale: float
    x_fov: float
    aspect: float

    kind = "projector"
    delta_position = True
    starts_light_paths = True

    def __post_init__(self):
        self.position = self.to_world[:3, 3].copy()
        self.axis = self.to_world[:3, 2].copy()            # to_world (0, 0, 1), not normalised
        self.to_local = np.linalg.inv(self.to_world[:3, :3])
        self.tan_x = float(np.tan(np.radians(self.x_fov) / 2))
        self.tan_y = self.tan_x / self.aspect
        self.linear = self.to_world[:3, :3].copy()
        self.image_area = 4.0 * self.tan_x * self.tan_y          # A: the image on z = 1
        self.det = abs(float(np.linalg.det(self.linear)))

    def image_position(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Projector-space ``z`` (n,), image positions ``s`` (n, 2) of world points and
        whether they are lit (``z > 0``, ``s`` in the image)."""
        local = (p - self.position) @ self.to_local.T
        z = local[:, 2]
        safe = np.where(z > 0, z, 1.0)
        s = np.stack((0.5 * (1.0 - local[:, 0] / (safe * self.tan_x)),
                      0.5 * (1.0 - local[:, 1] / (safe * self.tan_y))), axis=1)
        lit = (z > 0) & np.all((s >= 0.0) & (s <= 1.0), axis=1)
        return z, s, lit

    def sample_direction(self, scene, ref_p, u):
        """Towards the pinhole; weight ``pi k E(s) / (z^2 cos)`` where lit, pdf 1."""
        to_light = self.position - ref_p
        dist = norm(to_light)
        wo = unscale(to_light, np.where(dist > 0, dist, 1.0))
        z, s, lit = self.image_position(ref_p)
        weight = np.zeros((len(ref_p), 3))
        rows = np.flatnonzero(lit)
        if len(rows):
            if isinstance(self.irradiance, Texture):
                value = self.irradiance.eval(s[rows])
            else:
                value = np.broadcast_to(self.irradiance, (len(rows), 3))
            cos = -dot(np.broadcast_to(self.axis, (len(rows), 3)), wo[rows])
            weight[rows] = value * (np.pi * self.scale / (z[rows] ** 2 * cos))[:, None]
        return EmitterSample(wo, dist, np.ones(len(u)), weight, np.ones(len(u), dtype=bool))

    def irradiance_at(self, s: np.ndarray) -> np.ndarray:
        """The texture (n, 3) at image positions ``s``."""
        if isinstance(self.irradiance, Texture):
            return self.irradiance.eval(s)
        return np.broadcast_to(self.irradiance, (len(s), 3)).copy()

    def position_density(self, s: np.ndarray) -> np.ndarray:
        """Density (n,) over the unit square with which light paths draw image positions."""
        if isinstance(self.irradiance, Texture):
            return self.irradiance.pdf_position(s)
        return np.ones(len(s))

    def sample_position(self, scene, u):
        return at_point(self.position, len(u))

    def sample_ray_direction(self, n, u):
        """Through an image position drawn by the texture (see the module docstring)."""
        if isinstance(self.irradiance, Texture):
            s, pdf_s = self.irradiance.sample_position(u)
        else:
            s, pdf_s = np.asarray(u, np.float64), np.ones(len(u))
        v = self.world_direction(s)
        length = norm(v)
        d = unscale(v, length)
        pdf_dir = pdf_s * length ** 3 / (self.image_area * self.det)
        along_axis = dot(v, np.broadcast_to(self.axis, v.shape))
        ok = (pdf_s > 0) & (along_axis > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(ok, np.pi * self.scale * self.image_area * self.det
                             / (pdf_s * along_axis), 0.0)
        return d, np.where(ok, pdf_dir, 0.0), self.irradiance_at(s) * scale[:, None]

    def pdf_ray_direction(self, n, d):
        s, v, lit = self.leaving(d)
        pdf = self.position_density(s) * norm(v) ** 3 / (self.image_area * self.det)
        return np.where(lit, pdf, 0.0)

    def eval_towards(self, n, d):
        """The intensity ``pi k E(s) |v|^3 / (n . v)`` along ``d``, 0 outside the image."""
        s, v, lit = self.leaving(d)
        along_axis = dot(v, np.broadcast_to(self.axis, v.shape))
        ok = lit & (along_axis > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(ok, np.pi * self.scale * norm(v) ** 3 / along_axis, 0.0)
        return self.irradiance_at(s) * scale[:, None]

    def world_direction(self, s: np.ndarray) -> np.ndarray:
        """``v = R l`` (n, 3) of image positions ``s``, ``l`` on the plane ``z = 1``."""
        local = np.stack((self.tan_x * (1.0 - 2.0 * s[:, 0]), self.tan_y * (1.0 - 2.0 * s[:, 1]),
                          np.ones(len(s))), axis=1)
        return local @ self.linear.T

    def leaving(self, d: np.ndarray):
        """Image positions ``s`` (n, 2) of world directions ``d`` leaving the pinhole, their
        ``v`` (n, 3, on the plane ``z = 1`` mapped to world) and whether they are in the image."""
        _, s, lit = self.image_position(self.position + d)
        local = d @ self.to_local.T
        z = np.where(local[:, 2] > 0, local[:, 2], 1.0)
        return s, unscale(d, z), lit


def texture_aspect(irradiance) -> float:
    """Width / height of a texture's image (Mitsuba's ``Texture::resolution``; 1 when it has
    none, e.g. a constant or a checkerboard)."""
    width, height = getattr(irradiance, "width", 1), getattr(irradiance, "height", 1)
    return width / height


@register("emitter", "projector")
def create(props: Props):
    """``irradiance`` (a colour or texture, 1), ``scale`` (1), ``to_world``, ``fov`` with
    ``fov_axis`` or ``focal_length`` (50mm), read against the texture's aspect."""
    plugin = props.plugin
    children(plugin, {"texture": 1})
    irradiance = props.emission_or_texture("irradiance", 1.0)
    scale = props.float("scale", 1.0)
    aspect = texture_aspect(irradiance)
    x_fov = read_x_fov(plugin, props, aspect)
    to_world = props.transform("to_world")
    if abs(np.linalg.det(to_world[:3, :3])) < 1e-300:
        raise plugin.error("the projector's to_world is singular", props.line("to_world"))
    return ProjectorEmitter(to_world=to_world, irradiance=irradiance, scale=scale,
                            x_fov=x_fov, aspect=aspect)
