r"""Thin dielectric sheet (a window pane), Mitsuba's ``thindielectric`` plugin.

An infinitely thin slab of index :math:`\eta = \eta_{int}/\eta_{ext}`: light
is reflected specularly or passes straight through (:math:`w_o = -w_i`, no
refraction: the two refractions of a parallel slab cancel). With the
single-interface Fresnel reflectance :math:`R = F(|\cos\theta_i|, \eta)`,
the infinite series of internal reflections sums to

.. math:: r = R + \frac{(1 - R)^2 R}{1 - R^2} = \frac{2R}{1 + R},\qquad t = 1 - r.

The lobe is chosen with probabilities :math:`r` and :math:`t`, so the
weights are just ``specular_reflectance`` and ``specular_transmittance``.
Both sides behave alike, the crossing has no :math:`\eta^2` radiance
scaling and ``bs.eta`` is 1 (the ray leaves into the medium it came from).
Mitsuba calls the transmission lobe a *null* lobe; for a path tracer it is a
Dirac lobe like any other.
"""
from __future__ import annotations

import numpy as np

from ..scene.properties import Props
from ..scene.registry import register
from .base import BSDFSample, DeltaBSDF, as_colour_or_texture, make_sample
from .dielectric import AIR_IOR, BK7_IOR
from .fresnel import fresnel_dielectric, reflect
from .parameters import colour_or_texture, ior, textures_only


class ThinDielectric(DeltaBSDF):
    """Thin two-sided sheet of glass between media of index ``ext_ior``."""

    texture_params = ("specular_reflectance", "specular_transmittance")

    def __init__(self, int_ior: float = BK7_IOR, ext_ior: float = AIR_IOR,
                 specular_reflectance=1.0, specular_transmittance=1.0):
        if int_ior < 0 or ext_ior < 0:
            raise ValueError("The interior and exterior indices of refraction must be positive")
        self.eta = float(int_ior) / float(ext_ior)
        self.specular_reflectance = as_colour_or_texture(specular_reflectance)
        self.specular_transmittance = as_colour_or_texture(specular_transmittance)

    def reflectance(self, cos_theta_i: np.ndarray) -> np.ndarray:
        r"""Reflectance :math:`r = 2R/(1 + R)` of the slab, all internal reflections summed -> (n,)."""
        R = fresnel_dielectric(np.abs(cos_theta_i), self.eta)[0]
        return 2.0 * R / (1.0 + R)

    #: The straight-through lobe is a null event in Mitsuba (``BSDFFlags::Null``): volumetric
    #: integrators do not count it as a bounce, and shadow rays cross the pane.
    null_lobe = True

    def eval_null_transmission(self, cos_theta_i: np.ndarray) -> np.ndarray:
        """What a shadow ray keeps crossing the pane, ``(1 - r) specular_transmittance`` -> (n, 3)."""
        return (1.0 - self.reflectance(cos_theta_i))[:, None] * self.specular_transmittance

    def sample(self, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray) -> BSDFSample:
        """Reflect if ``u1 <= r``, else pass straight through (``wo = -wi``)."""
        r = self.reflectance(wi[:, 2])
        selected_r = u1 <= r
        wo = np.where(selected_r[:, None], reflect(wi), -wi)
        weight = np.where(selected_r[:, None], self.specular_reflectance, self.specular_transmittance)
        pdf = np.where(selected_r, r, 1.0 - r)
        return make_sample(wo, weight, pdf, delta=True, eta=1.0, valid=np.ones(wi.shape[0], dtype=bool))


@register("bsdf", "thindielectric")
def create(props: Props) -> ThinDielectric:
    """A ``dielectric``'s parameters."""
    textures_only(props)
    return ThinDielectric(ior(props, "int_ior", "bk7"), ior(props, "ext_ior", "air"),
                          colour_or_texture(props, "specular_reflectance", 1.0),
                          colour_or_texture(props, "specular_transmittance", 1.0))
