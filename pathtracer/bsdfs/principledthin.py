r"""The thin principled BSDF (Burley 2015), Mitsuba 3's ``principledthin`` plugin.

A two-dimensional sheet seen alike from both sides: ``wi`` and ``wo`` are mirrored so that
:math:`\cos\theta_i > 0`, and :math:`w_o^r` is ``wo`` with :math:`|z|`; the half vector is
:math:`h = \mathrm{normalize}(w_i + w_o^r)` for reflection and transmission alike (light
crosses the sheet without bending, ``bs.eta`` = 1). With :math:`s` = spec_trans and
:math:`d` = diff_trans / 2, :math:`f\,|\cos\theta_o|` is the sum of

* specular reflection, :math:`s\,F\,D\,G / (4\cos\theta_i)` (GGX of
  :func:`.principled_lobes.distribution_alphas`, :math:`F` =
  :func:`.principled_lobes.thin_fresnel`); only where :math:`s > 0`, as in Mitsuba;
* specular transmission, :math:`s\,c\,(1 - F_d)\,D'\,G' / (4\cos\theta_i)` with the roughness
  scaled by :math:`0.65\,\eta - 0.35` (Burley 2015, figure 15; :math:`c` = base_color);
* the diffuse, retro-reflection, fake-subsurface and sheen terms of :mod:`.principled`
  times :math:`(1 - s)(1 - d)`;
* Lambertian transmission, :math:`(1 - s)\,d\,c\,|\cos\theta_o|/\pi`.

Sampling picks specular reflection, specular transmission (a reflection about a visible
normal of the scaled distribution, mirrored through the sheet), cosine reflection or cosine
transmission with probabilities proportional to :math:`\rho_{sr} s/2`, :math:`\rho_{st} s/2`,
:math:`\rho_{dr}(1 - s)(1 - d)`, :math:`\rho_{dt}(1 - s)\,d` (the ``*_sampling_rate``
properties); the density is the mixture with the Jacobian :math:`1/(4\,w_o^r\cdot h)` and
the weight ``eval / pdf``. ``eta`` may be a texture.
"""
from __future__ import annotations

import numpy as np

from ..core import sampling
from ..core.vec import dot_einsum
from ..scene.properties import Props
from ..scene.registry import register
from ..textures.base import Texture
from . import principled_lobes as lobes
from .base import BSDF, BSDFSample, as_colour_or_texture, make_sample
from .fresnel import fresnel_dielectric, reflect_about
from .microfacet import MicrofacetDistribution, _normalize
from .parameters import colour_or_texture, scalar_or_texture, textures_only
from .roughdielectric import _mulsign_z

SCALAR_DEFAULTS = {"roughness": 0.5, "anisotropic": 0.0, "spec_trans": 0.0, "spec_tint": 0.0,
                   "sheen": 0.0, "sheen_tint": 0.0, "flatness": 0.0, "diff_trans": 0.0,
                   "eta": 1.5}
SAMPLING_RATES = {"specular_reflectance_sampling_rate": 1.0,
                  "specular_transmittance_sampling_rate": 1.0,
                  "diffuse_reflectance_sampling_rate": 1.0,
                  "diffuse_transmittance_sampling_rate": 1.0}
#: Attribute names where the property's would clash with the BSDF interface.
_ATTRIBUTE = {"anisotropic": "anisotropy", "eta": "eta_thin"}
_ALWAYS = ("roughness", "eta")


