r"""Mitsuba's ``spot`` emitter: a point light shining into a cone.

Dirac in position like :mod:`pathtracer.emitters.point`: next-event weight
``I falloff T / r^2``, pdf 1. Light paths start in a uniform direction of the cutoff cone
(weight ``I falloff T / pdf_cone``).

``T`` is 1, or the projected ``texture`` looked up where the direction crosses the plane
``z = 1`` of the light's frame, scaled so that the cutoff cone spans ``[0, 1]^2`` (as
Mitsuba's ``SpotLight::direction_to_uv``):

.. math:: (u, v) = \Bigl(\tfrac12 + \frac{x}{2 z \tan\theta_c},\;
                          \tfrac12 + \frac{y}{2 z \tan\theta_c}\Bigr),

with :math:`(x, y, z) = \mathrm{to\_world}^{-1} d` for the (unnormalised) direction ``d``
leaving the light, and :math:`\theta_c` the cutoff angle. The texture is only looked up
where the falloff is positive.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.sampling import square_to_uniform_cone, square_to_uniform_cone_pdf
from ..core.vec import normalize
from ..scene.properties import Props, build_texture, children
from ..scene.registry import register
from ..textures.base import Texture
from .base import Emitter, EmitterSample
from .point import at_point, towards_point


@dataclass
class SpotEmitter(Emitter):
    """Mitsuba's ``spot``: a point light shining along its local +z, inside a cone.

    Radiant intensity ``intensity`` [W/sr] within ``beam_width`` of the axis,
    falling linearly in angle to 0 at ``cutoff_angle`` (both in radians here), times the
    projected ``texture`` where there is one.
    """

    position: np.ndarray    # (3,)
    to_local: np.ndarray    # (3, 3) inverse of the linear part of to_world
    intensity: np.ndarray   # (3,)
    cutoff_angle: float
    beam_width: float
    texture: Texture | None = None

    kind = "spot"
    delta_position = True
    starts_light_paths = True

    def falloff(self, d_world: np.ndarray) -> np.ndarray:
        """Fraction (n,) of the full intensity emitted along world directions ``d_world``."""
        local = d_world @ self.to_local.T
        cos_theta = local[:, 2] / np.linalg.norm(local, axis=1)
        angle = np.arccos(np.clip(cos_theta, -1.0, 1.0))
        with np.errstate(divide="ignore", invalid="ignore"):
            ramp = (self.cutoff_angle - angle) / (self.cutoff_angle - self.beam_width)
        ramp = np.where(cos_theta >= np.cos(self.beam_width), 1.0, ramp)
        return np.where(cos_theta > np.cos(self.cutoff_angle), ramp, 0.0)

    def texture_uv(self, d_world: np.ndarray) -> np.ndarray:
        """Texture coordinates (n, 2) of directions leaving the light (module docstring);
        call only where the falloff is positive (there ``z > 0``)."""
        local = d_world @ self.to_local.T
        scale = 0.5 / (local[:, 2] * np.tan(self.cutoff_angle))
        return 0.5 + local[:, :2] * scale[:, None]

    def textured(self, d_world: np.ndarray, falloff: np.ndarray, value: np.ndarray) -> np.ndarray:
        """``value`` (n, 3) along world directions ``d_world`` (whose :meth:`falloff` is
        given) times the projected texture where the falloff is positive (unchanged without
        a texture)."""
        if self.texture is None:
            return value
        lit = np.flatnonzero(falloff > 0)
        value[lit] *= self.texture.eval(self.texture_uv(d_world[lit]))
        return value

    def sample_direction(self, scene, ref_p, u):
        wo, dist, weight = towards_point(self.position, self.intensity, ref_p)
        falloff = self.falloff(-wo)
        weight = self.textured(-wo, falloff, weight * falloff[:, None])
        return EmitterSample(wo, dist, np.ones(len(u)), weight, np.ones(len(u), dtype=bool))

    def sample_position(self, scene, u):
        return at_point(self.position, len(u))

    def sample_ray_direction(self, n, u):
        """A uniform direction in the cutoff cone (world space), weight ``I falloff T / pdf_cone``."""
        cos_cutoff = np.cos(self.cutoff_angle)
        local = square_to_uniform_cone(u, cos_cutoff)
        d = normalize(local @ np.linalg.inv(self.to_local).T)
        pdf_dir = square_to_uniform_cone_pdf(local, cos_cutoff)
        falloff = self.falloff(d)
        return d, pdf_dir, self.textured(d, falloff, self.intensity * (falloff / pdf_dir)[:, None])

    def pdf_ray_direction(self, n, d):
        local = normalize(d @ self.to_local.T)
        return square_to_uniform_cone_pdf(local, np.cos(self.cutoff_angle))

    def eval_towards(self, n, d):
        falloff = self.falloff(d)
        return self.textured(d, falloff, self.intensity * falloff[:, None])


@register("emitter", "spot")
def create(props: Props):
    """``to_world``, ``intensity``, ``cutoff_angle`` (20 degrees), ``beam_width``
    (3/4 of the cutoff) and an optional projected ``texture``, which must vary (Mitsuba
    refuses a constant there: that is ``intensity``'s job)."""
    plugin = props.plugin
    children(plugin, {"texture": 1})
    texture = None
    if "texture" in props.textures:
        props.used.add("texture")
        texture = build_texture(props.textures["texture"], props.folders, props.texture_cache)
        if not texture.spatially_varying:
            raise props.textures["texture"].error(
                "a spot light's \"texture\" must vary over the image (e.g. a bitmap), as "
                "Mitsuba requires; give a uniform colour as \"intensity\"")
    elif props.has("texture"):
        raise plugin.error("a spot light's \"texture\" must be a nested <texture> that varies "
                           "(e.g. a bitmap), as Mitsuba requires; give a uniform colour as "
                           "\"intensity\"", props.line("texture"))
    m = props.transform("to_world")
    cutoff = props.float("cutoff_angle", 20.0)
    beam = props.float("beam_width", cutoff * 0.75)
    if not 0 < cutoff <= 180:
        raise plugin.error(f"cutoff_angle must lie in (0, 180] degrees, got {cutoff:g}",
                           props.line("cutoff_angle"))
    if not 0 <= beam <= cutoff:
        raise plugin.error(f"beam_width must lie in [0, cutoff_angle = {cutoff:g}] degrees, got {beam:g}",
                           props.line("beam_width") if props.has("beam_width") else None)
    return SpotEmitter(position=m[:3, 3].copy(), to_local=np.linalg.inv(m[:3, :3]),
                       intensity=props.color("intensity", 1.0),
                       cutoff_angle=np.radians(cutoff), beam_width=np.radians(beam),
                       texture=texture)
