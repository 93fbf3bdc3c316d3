r"""Smooth conductor (perfect mirror), Mitsuba's ``conductor`` plugin.

The BRDF is a Dirac delta around the mirror direction
:math:`w_r = (-x_i, -y_i, z_i)`:

.. math:: f(w_i, w_o)\,|\cos\theta_o| = F(\cos\theta_i)\,R_s\,\delta(w_o - w_r),

with ``specular_reflectance`` :math:`R_s` (a colour or a texture) and the
exact conductor Fresnel factor :math:`F` of the complex index
:math:`\eta + ik` (per RGB channel,
:func:`~pathtracer.bsdfs.fresnel.fresnel_conductor`). Mitsuba's default
``material="none"`` is :math:`0 + 1i`, for which :math:`F = 1` exactly; a
named material uses the RGB indices of
:mod:`~pathtracer.bsdfs.conductor_presets`. The sample weight is
:math:`F R_s`; one-sided (no reflection from below).
"""
from __future__ import annotations

import numpy as np

from ..scene.properties import Props
from ..scene.registry import register
from .base import BSDFSample, DeltaBSDF, as_colour, as_colour_or_texture, make_sample
from .fresnel import fresnel_conductor, reflect
from .parameters import colour_or_texture, conductor_ior, textures_only


def complex_ior(eta, k) -> np.ndarray:
    r"""The (3,) complex index :math:`\eta + ik` of a conductor from its RGB parts."""
    return as_colour(eta) + 1j * as_colour(k)


def conductor_reflectance(cos_theta: np.ndarray, eta_complex: np.ndarray,
                          specular_reflectance) -> np.ndarray:
    r""":math:`F(\cos\theta)\,R_s` -> (n, 3), shared by the smooth and rough conductors.

    ``specular_reflectance`` is a (3,) colour or the (n, 3) values of a texture
    at the hits. For Mitsuba's ``material="none"`` (:math:`0 + 1i`) :math:`F = 1`.
    """
    if np.all(eta_complex == 1j):
        return np.broadcast_to(specular_reflectance, (cos_theta.shape[0], 3))
    return fresnel_conductor(cos_theta[:, None], eta_complex[None, :]) * specular_reflectance


class Conductor(DeltaBSDF):
    """Perfect mirror tinted by ``specular_reflectance`` and the conductor Fresnel factor."""

    texture_params = ("specular_reflectance",)

    def __init__(self, specular_reflectance=1.0, eta=0.0, k=1.0):
        self.specular_reflectance = as_colour_or_texture(specular_reflectance)
        self.eta_complex = complex_ior(eta, k)

    def fresnel(self, cos_theta: np.ndarray) -> np.ndarray:
        """Conductor Fresnel factor times ``specular_reflectance`` -> (n, 3)."""
        return conductor_reflectance(cos_theta, self.eta_complex, self.specular_reflectance)

    def sample(self, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray) -> BSDFSample:
        """The mirror direction with weight :math:`F R_s` (pdf 1, delta); invalid from below."""
        n = wi.shape[0]
        valid = wi[:, 2] > 0.0
        weight = self.fresnel(np.maximum(wi[:, 2], 0.0))
        return make_sample(reflect(wi), weight, np.ones(n), delta=True, eta=1.0, valid=valid)


@register("bsdf", "conductor")
def create(props: Props) -> Conductor:
    """``material`` or ``eta``/``k`` (a perfect mirror by default), ``specular_reflectance`` (1)."""
    textures_only(props)
    eta, k = conductor_ior(props)
    return Conductor(colour_or_texture(props, "specular_reflectance", 1.0), eta, k)
