"""Mitsuba's ``directional`` emitter: parallel light from infinitely far away."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import _rotation_only


@dataclass
class DirectionalEmitter:
    """Mitsuba's ``directional``: parallel light of ``irradiance`` [W/m^2] travelling along ``direction``."""

    direction: np.ndarray   # (3,) unit, the direction the light travels
    irradiance: np.ndarray  # (3,)
    kind: str = "directional"


def _build_directional(plugin, props, folders):
    if props.has("direction") and props.has("to_world"):
        raise plugin.error("give either direction or to_world, not both")
    direction = props.point("direction", None)
    if direction is None:
        m = _rotation_only(plugin, props)
        direction = m[:3, 2].copy()
    if not np.linalg.norm(direction) > 0:
        raise plugin.error("direction must not be zero", props.line("direction"))
    return DirectionalEmitter(direction=direction / np.linalg.norm(direction),
                              irradiance=props.color("irradiance", 1.0))


def _sample_directional(emitter, sample, rows):
    """Parallel light: the one direction it comes from, a shadow ray to infinity."""
    sample.wo[rows] = -emitter.direction
    sample.dist[rows] = np.inf
    sample.pdf[rows] = 1.0
    sample.delta[rows] = True
    sample.weight[rows] = emitter.irradiance
