r"""Smooth dielectric interface (glass), Mitsuba's ``dielectric`` plugin.

Two Dirac lobes: specular reflection with probability :math:`F` and
refraction with probability :math:`1 - F`, where :math:`F` is the exact
unpolarized Fresnel reflectance (:func:`~pathtracer.bsdfs.fresnel.fresnel_dielectric`)
for :math:`\eta = \eta_{int}/\eta_{ext}`. Choosing the lobe with exactly
these probabilities makes the Fresnel factor cancel:

.. math::
    \text{reflection: } w_o = (-x_i, -y_i, z_i),\quad
        \text{weight} = \frac{F\,R_s}{F} = R_s, \quad p = F;

    \text{transmission: } w_o = (-\eta_{ti} x_i, -\eta_{ti} y_i, \cos\theta_t),\quad
        \text{weight} = \frac{(1 - F)\,T_s\,\eta_{ti}^2}{1 - F} = T_s\,\eta_{ti}^2,
        \quad p = 1 - F.

The factor :math:`\eta_{ti}^2 = (\eta_i/\eta_t)^2` is the radiance scaling
of Mitsuba's ``TransportMode::Radiance``: radiance is compressed into a
smaller solid angle when it enters the denser medium, so it is multiplied
by :math:`1/\eta^2` when the camera path enters glass (and by :math:`\eta^2`
when it leaves). Under total internal reflection :math:`F = 1` and the
reflection lobe is always chosen. ``bs.eta`` is :math:`\eta_{it}` on
transmission (:math:`\eta` entering, :math:`1/\eta` leaving) and 1 on
reflection, so that the product of ``bs.eta`` along a path undoes the
:math:`\eta^2` radiance scaling for Russian roulette.
"""
from __future__ import annotations

import numpy as np

from ..scene.properties import Props
from ..scene.registry import register
from .base import BSDFSample, DeltaBSDF, as_colour_or_texture, make_sample
from .fresnel import fresnel_dielectric, reflect, refract
from .parameters import colour_or_texture, ior, textures_only

BK7_IOR = 1.5046
AIR_IOR = 1.000277


class Dielectric(DeltaBSDF):
    """Smooth glass-like interface between media of indices ``int_ior`` (inside) and ``ext_ior``."""

    texture_params = ("specular_reflectance", "specular_transmittance")
    refracts = True

    def __init__(self, int_ior: float = BK7_IOR, ext_ior: float = AIR_IOR,
                 specular_reflectance=1.0, specular_transmittance=1.0):
        if int_ior < 0 or ext_ior < 0:
            raise ValueError("The interior and exterior indices of refraction must be positive")
        self.int_ior = float(int_ior)
        self.ext_ior = float(ext_ior)
        self.eta = self.int_ior / self.ext_ior
        self.specular_reflectance = as_colour_or_texture(specular_reflectance)
        self.specular_transmittance = as_colour_or_texture(specular_transmittance)

    def sample(self, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray) -> BSDFSample:
        """Choose reflection if ``u1 <= F``, else refraction (see the module docstring)."""
        F, cos_theta_t, eta_it, eta_ti = fresnel_dielectric(wi[:, 2], self.eta)
        selected_r = u1 <= F

        wo = np.where(selected_r[:, None], reflect(wi), refract(wi, cos_theta_t, eta_ti))
        pdf = np.where(selected_r, F, 1.0 - F)
        weight = np.where(selected_r[:, None], self.specular_reflectance,
                          self.specular_transmittance * (eta_ti * eta_ti)[:, None])
        eta = np.where(selected_r, 1.0, eta_it)
        valid = np.ones(wi.shape[0], dtype=bool)
        return make_sample(wo, weight, pdf, delta=True, eta=eta, valid=valid)

    def lobes(self, wi: np.ndarray):
        r"""Both Dirac lobes at once, for estimators that split or pick lobes themselves.

        Returns
        -------
        F : (n,) Fresnel reflectance.
        wo_r, weight_r : reflected direction and :math:`F R_s`.
        wo_t, weight_t : refracted direction and :math:`(1 - F) T_s \eta_{ti}^2`
            (zero under total internal reflection).
        """
        F, cos_theta_t, _, eta_ti = fresnel_dielectric(wi[:, 2], self.eta)
        weight_r = F[:, None] * self.specular_reflectance
        weight_t = ((1.0 - F) * eta_ti * eta_ti)[:, None] * self.specular_transmittance
        return F, reflect(wi), weight_r, refract(wi, cos_theta_t, eta_ti), weight_t


@register("bsdf", "dielectric")
def create(props: Props) -> Dielectric:
    """``int_ior`` (``bk7``), ``ext_ior`` (``air``), ``specular_reflectance`` and
    ``specular_transmittance`` (1)."""
    textures_only(props)
    return Dielectric(ior(props, "int_ior", "bk7"), ior(props, "ext_ior", "air"),
                      colour_or_texture(props, "specular_reflectance", 1.0),
                      colour_or_texture(props, "specular_transmittance", 1.0))
