"""Mitsuba's ``directional`` emitter: parallel light from infinitely far away.

Dirac in direction: next-event estimation sends a shadow ray to infinity against the
direction of travel, with weight ``E`` (the irradiance) and pdf 1; no ray ever sees it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scene.properties import Props, children
from ..scene.registry import register
from .base import Emitter, EmitterSample, rotation_only


@dataclass
class DirectionalEmitter(Emitter):
    """Mitsuba's ``directional``: parallel light of ``irradiance`` [W/m^2] travelling along ``direction``."""

    direction: np.ndarray   # (3,) unit, the direction the light travels
    irradiance: np.ndarray  # (3,)

    kind = "directional"
    delta_direction = True

    def sample_direction(self, scene, ref_p, u):
        """The one direction the light comes from."""
        count = len(u)
        return EmitterSample(np.broadcast_to(-self.direction, (count, 3)), np.full(count, np.inf),
                             np.ones(count), np.broadcast_to(self.irradiance, (count, 3)),
                             np.ones(count, dtype=bool))


@register("emitter", "directional")
def create(props: Props):
    """``direction`` or the local +z of ``to_world`` (not both), ``irradiance``."""
    plugin = props.plugin
    children(plugin, {})
    if props.has("direction") and props.has("to_world"):
        raise plugin.error("give either direction or to_world, not both")
    direction = props.point("direction", None)
    if direction is None:
        m = rotation_only(props)
        direction = m[:3, 2].copy()
    if not np.linalg.norm(direction) > 0:
        raise plugin.error("direction must not be zero", props.line("direction"))
    return DirectionalEmitter(direction=direction / np.linalg.norm(direction),
                              irradiance=props.color("irradiance", 1.0))
