r"""Opacity mask, Mitsuba's ``mask`` plugin.

A surface that is there with probability ``opacity`` :math:`\alpha` (a number or a texture
read with ``eval_1``, clipped to [0, 1]; Mitsuba's default 0.5) and otherwise lets light
through unchanged:

.. math:: f = \alpha\,f_{nested} + (1 - \alpha)\,\delta(w_o + w_i).

``eval`` and ``pdf`` are :math:`\alpha` times the nested BSDF's (the pass-through is a
Dirac lobe). ``sample`` takes the nested BSDF when :math:`u_1 < \alpha` (reusing
:math:`u_1/\alpha`; its weight unchanged, its pdf times :math:`\alpha`), else continues
straight through: :math:`w_o = -w_i`, weight 1, pdf :math:`1 - \alpha`, a Dirac sample.

As in Mitsuba's ``path``, the pass-through is an ordinary bounce: it counts towards
``max_depth``, and shadow rays are blocked by a masked surface whatever its opacity.
"""
from __future__ import annotations

import copy

import numpy as np

from ..scene.properties import Props
from ..scene.registry import register
from ..textures.base import Texture
from .base import BSDF, BSDFSample, make_sample
from .parameters import nested_bsdfs, scalar_or_texture


class MaskBSDF(BSDF):
    """``nested`` with probability ``opacity``, else straight through."""

    scalar_texture_params = ("opacity",)

    def __init__(self, nested: BSDF, opacity=0.5):
        self.nested = nested
        self.opacity = (opacity if isinstance(opacity, Texture)
                        else float(np.clip(opacity, 0.0, 1.0)))
        self.has_smooth = nested.has_smooth
        self.is_delta = nested.is_delta
        # The nested BSDF's refraction (the pass-through has no value to scale).
        self.refracts, self.eta = nested.refracts, getattr(nested, "eta", 1.0)

    @property
    def textured(self) -> bool:
        """The opacity or the nested BSDF varies over the surface."""
        return isinstance(self.opacity, Texture) or self.nested.textured

    @property
    def anisotropic(self) -> bool:
        """A nested BSDF sees the azimuth of the tangent frame."""
        return self.nested.anisotropic

    @property
    def needs_geometry(self) -> bool:
        """The nested BSDF perturbs the shading normal."""
        return self.nested.needs_geometry

    def at(self, uv: np.ndarray, geometry=None) -> "MaskBSDF":
        """The mask with its opacity and nested BSDF bound to the hits' ``uv``."""
        bound = copy.copy(self)
        if isinstance(self.opacity, Texture):
            bound.opacity = np.clip(self.opacity.eval_1(uv), 0.0, 1.0)
        if self.nested.textured:
            bound.nested = self.nested.at(uv, geometry)
        return bound

    def _opacity(self, n: int) -> np.ndarray:
        return np.broadcast_to(np.asarray(self.opacity, dtype=np.float64), (n,))

    def eval(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Opacity times the nested value -> (n, 3)."""
        return self._opacity(len(wi))[:, None] * self.nested.eval(wi, wo)

    def pdf(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Opacity times the nested density -> (n,)."""
        return self._opacity(len(wi)) * self.nested.pdf(wi, wo)

    def sample(self, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray) -> BSDFSample:
        """The nested BSDF with probability ``opacity``, else the pass-through."""
        opacity = self._opacity(len(wi))
        surface = u1 < opacity
        with np.errstate(divide="ignore", invalid="ignore"):
            reused = np.where(surface, u1 / opacity, 0.0)
        bs = self.nested.sample(wi, np.clip(reused, 0.0, 1.0), u2)
        wo = np.where(surface[:, None], bs.wo, -wi)
        weight = np.where(surface[:, None], bs.weight, 1.0)
        pdf = np.where(surface, bs.pdf * opacity, 1.0 - opacity)
        valid = np.where(surface, bs.valid, pdf > 0.0)
        return make_sample(wo, weight, pdf, delta=np.where(surface, bs.delta, True),
                           eta=np.where(surface, bs.eta, 1.0), valid=valid)


@register("bsdf", "mask")
def create(props: Props) -> MaskBSDF:
    """One nested BSDF and an ``opacity`` (0.5: a number or a texture)."""
    nested, = nested_bsdfs(props, 1, 1, textures=1)
    return MaskBSDF(nested, scalar_or_texture(props, "opacity", 0.5))
