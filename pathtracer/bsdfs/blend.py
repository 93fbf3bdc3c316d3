r"""Linear blend of two BSDFs, Mitsuba's ``blendbsdf`` plugin.

.. math:: f = (1 - w)\,f_0 + w\,f_1,\qquad p = (1 - w)\,p_0 + w\,p_1,

with the blend ``weight`` :math:`w` (a number or a texture read with ``eval_1``, clipped
to [0, 1] as Mitsuba clips it). Sampling picks :math:`f_0` when :math:`u_1 > w` (then
reuses :math:`(u_1 - w)/(1 - w)`), else :math:`f_1` (with :math:`u_1 / w`), and, as
Mitsuba 3.9.1 does, reports the mixture density of the sampled direction and the weight

.. math:: \frac{(1 - w)\,f_0 + w\,f_1}{(1 - w)\,p_0 + w\,p_1}

where the chosen lobe's :math:`f\cos/p` stands for its value times its ``pdf`` (for a Dirac
lobe, whose ``pdf`` is its selection probability, the other BSDF's finite value and density
at that direction are added in the same way). Direction, ``delta`` and ``eta`` are the
chosen BSDF's.
"""
from __future__ import annotations

import copy

import numpy as np

from ..scene.properties import Props
from ..scene.registry import register
from ..textures.base import Texture
from .base import BSDF, BSDFSample, make_sample
from .parameters import nested_bsdfs, scalar_or_texture


class BlendBSDF(BSDF):
    """``(1 - weight) * first + weight * second``."""

    scalar_texture_params = ("weight",)

    def __init__(self, first: BSDF, second: BSDF, weight=0.5):
        self.bsdfs = (first, second)
        self.weight = weight if isinstance(weight, Texture) else float(np.clip(weight, 0.0, 1.0))
        self.has_smooth = first.has_smooth or second.has_smooth
        self.is_delta = first.is_delta and second.is_delta
        # For the light tracer's adjoint scaling: the relative index of the refracting
        # BSDF (the first one's if both refract).
        refracting = [b for b in (first, second) if b.refracts]
        self.refracts = bool(refracting)
        self.eta = refracting[0].eta if refracting else 1.0

    @property
    def textured(self) -> bool:
        """The weight or a blended BSDF varies over the surface."""
        return isinstance(self.weight, Texture) or any(b.textured for b in self.bsdfs)

    @property
    def anisotropic(self) -> bool:
        """A nested BSDF sees the azimuth of the tangent frame."""
        return any(b.anisotropic for b in self.bsdfs)

    @property
    def needs_geometry(self) -> bool:
        """A blended BSDF perturbs the shading normal."""
        return any(b.needs_geometry for b in self.bsdfs)

    def at(self, uv: np.ndarray, geometry=None) -> "BlendBSDF":
        """The blend with the weight and both BSDFs bound to the hits' ``uv``."""
        bound = copy.copy(self)
        if isinstance(self.weight, Texture):
            bound.weight = np.clip(self.weight.eval_1(uv), 0.0, 1.0)
        bound.bsdfs = tuple(b.at(uv, geometry) if b.textured else b for b in self.bsdfs)
        return bound

    def _weight(self, n: int) -> np.ndarray:
        return np.broadcast_to(np.asarray(self.weight, dtype=np.float64), (n,))

    def eval(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """:math:`(1 - w) f_0 + w f_1` times foreshortening -> (n, 3)."""
        w = self._weight(len(wi))[:, None]
        return (1.0 - w) * self.bsdfs[0].eval(wi, wo) + w * self.bsdfs[1].eval(wi, wo)

    def pdf(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """:math:`(1 - w) p_0 + w p_1` -> (n,)."""
        w = self._weight(len(wi))
        return (1.0 - w) * self.bsdfs[0].pdf(wi, wo) + w * self.bsdfs[1].pdf(wi, wo)

    def sample(self, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray) -> BSDFSample:
        """Sample one BSDF by ``u1``; weight and pdf of the mixture (see the module docstring)."""
        w = self._weight(len(wi))
        first = u1 > w
        with np.errstate(divide="ignore", invalid="ignore"):
            reused = np.where(first, (u1 - w) / (1.0 - w), u1 / w)
        reused = np.where(np.isfinite(reused), np.clip(reused, 0.0, 1.0), 0.0)
        # Both BSDFs are sampled for every row: a bound BSDF needs all of its rows.
        samples = [b.sample(wi, reused, u2) for b in self.bsdfs]

        def pick(a, b):
            return np.where(first.reshape((-1,) + (1,) * (a.ndim - 1)), a, b)

        wo = pick(samples[0].wo, samples[1].wo)
        bs_pdf = pick(samples[0].pdf, samples[1].pdf)
        bs_weight = pick(samples[0].weight, samples[1].weight)
        # The other BSDF at the chosen direction.
        other_0 = self.bsdfs[1].eval(wi, wo), self.bsdfs[1].pdf(wi, wo)
        other_1 = self.bsdfs[0].eval(wi, wo), self.bsdfs[0].pdf(wi, wo)
        other_value = pick(other_0[0], other_1[0])
        other_pdf = pick(other_0[1], other_1[1])
        w_chosen = np.where(first, 1.0 - w, w)
        w_other = 1.0 - w_chosen
        pdf = w_other * other_pdf + w_chosen * bs_pdf
        with np.errstate(divide="ignore", invalid="ignore"):
            weight = ((w_other[:, None] * other_value + w_chosen[:, None] * bs_weight * bs_pdf[:, None])
                      / np.where(pdf > 0.0, pdf, 1.0)[:, None])
        valid = pick(samples[0].valid, samples[1].valid) & (pdf > 0.0)
        return make_sample(wo, weight, pdf, delta=pick(samples[0].delta, samples[1].delta),
                           eta=pick(samples[0].eta, samples[1].eta), valid=valid)


@register("bsdf", "blendbsdf")
def create(props: Props) -> BlendBSDF:
    """Two nested BSDFs and a ``weight`` (required: a number or a texture)."""
    first, second = nested_bsdfs(props, 2, 2, textures=1)
    return BlendBSDF(first, second, scalar_or_texture(props, "weight", None))
