r"""Disney's principled BSDF (Burley 2012, 2015), Mitsuba 3's ``principled`` plugin.

With :math:`m` = metallic, :math:`s` = spec_trans, the lobe weights are
:math:`w_r = (1 - m)(1 - s)` (diffuse) and :math:`w_t = (1 - m)\,s` (transmission). For
:math:`w_i` on either side, :math:`\eta'` (:math:`\eta` seen from outside, :math:`1/\eta`
from inside) and the half vector :math:`h` of :mod:`.roughdielectric` (turned up), the value
:math:`f\,|\cos\theta_o|` is the sum of

* the main GGX lobe (anisotropic :math:`\alpha_u, \alpha_v` from roughness and
  anisotropic, :func:`.principled_lobes.distribution_alphas`), reflection
  :math:`F\,D\,G / (4|\cos\theta_i|)` with the colour Fresnel of
  :func:`.principled_lobes.principled_fresnel`;
* its transmission, :math:`\sqrt{c}\,w_t\,|(1 - F_d)\,D\,G\,(w_i\cdot h)(w_o\cdot h) /
  (\cos\theta_i\,(w_i\cdot h + \eta' w_o\cdot h)^2)|` (the :math:`1/\eta'^2` radiance
  scaling included, :math:`c` = base_color);
* the clearcoat, :math:`\tfrac14 k\,F_{Schlick}(0.04)\,D_{GTR1}\,G_{cc}\,|\cos\theta_o|`
  (:math:`k` = clearcoat; front side only);
* the diffuse lobe (front side only, :math:`F_{i,o} = S(|\cos\theta_{i,o}|)`,
  :math:`R_r = 2 r (h\cdot w_o)^2`),
  :math:`w_r\,c\,|\cos\theta_o|/\pi\;\mathrm{lerp}(f_d + f_{retro}, f_{ss}, \text{flatness})`
  with :math:`f_d = (1 - F_i/2)(1 - F_o/2)`,
  :math:`f_{retro} = R_r (F_o + F_i + F_o F_i (R_r - 1))` and Hanrahan-Krueger's
  :math:`f_{ss} = 1.25\,(F_{ss}(1/(|\cos\theta_o| + |\cos\theta_i|) - 1/2) + 1/2)`,
  :math:`F_{ss} = \mathrm{lerp}(1, R_r/2, F_o)\,\mathrm{lerp}(1, R_r/2, F_i)`;
* the sheen, :math:`\text{sheen}\,(1 - m)\,S(|h\cdot w_o|)\,\mathrm{lerp}(1, c/\mathrm{lum}(c),
  \text{sheen\_tint})\,|\cos\theta_o|` (front side only).

Sampling picks a lobe with probabilities proportional to (front side)
:math:`\rho_s (1 - w_t (1 - F_d))`, :math:`\rho_s w_t (1 - F_d)`, :math:`\rho_c k/4`,
:math:`\rho_d w_r` (the ``*_sampling_rate`` properties :math:`\rho`; :math:`F_d` of the
sampled visible normal), or :math:`F_d` and :math:`1 - F_d` from inside; the density is the
mixture of the GGX visible-normal densities (reflection and refraction Jacobians), the
GTR1 normal density and :math:`\cos\theta_o/\pi`, with the same probabilities evaluated at
the half vector of :math:`w_o`; the weight is ``eval / pdf``. As in Mitsuba.

One difference from Mitsuba's ``scalar_*`` variants: they add the sheen only where the
diffuse lobe is active, so with spec_trans exactly 1 they drop it; their vectorised
variants, and this plugin, add it wherever its own mask holds.
"""
from __future__ import annotations

import numpy as np

from ..core import sampling
from ..core.vec import dot_einsum
from ..scene.properties import Props
from ..scene.registry import register
from . import principled_lobes as lobes
from .base import BSDF, BSDFSample, as_colour_or_texture, make_sample
from .fresnel import fresnel_dielectric, reflect_about, refract_about
from .microfacet import MicrofacetDistribution, _normalize
from .parameters import colour_or_texture, scalar_or_texture, textures_only
from .roughdielectric import _mulsign_z