class PrincipledThin(BSDF):
    """Mitsuba's thin principled BSDF; every parameter may be a texture (``eta`` too)."""

    texture_params = ("base_color",)
    scalar_texture_params = tuple(_ATTRIBUTE.get(name, name) for name in SCALAR_DEFAULTS)
    has_smooth = True
    is_delta = False

    def __init__(self, base_color=0.5, specular_reflectance_sampling_rate: float = 1.0,
                 specular_transmittance_sampling_rate: float = 1.0,
                 diffuse_reflectance_sampling_rate: float = 1.0,
                 diffuse_transmittance_sampling_rate: float = 1.0, **scalars):
        lobes.set_scalars(self, "principledthin", scalars, SCALAR_DEFAULTS, _ATTRIBUTE,
                          always=_ALWAYS)
        self.base_color = as_colour_or_texture(base_color)
        self.rates = (float(specular_reflectance_sampling_rate),
                      float(specular_transmittance_sampling_rate),
                      float(diffuse_reflectance_sampling_rate),
                      float(diffuse_transmittance_sampling_rate))

    @property
    def anisotropic(self) -> bool:
        """Sees the tangent frame when ``anisotropic`` is on."""
        return self.on["anisotropic"]

    def _param(self, name: str, n: int) -> np.ndarray:
        return np.broadcast_to(np.asarray(getattr(self, name), dtype=np.float64), (n,))

    def _distributions(self, n: int):
        """GGX of the reflection and of the transmission (roughness scaled by the index)."""
        roughness, anisotropy = self._param("roughness", n), self._param("anisotropy", n)
        scaled = (0.65 * self._param("eta_thin", n) - 0.35) * roughness
        on = self.on["anisotropic"]
        reflection = MicrofacetDistribution(
            "ggx", *lobes.distribution_alphas(roughness, anisotropy, on), True)
        transmission = MicrofacetDistribution(
            "ggx", *lobes.distribution_alphas(scaled, anisotropy, on), True)
        return reflection, transmission

    def _probabilities(self, n: int):
        """Normalised probabilities of specular reflection and transmission, cosine
        reflection and transmission -> four (n,)."""
        spec_trans, diff_trans = self._param("spec_trans", n), 0.5 * self._param("diff_trans", n)
        rate_sr, rate_st, rate_dr, rate_dt = self.rates
        zero = np.zeros(n)
        p_sr = spec_trans * rate_sr / 2.0 if self.on["spec_trans"] else zero
        p_st = spec_trans * rate_st / 2.0 if self.on["spec_trans"] else zero
        p_dr = rate_dr * (1.0 - spec_trans) * (1.0 - diff_trans)
        p_dt = rate_dt * (1.0 - spec_trans) * diff_trans if self.on["diff_trans"] else zero
        total = p_sr + p_st + p_dr + p_dt
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(total > 0.0, 1.0 / total, 0.0)
        return p_sr * scale, p_st * scale, p_dr * scale, p_dt * scale

    @staticmethod
    def _front(wi: np.ndarray, wo: np.ndarray):
        """Both directions mirrored to ``wi``'s front side, and the half vector of the
        reflection of ``wo`` onto it."""
        wi_t, wo_t = _mulsign_z(wi, wi[:, 2]), _mulsign_z(wo, wi[:, 2])
        wo_r = wo_t * np.array([1.0, 1.0, 0.0]) + np.abs(wo_t) * np.array([0.0, 0.0, 1.0])
        with np.errstate(divide="ignore", invalid="ignore"):
            h = _normalize(wi_t + wo_r)
        h = np.where(np.all(np.isfinite(h), axis=1)[:, None], h, np.array([0.0, 0.0, 1.0]))
        return wi_t, wo_t, wo_r, h

    def eval(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Sum of the lobes (module docstring) -> (n, 3)."""
        n = wi.shape[0]
        active = wi[:, 2] != 0.0
        wi_t, wo_t, _, h = self._front(wi, wo)
        cos_i = np.where(active, wi_t[:, 2], 1.0)
        cos_o = wo_t[:, 2]
        reflect, refract = cos_o > 0.0, cos_o < 0.0
        base = np.broadcast_to(self.base_color, (n, 3))
        spec_trans, diff_trans = self._param("spec_trans", n), 0.5 * self._param("diff_trans", n)
        value = np.zeros((n, 3))
        if self.on["spec_trans"]:
            eta = self._param("eta_thin", n)
            dot_i = dot_einsum(wi_t, h)
            F_d = fresnel_dielectric(dot_i, eta)[0]
            distr_r, distr_t = self._distributions(n)
            on = active & (spec_trans > 0.0) & reflect \
                & lobes.macro_micro_agree(h, wi_t, wo_t, cos_i, True)
            F = lobes.thin_fresnel(F_d, self._param("spec_tint", n), base, dot_i, eta)
            r = spec_trans * distr_r.eval(h) * distr_r.G(wi_t, wo_t, h) / (4.0 * cos_i)
            value += np.where(on[:, None], F * r[:, None], 0.0)
            on = active & refract & (spec_trans > 0.0) \
                & lobes.macro_micro_agree(h, wi_t, wo_t, cos_i, False)
            t = spec_trans * (1.0 - F_d) * distr_t.eval(h) * distr_t.G(wi_t, wo_t, h) / (4.0 * cos_i)
            value += np.where(on[:, None], base * t[:, None], 0.0)

        on = active & reflect & (spec_trans < 1.0) & (diff_trans < 1.0)
        abs_o = np.abs(cos_o)
        F_o, F_i = lobes.schlick_weight(abs_o), lobes.schlick_weight(cos_i)
        cos_d = dot_einsum(h, wo_t)
        Rr = 2.0 * self._param("roughness", n) * cos_d * cos_d
        diffuse = lobes.diffuse_retro(F_o, F_i, Rr)
        if self.on["flatness"]:
            flatness = self._param("flatness", n)
            F_ss = lobes.subsurface_fresnel(F_o, F_i, Rr)
            with np.errstate(divide="ignore", invalid="ignore"):
                f_ss = 1.25 * (F_ss * (1.0 / (abs_o + cos_i) - 0.5) + 0.5)
            diffuse = diffuse * (1.0 - flatness) + f_ss * flatness
        d = (1.0 - spec_trans) * cos_o / np.pi * (1.0 - diff_trans) * diffuse
        value += np.where(on[:, None], d[:, None] * base, 0.0)
        if self.on["sheen"]:
            s = self._param("sheen", n) * (1.0 - spec_trans) * lobes.schlick_weight(np.abs(cos_d)) \
                * (1.0 - diff_trans) * abs_o
            if self.on["sheen_tint"]:
                sheen_tint = self._param("sheen_tint", n)[:, None]
                colour = 1.0 - sheen_tint + lobes.tint(base) * sheen_tint
            else:
                colour = np.ones((1, 3))
            value += np.where(on[:, None], s[:, None] * colour, 0.0)

        if self.on["diff_trans"]:
            on = active & refract & (spec_trans < 1.0) & (diff_trans > 0.0)
            t = (1.0 - spec_trans) * diff_trans / np.pi * abs_o
            value += np.where(on[:, None], t[:, None] * base, 0.0)
        ok = active & np.all(np.isfinite(value), axis=1)
        return np.where(ok[:, None], value, 0.0)

    def pdf(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Mixture density of :meth:`sample` -> (n,)."""
        n = wi.shape[0]
        active = wi[:, 2] != 0.0
        wi_t, wo_t, wo_r, h = self._front(wi, wo)
        cos_o = wo_t[:, 2]
        reflect, refract = cos_o > 0.0, cos_o < 0.0
        p_sr, p_st, p_dr, p_dt = self._probabilities(n)
        pdf = np.where(reflect, p_dr * sampling.INV_PI * cos_o, 0.0)
        if self.on["diff_trans"]:
            pdf += np.where(refract, p_dt * sampling.INV_PI * -cos_o, 0.0)
        if self.on["spec_trans"]:
            cos_i = np.where(active, wi_t[:, 2], 1.0)
            distr_r, distr_t = self._distributions(n)
            with np.errstate(divide="ignore", invalid="ignore"):
                jacobian = np.abs(1.0 / (4.0 * dot_einsum(wo_r, h)))
                wi_up = np.where(active[:, None], wi_t, np.array([0.0, 0.0, 1.0]))
                spec = np.where(lobes.macro_micro_agree(h, wi_t, wo_t, cos_i, True) & reflect,
                                p_sr * distr_r.pdf(wi_up, h) * jacobian, 0.0)
                spec += np.where(lobes.macro_micro_agree(h, wi_t, wo_t, cos_i, False) & refract,
                                 p_st * distr_t.pdf(wi_up, h) * jacobian, 0.0)
            pdf += spec
        return np.where(active & np.isfinite(pdf), pdf, 0.0)

    def sample(self, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray) -> BSDFSample:
        """Pick a lobe by ``u1`` (specular reflection, specular transmission, cosine
        reflection, cosine transmission along [0, 1)), draw its direction with ``u2`` on the
        front side, mirror back to ``wi``'s side; weight = eval / pdf."""
        n = wi.shape[0]
        cos_i = wi[:, 2]
        active = cos_i != 0.0
        wi_t = np.where(active[:, None], _mulsign_z(wi, cos_i), np.array([0.0, 0.0, 1.0]))
        p_sr, p_st, p_dr, _ = self._probabilities(n)
        spec = self.on["spec_trans"]
        pick_sr = spec & (u1 < p_sr)
        pick_st = spec & (u1 >= p_sr) & (u1 < p_sr + p_st)
        pick_dr = (u1 >= p_sr + p_st) & (u1 < p_sr + p_st + p_dr)
        pick_dt = self.on["diff_trans"] & (u1 >= p_sr + p_st + p_dr)
        up = np.ones(n)
        cosine = sampling.square_to_cosine_hemisphere(u2)
        wo = np.where(pick_dr[:, None], cosine, 0.0)
        wo = np.where(pick_dt[:, None], -cosine, wo)
        if spec:
            distr_r, distr_t = self._distributions(n)
            m_r, m_t = distr_r.sample(wi_t, u2)[0], distr_t.sample(wi_t, u2)[0]
            with np.errstate(invalid="ignore"):
                wo_sr = reflect_about(wi_t, m_r)
                wo_st = reflect_about(wi_t, m_t) * np.array([1.0, 1.0, -1.0])
            active &= ~pick_sr | (lobes.macro_micro_agree(m_r, wi_t, wo_sr, up, True)
                                  & (wo_sr[:, 2] > 0.0))
            active &= ~pick_st | (lobes.macro_micro_agree(m_t, wi_t, wo_st, up, False)
                                  & (wo_st[:, 2] < 0.0))
            wo = np.where(pick_sr[:, None], wo_sr, wo)
            wo = np.where(pick_st[:, None], wo_st, wo)
        wo = np.where(np.isfinite(wo), wo, 0.0)
        wo = _mulsign_z(wo, cos_i)
        pdf = np.where(active, self.pdf(wi, wo), 0.0)
        valid = active & (pdf > 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            weight = self.eval(wi, wo) / np.where(valid, pdf, 1.0)[:, None]
        return make_sample(wo, weight, pdf, delta=False, eta=1.0, valid=valid)


@register("bsdf", "principledthin")
def create(props: Props) -> PrincipledThin:
    """Mitsuba's properties: ``base_color`` (colour or texture), the scalar parameters and
    ``eta`` (number or texture), the four sampling rates."""
    textures_only(props)
    plugin = props.plugin
    scalars = {name: scalar_or_texture(props, name, default)
               for name, default in SCALAR_DEFAULTS.items()}
    if not isinstance(scalars["eta"], Texture) and not scalars["eta"] > 0.0:
        raise plugin.error("\"eta\" must be positive", props.line("eta"))
    rates = {name: props.float(name, default) for name, default in SAMPLING_RATES.items()}
    for name, value in rates.items():
        if not value >= 0.0:
            raise plugin.error(f"\"{name}\" must be >= 0", props.line(name))
    return PrincipledThin(colour_or_texture(props, "base_color", 0.5), **rates, **scalars)
