"""Mitsuba's ``point`` emitter: an isotropic point light."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.vec import norm, unscale


@dataclass
class PointEmitter:
    """Isotropic point light: radiant intensity ``intensity`` [W/sr], falling off as 1/r^2."""

    position: np.ndarray  # (3,)
    intensity: np.ndarray  # (3,)
    kind: str = "point"


def _build_point(plugin, props, folders):
    if props.has("position") and props.has("to_world"):
        raise plugin.error("give either position or to_world, not both")
    position = props.point("position", None)
    if position is None:
        position = props.transform("to_world")[:3, 3].copy()
    return PointEmitter(position=position, intensity=props.color("intensity", 1.0))


def _sample_point(emitter, ref_p, sample, rows):
    """Point or spot light: the one position, intensity / r^2 (times the spot's falloff)."""
    to_light = emitter.position - ref_p
    dist = norm(to_light)
    wo = unscale(to_light, dist)
    weight = unscale(emitter.intensity, dist ** 2)
    if emitter.kind == "spot":
        weight = weight * emitter.falloff(-wo)[:, None]
    sample.wo[rows] = wo
    sample.dist[rows] = dist
    sample.pdf[rows] = 1.0
    sample.delta[rows] = True
    sample.weight[rows] = weight
