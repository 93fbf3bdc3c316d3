r"""Rough plastic (a diffuse base under a rough dielectric coating), Mitsuba's ``roughplastic`` plugin.

A microfacet reflection at the coating plus a diffuse lobe for the light
that passes the coating, scatters in the base and leaves again:

.. math::
    f(w_i, w_o)\cos\theta_o =
        \frac{F(w_i\cdot h)\,D(h)\,G(w_i, w_o, h)}{4\cos\theta_i}\,R_s
      + \frac{\cos\theta_o}{\pi}\,\frac{1}{\eta^2}\,T(\cos\theta_i)\,T(\cos\theta_o)\,
        \frac{\rho}{1 - R_{int}}

(one-sided; :math:`h` the half vector; :math:`F` the dielectric Fresnel
reflectance for :math:`\eta = \eta_{int}/\eta_{ext}`). :math:`T` is the
coating's directional transmittance and :math:`R_{int}` its internal diffuse
reflectance, both integrated numerically as Mitsuba does
(:mod:`.microfacet_albedo`); ``nonlinear`` replaces :math:`\rho/(1 - R_{int})`
by :math:`\rho/(1 - \rho R_{int})` (see :mod:`.plastic`). Only isotropic
roughness, as in Mitsuba.

Sampling picks the glossy lobe with probability

.. math:: P_s = \frac{(1 - T_i)\,w}{(1 - T_i)\,w + T_i\,(1 - w)},

:math:`w` the specular sampling weight of :mod:`.plastic`, reflecting
:math:`w_i` about a visible normal; otherwise a cosine-weighted direction.
The density is the mixture

.. math:: p(w_o) = P_s\,\frac{D(h)\,G_1(w_i, h)}{4\cos\theta_i} + (1 - P_s)\frac{\cos\theta_o}{\pi}

(:math:`P_s\,D(h)\cos\theta_h/(4\,w_o\cdot h)` for the glossy part with
``sample_visible=false``) and the weight is ``eval / pdf``, as in Mitsuba (whose Beckmann
:math:`G_1` is a rational approximation, see :mod:`.microfacet`).
"""
from __future__ import annotations

import numpy as np

from ..core import sampling
from ..core.vec import dot_einsum
from ..scene.properties import Props
from ..scene.registry import register
from ..textures.base import Texture
from .base import BSDF, BSDFSample, as_colour_or_texture, make_sample
from .dielectric import AIR_IOR
from .fresnel import fresnel_dielectric, reflect_about
from .microfacet import MicrofacetDistribution, reflection_half_vector
from .microfacet_albedo import coating_tables, interpolate
from .parameters import distinct_iors, microfacet_parameters, plastic_parameters, textures_only
from .plastic import POLYPROPYLENE_IOR, internal_scattering, specular_sampling_weight


