"""Mitsuba's ``constant`` emitter: a uniform environment, sampled uniformly on the sphere."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.sampling import INV_FOUR_PI, square_to_uniform_sphere
from ..scene.properties import Props, children
from ..scene.registry import register
from .base import EnvironmentEmitter


@dataclass
class ConstantEmitter(EnvironmentEmitter):
    """Uniform environment: every escaped ray sees ``radiance``."""

    radiance: np.ndarray  # (3,)

    kind = "constant"

    def eval(self, d_world: np.ndarray) -> np.ndarray:
        """Radiance (n, 3) arriving from the directions ``d_world``."""
        return np.tile(self.radiance, (len(d_world), 1))

    def sample(self, u: np.ndarray):
        """Uniform directions on the sphere: ``(wo, pdf, radiance)``."""
        wo = square_to_uniform_sphere(u)
        return wo, np.full(len(u), INV_FOUR_PI), self.eval(wo)

    def pdf(self, d_world: np.ndarray) -> np.ndarray:
        """Solid-angle density (n,) of :meth:`sample`: 1 / 4 pi."""
        return np.full(len(d_world), INV_FOUR_PI)


@register("emitter", "constant")
def create(props: Props):
    """``radiance``."""
    children(props.plugin, {})
    return ConstantEmitter(radiance=props.color("radiance", 1.0))
