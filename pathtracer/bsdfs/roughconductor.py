r"""Rough conductor (microfacet BRDF), Mitsuba's ``roughconductor`` plugin.

Torrance-Sparrow / Walter et al. with the half vector
:math:`h = \mathrm{normalize}(w_i + w_o)`:

.. math::
    f(w_i, w_o)\cos\theta_o = \frac{F(w_i\cdot h)\,D(h)\,G_1(w_i, h)\,G_1(w_o, h)}{4\cos\theta_i}\,R_s
    \qquad (\cos\theta_i > 0,\ \cos\theta_o > 0).

(The :math:`\cos\theta_o` of the BRDF's denominator cancels the
foreshortening.) With ``material="none"`` the Fresnel factor is 1; an
explicit complex index ``eta + i k`` uses the exact conductor Fresnel.

Sampling draws a visible normal :math:`m \sim D_{w_i}` and reflects
:math:`w_i` about it; with the Jacobian :math:`1/(4\,w_o\cdot m)` of the
reflection,

.. math::
    p(w_o) = \frac{D_{w_i}(m)}{4\,w_o\cdot m} = \frac{D(m)\,G_1(w_i, m)}{4\cos\theta_i},
    \qquad \text{weight} = \frac{f\cos\theta_o}{p} = F\,G_1(w_o, m)\,R_s,

using Mitsuba's :math:`G_1` (rational approximation for Beckmann, see
:mod:`.microfacet`). Directions reflected below the surface are rejected.
"""
from __future__ import annotations

import numpy as np

from ..core.vec import dot_einsum
from ..scene.properties import Props
from ..scene.registry import register
from .base import BSDF, BSDFSample, as_colour_or_texture, make_sample
from .conductor import complex_ior, conductor_reflectance
from .fresnel import reflect_about
from .microfacet import RoughSurface, reflection_half_vector, textured_distribution
from .parameters import colour_or_texture, conductor_ior, microfacet_parameters, textures_only


class RoughConductor(RoughSurface, BSDF):
    r"""Microfacet conductor.

    Parameters
    ----------
    distribution : {"beckmann", "ggx"}
    alpha_u, alpha_v : float or Texture
        Roughness along the local tangent and bitangent (Mitsuba default 0.1); a texture
        gives it per hit (its ``eval_1``, as in Mitsuba).
    specular_reflectance : (3,) array_like
        Colour multiplying the reflection.
    eta, k : (3,) array_like, optional
        Complex index of refraction. The default ``0 + 1i`` is Mitsuba's
        ``material="none"``: Fresnel factor exactly 1.
    sample_visible : bool
        Sample visible normals (default) or :math:`D(m)\cos\theta_m`; then
        :math:`p = D\cos\theta_m/(4\,w_o\cdot m)` and the weight is
        :math:`F\,G\,(w_i\cdot m)/(\cos\theta_i\cos\theta_m)`.
    """

    texture_params = ("specular_reflectance",)
    scalar_texture_params = ("alpha_u", "alpha_v")
    has_smooth = True
    is_delta = False

    def __init__(self, distribution: str = "beckmann", alpha_u: float = 0.1,
                 alpha_v: float | None = None, specular_reflectance=1.0,
                 eta=0.0, k=1.0, sample_visible: bool = True):
        self.distr = textured_distribution(self, distribution, alpha_u, alpha_v, sample_visible)
        self.specular_reflectance = as_colour_or_texture(specular_reflectance)
        self.eta_complex = complex_ior(eta, k)

    def fresnel(self, cos_theta: np.ndarray) -> np.ndarray:
        """Conductor Fresnel factor times ``specular_reflectance`` -> (n, 3)."""
        return conductor_reflectance(cos_theta, self.eta_complex, self.specular_reflectance)

    def eval(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        r""":math:`F\,D(h)\,G(w_i, w_o, h)\,R_s / (4\cos\theta_i)` -> (n, 3)."""
        h, active = reflection_half_vector(wi, wo)
        D = self.distr.eval(h)
        G = self.distr.G(wi, wo, h)
        with np.errstate(divide="ignore", invalid="ignore"):
            value = D * G / (4.0 * wi[:, 2])
        value = np.where(active & (D != 0.0), value, 0.0)
        return value[:, None] * self.fresnel(dot_einsum(wi, h))

    def pdf(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        r""":math:`D(h)\,G_1(w_i, h)/(4\cos\theta_i)` (Mitsuba's :math:`G_1`) -> (n,)."""
        return self._pdf(wi, wo, self.distr.smith_g1)

    def pdf_exact(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Density that :meth:`sample` actually draws from (exact Smith G1; equals :meth:`pdf` for GGX)."""
        return self._pdf(wi, wo, self.distr.smith_g1_exact)

    def _pdf(self, wi: np.ndarray, wo: np.ndarray, smith_g1) -> np.ndarray:
        """Reflection pdf with the given masking function; 0 where micro- and macro-surface disagree."""
        h, active = reflection_half_vector(wi, wo)
        active &= (dot_einsum(wi, h) > 0.0) & (dot_einsum(wo, h) > 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            if self.distr.sample_visible:
                result = self.distr.eval(h) * smith_g1(wi, h) / (4.0 * wi[:, 2])
            else:
                result = self.distr.pdf(wi, h) / (4.0 * dot_einsum(wo, h))
        return np.where(active, result, 0.0)

    def sample(self, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray) -> BSDFSample:
        """Reflect ``wi`` about a sampled visible normal; invalid if ``wi`` or ``wo`` is below the surface."""
        up = wi[:, 2] > 0.0
        wi_up = np.where(up[:, None], wi, np.array([0.0, 0.0, 1.0]))
        m, pdf_m = self.distr.sample(wi_up, u2)
        wo = reflect_about(wi_up, m)
        cos_o_m = dot_einsum(wo, m)
        with np.errstate(divide="ignore", invalid="ignore"):
            pdf = pdf_m / (4.0 * cos_o_m)
        valid = up & (pdf_m > 0.0) & (wo[:, 2] > 0.0) & np.isfinite(pdf) & np.all(np.isfinite(m), axis=1)
        weight = self._sample_weight(wi_up, wo, m)[:, None] * self.fresnel(dot_einsum(wi_up, m))
        return make_sample(wo, weight, pdf, delta=False, eta=1.0, valid=valid)

    def _sample_weight(self, wi: np.ndarray, wo: np.ndarray, m: np.ndarray) -> np.ndarray:
        """``eval / pdf`` without the Fresnel factor, for a normal drawn by the distribution."""
        if self.distr.sample_visible:
            return self.distr.smith_g1(wo, m)
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.distr.G(wi, wo, m) * dot_einsum(wi, m) / (wi[:, 2] * m[:, 2])


@register("bsdf", "roughconductor")
def create(props: Props) -> RoughConductor:
    """A ``conductor``'s parameters and the microfacet ones (``distribution``, ``alpha`` or
    ``alpha_u``/``alpha_v``, each a number or a texture, ``sample_visible``)."""
    textures_only(props)
    eta, k = conductor_ior(props)
    distribution, alpha_u, alpha_v, sample_visible = microfacet_parameters(props)
    return RoughConductor(distribution, alpha_u, alpha_v,
                          colour_or_texture(props, "specular_reflectance", 1.0), eta, k,
                          sample_visible)
