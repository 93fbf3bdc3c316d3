r"""Rough dielectric interface (frosted glass), Mitsuba's ``roughdielectric`` plugin.

Walter et al. (2007). For :math:`w_i` on either side, with
:math:`\eta' = \eta` seen from outside (:math:`\cos\theta_i > 0`) and
:math:`1/\eta` from inside, the generalised half vector is

.. math::
    m = \pm\,\mathrm{normalize}(w_i + w_o) \ \text{(reflection)},\qquad
    m = \pm\,\mathrm{normalize}(w_i + \eta' w_o) \ \text{(transmission)},

oriented to the upper hemisphere, and

.. math::
    f\cos\theta_o = \frac{F\,D\,G}{4|\cos\theta_i|}\,R_s,\qquad
    f\cos\theta_o = \left|\frac{(1 - F)\,D\,G\,(w_i\cdot m)(w_o\cdot m)}
        {\cos\theta_i\,(w_i\cdot m + \eta' w_o\cdot m)^2}\right|\,T_s

with :math:`F = F(w_i\cdot m, \eta)`, :math:`G = G_1(w_i, m)G_1(w_o, m)`;
the transmission term includes the :math:`1/\eta'^2` radiance scaling of
Mitsuba's ``TransportMode::Radiance`` (the :math:`\eta'^2` of Walter's
formula cancels it).

Sampling draws a visible normal for :math:`w_i` mirrored to the upper side,
then reflects with probability :math:`F` or refracts. With the Jacobians
:math:`1/(4\,w_o\cdot m)` and
:math:`\eta'^2 |w_o\cdot m| / (w_i\cdot m + \eta' w_o\cdot m)^2`,
:math:`p(w_o) = D_{w_i}(m)\,\{F, 1 - F\}\,|\partial m/\partial w_o|` and the
weight is :math:`G_1(w_o, m)\,R_s` (reflection) or
:math:`G_1(w_o, m)\,T_s / \eta'^2` (transmission). ``bs.eta`` is
:math:`\eta'` on transmission. Directions that end on the wrong side of the
macro- or microsurface are invalid samples (zero weight), as in Mitsuba.
"""
from __future__ import annotations

import numpy as np

from ..core.vec import dot_einsum
from ..scene.properties import Props
from ..scene.registry import register
from .base import BSDF, BSDFSample, as_colour_or_texture, make_sample
from .dielectric import AIR_IOR, BK7_IOR
from .fresnel import fresnel_dielectric, reflect_about, refract_about
from .microfacet import RoughSurface, _normalize, textured_distribution
from .parameters import colour_or_texture, distinct_iors, microfacet_parameters, textures_only


def _mulsign_z(v: np.ndarray, sign_of: np.ndarray) -> np.ndarray:
    """``v`` negated where ``sign_of`` is negative (sign bit, as Mitsuba's ``mulsign``)."""
    return np.where(np.signbit(sign_of)[:, None], -v, v)


