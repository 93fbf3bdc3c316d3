"""Mitsuba's ``point`` emitter: an isotropic point light.

Dirac in position: next-event estimation reaches it with weight ``I / r^2`` and pdf 1 (MIS
weight 1), and no ray ever hits it. Light paths start at its position in a uniform direction.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.sampling import square_to_uniform_sphere
from ..core.vec import norm, unscale
from ..scene.properties import Props, children
from ..scene.registry import register
from .base import Emitter, EmitterSample


@dataclass
class PointEmitter(Emitter):
    """Isotropic point light: radiant intensity ``intensity`` [W/sr], falling off as 1/r^2."""

    position: np.ndarray  # (3,)
    intensity: np.ndarray  # (3,)

    kind = "point"
    delta_position = True
    starts_light_paths = True

    def sample_direction(self, scene, ref_p, u):
        wo, dist, weight = towards_point(self.position, self.intensity, ref_p)
        return EmitterSample(wo, dist, np.ones(len(u)), weight, np.ones(len(u), dtype=bool))

    def sample_position(self, scene, u):
        return at_point(self.position, len(u))

    def sample_ray_direction(self, n, u):
        """A uniform direction (``1 / 4 pi``), weight ``4 pi I``."""
        d = square_to_uniform_sphere(u)
        return d, np.full(len(u), 1.0 / (4.0 * np.pi)), np.broadcast_to(self.intensity * (4.0 * np.pi),
                                                                         (len(u), 3))

    def pdf_ray_direction(self, n, d):
        return np.full(len(d), 1.0 / (4.0 * np.pi))

    def eval_towards(self, n, d):
        return np.broadcast_to(self.intensity, (len(d), 3))


def towards_point(position: np.ndarray, intensity: np.ndarray, ref_p: np.ndarray):
    """Directions (n, 3) and distances (n,) from ``ref_p`` to a point light, and its
    ``intensity / r^2`` (n, 3)."""
    to_light = position - ref_p
    dist = norm(to_light)
    wo = unscale(to_light, dist)
    return wo, dist, unscale(intensity, dist ** 2)


def at_point(position: np.ndarray, count: int):
    """``count`` light-path starts at a point light: ``(p, n, pdf, emission)`` with a zero
    normal, pdf 1 and emission 1 (the intensity comes with the direction)."""
    return (np.broadcast_to(position, (count, 3)), np.zeros((count, 3)), np.ones(count),
            np.ones((count, 3)))


@register("emitter", "point")
def create(props: Props):
    """``position`` or the origin of ``to_world`` (not both), ``intensity``."""
    plugin = props.plugin
    children(plugin, {})
    if props.has("position") and props.has("to_world"):
        raise plugin.error("give either position or to_world, not both")
    position = props.point("position", None)
    if position is None:
        position = props.transform("to_world")[:3, 3].copy()
    return PointEmitter(position=position, intensity=props.color("intensity", 1.0))
