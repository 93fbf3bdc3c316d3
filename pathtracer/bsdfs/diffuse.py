r"""Smooth diffuse (Lambertian) BRDF, Mitsuba's ``diffuse`` plugin.

.. math:: f(w_i, w_o) = \frac{\rho}{\pi}
          \quad\text{for } \cos\theta_i > 0,\ \cos\theta_o > 0,\ \text{else } 0.

The surface is one-sided: seen from below it is black (wrap it in
:class:`~pathtracer.bsdfs.twosided.TwoSided` for a two-sided material).

How it samples its directions is the lecture's ``hemisphere`` option of the integrators,
which only this BSDF reads: :func:`pathtracer.bsdfs.shading.eval_bsdf` and ``sample_bsdf``
take it and set it for the BSDF queries they make (:func:`hemisphere_sampling`), so that
the BSDFs that nest a diffuse one (two-sided, blends, masks, bump maps) need not pass it on.
"""
from __future__ import annotations

import contextlib
import contextvars

import numpy as np

from ..core import sampling
from ..core.vec import scale
from ..scene.properties import Props
from ..scene.registry import register
from .base import BSDF, BSDFSample, as_colour_or_texture, make_sample
from .parameters import colour_or_texture, textures_only

#: How diffuse lobes draw their directions: ``"cosine"`` or ``"uniform"`` (see
#: :class:`Diffuse`), for the BSDF queries of the current :func:`hemisphere_sampling` block.
HEMISPHERE = contextvars.ContextVar("hemisphere", default="cosine")


@contextlib.contextmanager
def hemisphere_sampling(hemisphere: str):
    """Diffuse BSDFs sample (and give the density of) ``hemisphere`` directions,
    ``"cosine"`` or ``"uniform"``, inside the ``with`` block."""
    token = HEMISPHERE.set(hemisphere)
    try:
        yield
    finally:
        HEMISPHERE.reset(token)


class Diffuse(BSDF):
    r"""Lambertian reflector with RGB albedo ``reflectance`` (:math:`\rho`).

    Sampling is cosine-weighted by default (:math:`p = \cos\theta_o/\pi`,
    weight :math:`= \rho`, Mitsuba's choice); inside ``hemisphere_sampling("uniform")``
    it samples the hemisphere uniformly instead (:math:`p = 1/(2\pi)`,
    weight :math:`= 2\rho\cos\theta_o`): same mean, larger variance, as in
    the lecture's comparison.
    """

    texture_params = ("reflectance",)
    has_smooth = True
    is_delta = False

    def __init__(self, reflectance=0.5):
        self.reflectance = as_colour_or_texture(reflectance)

    def _active(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Both directions strictly above the surface."""
        return (wi[:, 2] > 0.0) & (wo[:, 2] > 0.0)

    def eval(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        r""":math:`\rho\,\cos\theta_o / \pi` where both directions are above the surface."""
        cos_theta_o = np.where(self._active(wi, wo), wo[:, 2], 0.0)
        return scale(self.reflectance, sampling.INV_PI * cos_theta_o)

    def pdf(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        r"""Density of :meth:`sample`: :math:`\cos\theta_o/\pi` (cosine) or :math:`1/(2\pi)` (uniform)."""
        density = _hemisphere_pdf(wo, HEMISPHERE.get())
        return np.where(self._active(wi, wo), density, 0.0)

    def sample(self, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray) -> BSDFSample:
        """Sample ``wo`` on the upper hemisphere; invalid where ``wi`` is below the surface."""
        hemisphere = HEMISPHERE.get()
        wo = _hemisphere_sample(u2, hemisphere)
        pdf = _hemisphere_pdf(wo, hemisphere)
        valid = (wi[:, 2] > 0.0) & (pdf > 0.0)
        weight = scale(self.reflectance, _hemisphere_weight(wo, hemisphere))
        return make_sample(wo, weight, pdf, delta=False, eta=1.0, valid=valid)


def _hemisphere_sample(u2: np.ndarray, hemisphere: str) -> np.ndarray:
    """Cosine-weighted or uniform direction on the upper hemisphere."""
    if hemisphere == "cosine":
        return sampling.square_to_cosine_hemisphere(u2)
    if hemisphere == "uniform":
        return sampling.square_to_uniform_hemisphere(u2)
    raise ValueError(f"hemisphere must be 'cosine' or 'uniform', not {hemisphere!r}")


def _hemisphere_weight(wo: np.ndarray, hemisphere: str) -> np.ndarray:
    r"""Ratio :math:`(\cos\theta_o/\pi) / p(w_o)`, simplified so that cosine sampling gives exactly 1.

    Exact cancellation matters: a furnace scene then has zero variance.
    """
    if hemisphere == "cosine":
        return np.ones(wo.shape[0])
    return 2.0 * np.maximum(wo[:, 2], 0.0)


def _hemisphere_pdf(wo: np.ndarray, hemisphere: str) -> np.ndarray:
    """Solid-angle density of :func:`_hemisphere_sample`."""
    if hemisphere == "cosine":
        return sampling.square_to_cosine_hemisphere_pdf(wo)
    if hemisphere == "uniform":
        return sampling.square_to_uniform_hemisphere_pdf(wo)
    raise ValueError(f"hemisphere must be 'cosine' or 'uniform', not {hemisphere!r}")


@register("bsdf", "diffuse")
def create(props: Props) -> Diffuse:
    """``reflectance`` (0.5), a colour or a texture."""
    textures_only(props)
    return Diffuse(colour_or_texture(props, "reflectance", 0.5))