class RoughDielectric(RoughSurface, BSDF):
    """Microfacet interface between media of indices ``int_ior`` (inside) and ``ext_ior``."""

    texture_params = ("specular_reflectance", "specular_transmittance")
    refracts = True
    scalar_texture_params = ("alpha_u", "alpha_v")
    has_smooth = True
    is_delta = False

    def __init__(self, distribution: str = "beckmann", alpha_u: float = 0.1,
                 alpha_v: float | None = None, int_ior: float = BK7_IOR,
                 ext_ior: float = AIR_IOR, specular_reflectance=1.0,
                 specular_transmittance=1.0):
        if int_ior < 0 or ext_ior < 0 or int_ior == ext_ior:
            raise ValueError("The interior and exterior indices of refraction must be positive and differ")
        self.distr = textured_distribution(self, distribution, alpha_u, alpha_v, True)
        self.eta = float(int_ior) / float(ext_ior)
        self.specular_reflectance = as_colour_or_texture(specular_reflectance)
        self.specular_transmittance = as_colour_or_texture(specular_transmittance)

    def _geometry(self, wi: np.ndarray, wo: np.ndarray):
        """Reflection mask, relative index :math:`\\eta'`, generalised half vector (upper side)."""
        cos_i = wi[:, 2]
        reflect = cos_i * wo[:, 2] > 0.0
        eta = np.where(cos_i > 0.0, self.eta, 1.0 / self.eta)
        with np.errstate(divide="ignore", invalid="ignore"):
            m = _normalize(wi + wo * np.where(reflect, 1.0, eta)[:, None])
        m = _mulsign_z(m, m[:, 2])
        finite = np.all(np.isfinite(m), axis=1)
        m = np.where(finite[:, None], m, np.array([0.0, 0.0, 1.0]))
        return reflect, eta, m, finite & (cos_i != 0.0)

    def eval(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Reflection or transmission term, whichever side ``wo`` is on -> (n, 3)."""
        reflect, eta, m, active = self._geometry(wi, wo)
        cos_i = np.where(active, wi[:, 2], 1.0)
        D = self.distr.eval(m)
        F = fresnel_dielectric(dot_einsum(wi, m), self.eta)[0]
        G = self.distr.G(wi, wo, m)
        dot_i, dot_o = dot_einsum(wi, m), dot_einsum(wo, m)
        with np.errstate(divide="ignore", invalid="ignore"):
            value_r = F * D * G / (4.0 * np.abs(cos_i))
            value_t = np.abs((1.0 - F) * D * G * dot_i * dot_o
                             / (cos_i * (dot_i + eta * dot_o) ** 2))
        value = np.where(reflect[:, None], value_r[:, None] * self.specular_reflectance,
                         value_t[:, None] * self.specular_transmittance)
        ok = active & np.all(np.isfinite(value), axis=1)
        return np.where(ok[:, None], value, 0.0)

    def pdf(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Density of :meth:`sample` as Mitsuba reports it (its Beckmann G1) -> (n,)."""
        return self._pdf(wi, wo, self.distr.smith_g1)

    def pdf_exact(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Density :meth:`sample` really draws from (exact Smith G1; equals :meth:`pdf` for GGX)."""
        return self._pdf(wi, wo, self.distr.smith_g1_exact)

    def _pdf(self, wi: np.ndarray, wo: np.ndarray, smith_g1) -> np.ndarray:
        reflect, eta, m, active = self._geometry(wi, wo)
        dot_i, dot_o = dot_einsum(wi, m), dot_einsum(wo, m)
        # The micro- and macro-surface must agree on the side of both directions.
        active &= (dot_i * wi[:, 2] > 0.0) & (dot_o * wo[:, 2] > 0.0)
        wi_up = _mulsign_z(wi, wi[:, 2])
        with np.errstate(divide="ignore", invalid="ignore"):
            jacobian = np.where(reflect, 1.0 / (4.0 * dot_o),
                                eta * eta * dot_o / (dot_i + eta * dot_o) ** 2)
            visible = self.distr.eval(m) * smith_g1(wi_up, m) * np.abs(dot_einsum(wi_up, m)) / wi_up[:, 2]
        F = fresnel_dielectric(dot_i, self.eta)[0]
        result = visible * np.where(reflect, F, 1.0 - F) * np.abs(jacobian)
        return np.where(active & np.isfinite(result), result, 0.0)

    def sample(self, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray) -> BSDFSample:
        """Visible normal for ``wi`` mirrored up; reflect with probability F, else refract."""
        cos_i = wi[:, 2]
        active = cos_i != 0.0
        wi_up = _mulsign_z(wi, cos_i)
        wi_up = np.where(active[:, None], wi_up, np.array([0.0, 0.0, 1.0]))
        m, pdf_m = self.distr.sample(wi_up, u2)
        active &= (pdf_m != 0.0) & np.all(np.isfinite(m), axis=1)
        m = np.where(active[:, None], m, np.array([0.0, 0.0, 1.0]))

        F, cos_theta_t, eta_it, eta_ti = fresnel_dielectric(dot_einsum(wi, m), self.eta)
        selected_r = u1 <= F
        wo = np.where(selected_r[:, None], reflect_about(wi, m),
                      refract_about(wi, m, cos_theta_t, eta_ti))
        dot_i, dot_o = dot_einsum(wi, m), dot_einsum(wo, m)
        with np.errstate(divide="ignore", invalid="ignore"):
            jacobian = np.where(selected_r, 1.0 / (4.0 * dot_o),
                                eta_it * eta_it * dot_o / (dot_i + eta_it * dot_o) ** 2)
        pdf = pdf_m * np.where(selected_r, F, 1.0 - F) * np.abs(jacobian)
        g1 = self.distr.smith_g1(wo, m)
        weight = np.where(selected_r[:, None], self.specular_reflectance,
                          (eta_ti * eta_ti)[:, None] * self.specular_transmittance) * g1[:, None]
        eta = np.where(selected_r, 1.0, eta_it)
        valid = active & (g1 > 0.0) & (pdf > 0.0) & np.isfinite(pdf)
        return make_sample(wo, weight, pdf, delta=False, eta=eta, valid=valid)


@register("bsdf", "roughdielectric")
def create(props: Props) -> RoughDielectric:
    """A ``dielectric``'s parameters (``int_ior`` != ``ext_ior``) and the microfacet ones."""
    textures_only(props)
    int_ior, ext_ior = distinct_iors(props, "bk7")
    distribution, alpha_u, alpha_v, _ = microfacet_parameters(props)
    return RoughDielectric(distribution, alpha_u, alpha_v, int_ior, ext_ior,
                           colour_or_texture(props, "specular_reflectance", 1.0),
                           colour_or_texture(props, "specular_transmittance", 1.0))