class RoughPlastic(BSDF):
    """Diffuse base under a rough dielectric coating (Beckmann or GGX, isotropic).

    ``diffuse_reflectance`` and ``specular_reflectance`` may be textures (``alpha`` may not:
    the coating tables depend on it, and Mitsuba takes a number too).
    """

    texture_params = ("diffuse_reflectance", "specular_reflectance")
    has_smooth = True
    is_delta = False

    def __init__(self, distribution: str = "beckmann", alpha: float = 0.1,
                 diffuse_reflectance=0.5, specular_reflectance=1.0,
                 int_ior: float = POLYPROPYLENE_IOR, ext_ior: float = AIR_IOR,
                 nonlinear: bool = False, sample_visible: bool = True):
        if int_ior < 0 or ext_ior < 0 or int_ior == ext_ior:
            raise ValueError("The interior and exterior indices of refraction must be positive and differ")
        # The coating tables always integrate over visible normals, as Mitsuba's do.
        self.distr = MicrofacetDistribution(distribution, alpha, alpha, sample_visible)
        self.distribution = self.distr.distribution
        self.alpha_u = self.alpha_v = self.distr.alpha_u
        self.eta = float(int_ior) / float(ext_ior)
        self.diffuse_reflectance = as_colour_or_texture(diffuse_reflectance)
        self.specular_reflectance = as_colour_or_texture(specular_reflectance)
        self.nonlinear = bool(nonlinear)
        self.specular_weight = specular_sampling_weight(self.diffuse_reflectance,
                                                        self.specular_reflectance)
        self.transmittance, self.internal_reflectance = coating_tables(
            self.distribution, self.alpha_u, self.eta)
        self.bind_derived()

    def bind_derived(self) -> None:
        """The base's scattered albedo divided by eta squared, per hit when textured."""
        if isinstance(self.diffuse_reflectance, Texture):
            self._diffuse = None
            return
        self._diffuse = internal_scattering(self.diffuse_reflectance, self.internal_reflectance,
                                            self.nonlinear) / (self.eta * self.eta)

    def _specular_probability(self, wi: np.ndarray) -> np.ndarray:
        r""":math:`P_s` from the coating transmittance :math:`T_i` -> (n,)."""
        t_i = interpolate(self.transmittance, np.maximum(wi[:, 2], 0.0))
        specular = (1.0 - t_i) * self.specular_weight
        diffuse = t_i * (1.0 - self.specular_weight)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(specular + diffuse > 0.0, specular / (specular + diffuse), 1.0)

    def eval(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Glossy coating reflection plus the diffuse base -> (n, 3)."""
        h, active = reflection_half_vector(wi, wo)
        cos_i = np.where(active, wi[:, 2], 1.0)
        F = fresnel_dielectric(dot_einsum(wi, h), self.eta)[0]
        specular = F * self.distr.eval(h) * self.distr.G(wi, wo, h) / (4.0 * cos_i)
        t_i = interpolate(self.transmittance, np.maximum(wi[:, 2], 0.0))
        t_o = interpolate(self.transmittance, np.maximum(wo[:, 2], 0.0))
        diffuse = sampling.INV_PI * np.maximum(wo[:, 2], 0.0) * t_i * t_o
        value = specular[:, None] * self.specular_reflectance + diffuse[:, None] * self._diffuse
        return np.where(active[:, None], value, 0.0)

    def pdf(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Mixture density of the two lobes, as Mitsuba reports it -> (n,)."""
        return self._pdf(wi, wo, self.distr.smith_g1)

    def pdf_exact(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Density :meth:`sample` really draws from (exact Smith G1; equals :meth:`pdf` for GGX)."""
        return self._pdf(wi, wo, self.distr.smith_g1_exact)

    def _pdf(self, wi: np.ndarray, wo: np.ndarray, smith_g1) -> np.ndarray:
        h, active = reflection_half_vector(wi, wo)
        cos_i = np.where(active, wi[:, 2], 1.0)
        p_specular = self._specular_probability(wi)
        if self.distr.sample_visible:
            glossy = self.distr.eval(h) * smith_g1(wi, h) / (4.0 * cos_i)
        else:
            glossy = self.distr.pdf(wi, h) / (4.0 * np.where(active, dot_einsum(wo, h), 1.0))
        diffuse = sampling.INV_PI * np.maximum(wo[:, 2], 0.0)
        return np.where(active, p_specular * glossy + (1.0 - p_specular) * diffuse, 0.0)

    def sample(self, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray) -> BSDFSample:
        """Reflect about a visible normal if ``u1 < P_s``, else cosine-sample; weight = eval / pdf."""
        up = wi[:, 2] > 0.0
        wi_up = np.where(up[:, None], wi, np.array([0.0, 0.0, 1.0]))
        selected_s = u1 < self._specular_probability(wi_up)
        m, _ = self.distr.sample(wi_up, u2)
        with np.errstate(invalid="ignore"):
            wo = np.where(selected_s[:, None], reflect_about(wi_up, m),
                          sampling.square_to_cosine_hemisphere(u2))
        wo = np.where(np.isfinite(wo), wo, 0.0)
        pdf = self.pdf(wi_up, wo)
        valid = up & (pdf > 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            weight = self.eval(wi_up, wo) / np.where(valid, pdf, 1.0)[:, None]
        return make_sample(wo, weight, pdf, delta=False, eta=1.0, valid=valid)


@register("bsdf", "roughplastic")
def create(props: Props) -> RoughPlastic:
    """A ``plastic``'s parameters (``int_ior`` != ``ext_ior``) and the microfacet ones,
    with a number for an isotropic ``alpha`` only."""
    textures_only(props)
    int_ior, ext_ior = distinct_iors(props, "polypropylene")
    common = plastic_parameters(props, int_ior, ext_ior)
    distribution, alpha, _, sample_visible = microfacet_parameters(props, anisotropic=False)
    return RoughPlastic(distribution, alpha, **common, sample_visible=sample_visible)