#: Scalar parameters (number or texture read with ``eval_1``) and their defaults; the
#: attribute of ``anisotropic`` is ``anisotropy`` (BSDF.anisotropic is the frame flag).
SCALAR_DEFAULTS = {"roughness": 0.5, "anisotropic": 0.0, "metallic": 0.0, "spec_trans": 0.0,
                   "spec_tint": 0.0, "sheen": 0.0, "sheen_tint": 0.0, "flatness": 0.0,
                   "clearcoat": 0.0, "clearcoat_gloss": 0.0}
SAMPLING_RATES = {"diffuse_reflectance_sampling_rate": 1.0,
                  "main_specular_sampling_rate": 1.0, "clearcoat_sampling_rate": 1.0}
_ATTRIBUTE = {"anisotropic": "anisotropy"}


def eta_from_specular(specular: float) -> float:
    r"""Mitsuba's map of ``specular`` to the index: :math:`\eta = 2/(1 - \sqrt{0.08\,s}) - 1`."""
    return 2.0 / (1.0 - np.sqrt(0.08 * specular)) - 1.0


class Principled(BSDF):
    """Mitsuba's principled BSDF; every parameter but ``eta`` may be a texture.

    Parameters are those of the plugin (module docstring); ``eta`` None takes it from
    ``specular``. A lobe whose parameter is the number 0 is off, as in Mitsuba (which
    matters only for the density seen from inside when spec_trans is off).
    """

    texture_params = ("base_color",)
    scalar_texture_params = tuple(_ATTRIBUTE.get(name, name) for name in SCALAR_DEFAULTS)
    has_smooth = True
    is_delta = False

    def __init__(self, base_color=0.5, eta: float | None = None, specular: float = 0.5,
                 diffuse_reflectance_sampling_rate: float = 1.0,
                 main_specular_sampling_rate: float = 1.0, clearcoat_sampling_rate: float = 1.0,
                 **scalars):
        lobes.set_scalars(self, "principled", scalars, SCALAR_DEFAULTS, _ATTRIBUTE,
                          always=("roughness", "clearcoat_gloss"))
        self.base_color = as_colour_or_texture(base_color)
        has_st = self.on["spec_trans"]
        if eta is None:
            specular = 1e-3 if has_st and specular == 0.0 else float(specular)
            eta = eta_from_specular(specular)
        elif has_st and eta == 1.0:
            eta = 1.001
        if not eta > 0.0:
            raise ValueError("the index of refraction eta must be positive")
        self.eta = float(eta)
        self.diffuse_rate = float(diffuse_reflectance_sampling_rate)
        self.specular_rate = float(main_specular_sampling_rate)
        self.clearcoat_rate = float(clearcoat_sampling_rate)
        self.refracts = has_st

    @property
    def anisotropic(self) -> bool:
        """Sees the tangent frame when ``anisotropic`` is on."""
        return self.on["anisotropic"]

    # ------------------------------------------------------------------
    # Shared pieces
    # ------------------------------------------------------------------

    def _param(self, name: str, n: int) -> np.ndarray:
        return np.broadcast_to(np.asarray(getattr(self, name), dtype=np.float64), (n,))

    def _distribution(self, n: int) -> MicrofacetDistribution:
        alpha_u, alpha_v = lobes.distribution_alphas(self._param("roughness", n),
                                                     self._param("anisotropy", n),
                                                     self.on["anisotropic"])
        return MicrofacetDistribution("ggx", alpha_u, alpha_v, True)

    def _weights(self, n: int):
        """Diffuse and transmission weights (1 - m)(1 - s), (1 - m) s -> (n,), (n,)."""
        metallic, spec_trans = self._param("metallic", n), self._param("spec_trans", n)
        return (1.0 - metallic) * (1.0 - spec_trans), (1.0 - metallic) * spec_trans

    def _probabilities(self, front, F, brdf, bsdf, n):
        """Lobe-selection probabilities (diffuse, clearcoat, transmission, reflection)."""
        p_r = np.where(front, self.specular_rate * (1.0 - bsdf * (1.0 - F)), F)
        zero = np.zeros(n)
        p_t = np.where(front, self.specular_rate * bsdf * (1.0 - F), 1.0 - F) \
            if self.on["spec_trans"] else zero
        p_c = np.where(front, 0.25 * self._param("clearcoat", n) * self.clearcoat_rate, 0.0) \
            if self.on["clearcoat"] else zero
        p_d = np.where(front, brdf * self.diffuse_rate, 0.0)
        total = p_r + p_t + p_c + p_d
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(total > 0.0, 1.0 / total, 0.0)
        return p_d * scale, p_c * scale, p_t * scale, p_r * scale

    def _half_vector(self, wi: np.ndarray, wo: np.ndarray):
        """Reflection / refraction masks, :math:`\\eta'`, the half vector (upper side), and
        where it is defined."""
        cos_i, cos_o = wi[:, 2], wo[:, 2]
        reflect, refract = cos_i * cos_o > 0.0, cos_i * cos_o < 0.0
        eta_path = np.where(cos_i > 0.0, self.eta, 1.0 / self.eta)
        with np.errstate(divide="ignore", invalid="ignore"):
            h = _normalize(wi + wo * np.where(reflect, 1.0, eta_path)[:, None])
        h = _mulsign_z(h, h[:, 2])
        finite = np.all(np.isfinite(h), axis=1)
        h = np.where(finite[:, None], h, np.array([0.0, 0.0, 1.0]))
        return reflect, refract, eta_path, h, finite & (cos_i != 0.0)

    # ------------------------------------------------------------------
    # BSDF interface
    # ------------------------------------------------------------------

    def eval(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Sum of the five lobes (module docstring) -> (n, 3)."""
        n = wi.shape[0]
        reflect, refract, eta_path, h, active = self._half_vector(wi, wo)
        cos_i = np.where(active, wi[:, 2], 1.0)
        abs_o = np.abs(wo[:, 2])
        front = cos_i > 0.0
        base = np.broadcast_to(self.base_color, (n, 3))
        metallic = self._param("metallic", n)
        brdf, bsdf = self._weights(n)
        distr = self._distribution(n)
        dot_i, dot_o = dot_einsum(wi, h), dot_einsum(wo, h)
        F_d = fresnel_dielectric(dot_i, self.eta)[0]
        agree_r = lobes.macro_micro_agree(h, wi, wo, cos_i, True)
        D, G = distr.eval(h), distr.G(wi, wo, h)
        value = np.zeros((n, 3))

        on = active & reflect & agree_r & (F_d > 0.0)
        F = lobes.principled_fresnel(F_d, metallic, self._param("spec_tint", n), base, dot_i,
                                     front, bsdf, self.eta)
        with np.errstate(divide="ignore", invalid="ignore"):
            value += np.where(on[:, None], F * (D * G / (4.0 * np.abs(cos_i)))[:, None], 0.0)

        if self.on["spec_trans"]:
            on = active & (bsdf > 0.0) & refract & (F_d < 1.0) \
                & lobes.macro_micro_agree(h, wi, wo, cos_i, False)
            with np.errstate(divide="ignore", invalid="ignore"):
                # Walter's eta'^2 times the radiance scaling 1/eta'^2.
                t = bsdf * np.abs((1.0 - F_d) * D * G * dot_i * dot_o
                                  / (cos_i * (dot_i + eta_path * dot_o) ** 2))
            value += np.where(on[:, None], np.sqrt(base) * t[:, None], 0.0)

        if self.on["clearcoat"]:
            clearcoat = self._param("clearcoat", n)
            on = active & (clearcoat > 0.0) & reflect & agree_r & front
            alpha = lobes.clearcoat_alpha(self._param("clearcoat_gloss", n))
            c = (0.25 * clearcoat * lobes.schlick_fresnel(0.04, dot_i, self.eta)
                 * lobes.gtr1_eval(h, alpha) * lobes.clearcoat_G(wi, wo, h) * abs_o)
            value += np.where(on, c, 0.0)[:, None]

        F_o, F_i = lobes.schlick_weight(abs_o), lobes.schlick_weight(np.abs(cos_i))
        on = active & (brdf > 0.0) & reflect & front
        roughness = self._param("roughness", n)
        Rr = 2.0 * roughness * dot_o * dot_o
        diffuse = lobes.diffuse_retro(F_o, F_i, Rr)
        if self.on["flatness"]:
            flatness = self._param("flatness", n)
            F_ss = lobes.subsurface_fresnel(F_o, F_i, Rr)
            with np.errstate(divide="ignore", invalid="ignore"):
                f_ss = 1.25 * (F_ss * (1.0 / (abs_o + np.abs(cos_i)) - 0.5) + 0.5)
            diffuse = diffuse * (1.0 - flatness) + f_ss * flatness
        d = brdf * abs_o * diffuse / np.pi
        value += np.where(on[:, None], d[:, None] * base, 0.0)

        if self.on["sheen"]:
            sheen = self._param("sheen", n)
            on = active & (sheen > 0.0) & reflect & (1.0 - metallic > 0.0) & front
            s = sheen * (1.0 - metallic) * lobes.schlick_weight(np.abs(dot_o)) * abs_o
            if self.on["sheen_tint"]:
                sheen_tint = self._param("sheen_tint", n)[:, None]
                colour = 1.0 - sheen_tint + lobes.tint(base) * sheen_tint
            else:
                colour = np.ones((1, 3))
            value += np.where(on[:, None], s[:, None] * colour, 0.0)
        ok = active & np.all(np.isfinite(value), axis=1)
        return np.where(ok[:, None], value, 0.0)

    def pdf(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Mixture density of :meth:`sample` -> (n,)."""
        n = wi.shape[0]
        reflect, refract, eta_path, h, active = self._half_vector(wi, wo)
        cos_i = np.where(active, wi[:, 2], 1.0)
        front = cos_i > 0.0
        brdf, bsdf = self._weights(n)
        dot_i, dot_o = dot_einsum(wi, h), dot_einsum(wo, h)
        F_d = fresnel_dielectric(dot_i, self.eta)[0]
        p_d, p_c, p_t, p_r = self._probabilities(front, F_d, brdf, bsdf, n)
        with np.errstate(divide="ignore", invalid="ignore"):
            if self.on["spec_trans"]:
                jacobian = np.abs(np.where(reflect, 1.0 / (4.0 * dot_o),
                                           eta_path ** 2 * dot_o / (dot_i + eta_path * dot_o) ** 2))
            else:
                jacobian = np.abs(1.0 / (4.0 * dot_o))
            visible = self._distribution(n).pdf(_mulsign_z(wi, cos_i), h)
        agree_r = lobes.macro_micro_agree(h, wi, wo, cos_i, True) & reflect
        pdf = np.where(agree_r, p_r * visible * jacobian, 0.0)
        pdf += np.where(reflect, p_d * sampling.INV_PI * wo[:, 2], 0.0)
        if self.on["spec_trans"]:
            agree_t = lobes.macro_micro_agree(h, wi, wo, cos_i, False) & refract
            pdf += np.where(agree_t, p_t * visible * jacobian, 0.0)
        if self.on["clearcoat"]:
            alpha = lobes.clearcoat_alpha(self._param("clearcoat_gloss", n))
            pdf += np.where(agree_r, p_c * lobes.gtr1_pdf(h, alpha) * jacobian, 0.0)
        return np.where(active & np.isfinite(pdf), pdf, 0.0)

    def sample(self, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray) -> BSDFSample:
        """Pick a lobe by ``u1`` (diffuse, clearcoat, transmission, reflection, in that order
        along [0, 1)), draw its direction with ``u2``; weight = eval / pdf."""
        n = wi.shape[0]
        cos_i = wi[:, 2]
        front = cos_i > 0.0
        brdf, bsdf = self._weights(n)
        active = (cos_i != 0.0) & (front | (bsdf > 0.0))
        wi_up = np.where(active[:, None], _mulsign_z(wi, cos_i), np.array([0.0, 0.0, 1.0]))
        m, _ = self._distribution(n).sample(wi_up, u2)
        m = np.where(np.all(np.isfinite(m), axis=1)[:, None], m, np.array([0.0, 0.0, 1.0]))
        F_d, cos_t, eta_it, eta_ti = fresnel_dielectric(dot_einsum(wi, m), self.eta)
        p_d, p_c, p_t, _ = self._probabilities(front, F_d, brdf, bsdf, n)
        pick_d = u1 < p_d
        pick_c = (u1 >= p_d) & (u1 < p_d + p_c)
        pick_t = (u1 >= p_d + p_c) & (u1 < p_d + p_c + p_t)
        pick_r = u1 >= p_d + p_c + p_t

        alpha_cc = lobes.clearcoat_alpha(self._param("clearcoat_gloss", n))
        m_cc = lobes.gtr1_sample(u2, alpha_cc) if self.on["clearcoat"] else m
        with np.errstate(invalid="ignore"):
            wo = np.where(pick_r[:, None], reflect_about(wi, m), 0.0)
            wo = np.where(pick_t[:, None], refract_about(wi, m, cos_t, eta_ti), wo)
            wo = np.where(pick_c[:, None], reflect_about(wi, m_cc), wo)
            wo = np.where(pick_d[:, None], sampling.square_to_cosine_hemisphere(u2), wo)
        wo = np.where(np.isfinite(wo), wo, 0.0)
        side = cos_i * wo[:, 2]
        lobe_normal = np.where(pick_c[:, None], m_cc, m)
        active &= ~(pick_r | pick_c) | (lobes.macro_micro_agree(lobe_normal, wi, wo, cos_i, True)
                                        & (side > 0.0))
        active &= ~pick_t | (lobes.macro_micro_agree(m, wi, wo, cos_i, False) & (side < 0.0))
        active &= ~pick_d | (side > 0.0)
        pdf = np.where(active, self.pdf(wi, wo), 0.0)
        valid = active & (pdf > 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            weight = self.eval(wi, wo) / np.where(valid, pdf, 1.0)[:, None]
        eta = np.where(pick_t, eta_it, 1.0)
        return make_sample(wo, weight, pdf, delta=False, eta=eta, valid=valid)


@register("bsdf", "principled")
def create(props: Props) -> Principled:
    """Mitsuba's properties: ``base_color`` (colour or texture), the scalar parameters
    (number or texture), ``eta`` or ``specular`` (numbers, not both), the sampling rates."""
    textures_only(props)
    plugin = props.plugin
    if props.has("eta") and props.has("specular"):
        raise plugin.error("give either eta or specular, not both (they set the same index)",
                           props.line("specular"))
    scalars = {name: scalar_or_texture(props, name, default)
               for name, default in SCALAR_DEFAULTS.items()}
    rates = {name: props.float(name, default) for name, default in SAMPLING_RATES.items()}
    for name, value in rates.items():
        if not value >= 0.0:
            raise plugin.error(f"\"{name}\" must be >= 0", props.line(name))
    eta = props.float("eta", None)
    if eta is not None and not eta > 0.0:
        raise plugin.error("\"eta\" must be positive", props.line("eta"))
    specular = props.float("specular", 0.5)
    if not 0.0 <= specular < 12.5:
        raise plugin.error("\"specular\" must be in [0, 12.5) (eta = 2 / (1 - sqrt(0.08 "
                           "specular)) - 1)", props.line("specular"))
    return Principled(colour_or_texture(props, "base_color", 0.5), eta=eta, specular=specular,
                      **rates, **scalars)
