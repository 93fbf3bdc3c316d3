r"""Smooth plastic (a diffuse base under a smooth dielectric coating), Mitsuba's ``plastic`` plugin.

Two lobes: specular reflection at the coating, with the dielectric Fresnel
reflectance :math:`F_i = F(\cos\theta_i, \eta)`, and a diffuse lobe for the
light that enters the coating, scatters in the base and leaves again:

.. math::
    f(w_i, w_o)\cos\theta_o = \frac{\cos\theta_o}{\pi}\,\frac{1}{\eta^2}\,
        (1 - F_i)(1 - F_o)\,\frac{\rho}{1 - F_{dr}}

(one-sided: both cosines positive). :math:`\rho` is ``diffuse_reflectance``;
:math:`1/(1 - F_{dr})` sums the internal reflections at the coating, with
the hemispherically averaged internal reflectance
:math:`F_{dr} = F_{dr}(1/\eta)` (:func:`~pathtracer.bsdfs.fresnel.fresnel_diffuse_reflectance`).
With ``nonlinear`` each reflection also multiplies by :math:`\rho` again
(colour shift of a wet look): :math:`\rho / (1 - \rho F_{dr})`. The
:math:`1/\eta^2` accounts for the solid angle compression on entering.

Sampling (as Mitsuba): the specular lobe is picked with probability

.. math::
    P_s = \frac{F_i\,w}{F_i\,w + (1 - F_i)(1 - w)},\qquad
    w = \frac{\bar s}{\bar d + \bar s},

where :math:`\bar d` and :math:`\bar s` are the channel means of
``diffuse_reflectance`` and ``specular_reflectance`` (:math:`\bar s = 1` if
not given); its weight is :math:`F_i R_s / P_s` and ``pdf`` is :math:`P_s`
(delta). Otherwise the diffuse lobe is sampled cosine-weighted with pdf
:math:`(1 - P_s)\cos\theta_o/\pi`, which is also what :meth:`Plastic.pdf`
returns (the specular lobe has no density).
"""
from __future__ import annotations

import numpy as np

from ..core import sampling
from ..scene.properties import Props
from ..scene.registry import register
from ..textures.base import Texture
from .base import BSDF, BSDFSample, as_colour_or_texture, make_sample
from .dielectric import AIR_IOR
from .fresnel import fresnel_dielectric, fresnel_diffuse_reflectance, reflect
from .parameters import ior, plastic_parameters, textures_only

POLYPROPYLENE_IOR = 1.49


def specular_sampling_weight(diffuse_reflectance, specular_reflectance) -> float:
    r""":math:`w = \bar s / (\bar d + \bar s)` from the channel means (Mitsuba's lobe-selection weight).

    A texture counts with its :meth:`~pathtracer.textures.Texture.mean` (a bitmap's mean
    luminance), as Mitsuba computes the weight once for the whole surface.
    """
    s_mean = _mean(specular_reflectance)
    return s_mean / (_mean(diffuse_reflectance) + s_mean)


def _mean(value) -> float:
    """Mitsuba's ``mean()`` of a colour or a texture."""
    return float(value.mean()) if isinstance(value, Texture) else float(np.mean(value))


def specular_probability(F_i: np.ndarray, weight: float) -> np.ndarray:
    r"""Probability :math:`P_s` of picking the specular lobe, given the specular lobe's ``F_i`` -> (n,)."""
    specular = F_i * weight
    diffuse = (1.0 - F_i) * (1.0 - weight)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(specular + diffuse > 0.0, specular / (specular + diffuse), 1.0)


def internal_scattering(diffuse_reflectance: np.ndarray, internal_reflectance: float,
                        nonlinear: bool) -> np.ndarray:
    r""":math:`\rho/(1 - F_{dr})`, or :math:`\rho/(1 - \rho F_{dr})` when ``nonlinear`` -> (3,)."""
    if nonlinear:
        return diffuse_reflectance / (1.0 - diffuse_reflectance * internal_reflectance)
    return diffuse_reflectance / (1.0 - internal_reflectance)


class Plastic(BSDF):
    """Diffuse base under a smooth dielectric coating of index ``int_ior`` in ``ext_ior``.

    ``diffuse_reflectance`` and ``specular_reflectance`` may be textures.
    """

    texture_params = ("diffuse_reflectance", "specular_reflectance")
    has_smooth = True
    is_delta = False

    def __init__(self, diffuse_reflectance=0.5, specular_reflectance=1.0,
                 int_ior: float = POLYPROPYLENE_IOR, ext_ior: float = AIR_IOR,
                 nonlinear: bool = False):
        if int_ior < 0 or ext_ior < 0:
            raise ValueError("The interior and exterior indices of refraction must be positive")
        self.eta = float(int_ior) / float(ext_ior)
        self.diffuse_reflectance = as_colour_or_texture(diffuse_reflectance)
        self.specular_reflectance = as_colour_or_texture(specular_reflectance)
        self.nonlinear = bool(nonlinear)
        self.internal_reflectance = fresnel_diffuse_reflectance(1.0 / self.eta)
        self.specular_weight = specular_sampling_weight(self.diffuse_reflectance,
                                                        self.specular_reflectance)
        self.bind_derived()

    def bind_derived(self) -> None:
        """The base's scattered albedo divided by eta squared, per hit when textured."""
        if isinstance(self.diffuse_reflectance, Texture):
            self._diffuse = None
            return
        self._diffuse = internal_scattering(self.diffuse_reflectance, self.internal_reflectance,
                                            self.nonlinear) / (self.eta * self.eta)

    def _fresnel(self, cos_theta: np.ndarray) -> np.ndarray:
        return fresnel_dielectric(cos_theta, self.eta)[0]

    def _diffuse_value(self, F_i: np.ndarray, wo: np.ndarray) -> np.ndarray:
        r"""Diffuse lobe times foreshortening, :math:`\cos\theta_o/\pi\,(1-F_i)(1-F_o)\,\rho'/\eta^2` -> (n, 3)."""
        F_o = self._fresnel(wo[:, 2])
        scale = sampling.INV_PI * np.maximum(wo[:, 2], 0.0) * (1.0 - F_i) * (1.0 - F_o)
        return scale[:, None] * self._diffuse

    def eval(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """The diffuse lobe (the specular one is a Dirac delta) -> (n, 3)."""
        active = (wi[:, 2] > 0.0) & (wo[:, 2] > 0.0)
        value = self._diffuse_value(self._fresnel(wi[:, 2]), wo)
        return np.where(active[:, None], value, 0.0)

    def pdf(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        r"""Density of the diffuse lobe, :math:`(1 - P_s)\cos\theta_o/\pi` -> (n,)."""
        active = (wi[:, 2] > 0.0) & (wo[:, 2] > 0.0)
        p_diffuse = 1.0 - specular_probability(self._fresnel(wi[:, 2]), self.specular_weight)
        return np.where(active, p_diffuse * sampling.INV_PI * np.maximum(wo[:, 2], 0.0), 0.0)

    def sample(self, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray) -> BSDFSample:
        """Specular reflection if ``u1 < P_s``, else a cosine-weighted diffuse direction."""
        active = wi[:, 2] > 0.0
        F_i = self._fresnel(wi[:, 2])
        p_specular = specular_probability(F_i, self.specular_weight)
        selected_s = u1 < p_specular
        wo_diffuse = sampling.square_to_cosine_hemisphere(u2)
        wo = np.where(selected_s[:, None], reflect(wi), wo_diffuse)

        p_diffuse = 1.0 - p_specular
        pdf_diffuse = p_diffuse * sampling.INV_PI * np.maximum(wo_diffuse[:, 2], 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            weight_s = (F_i / p_specular)[:, None] * self.specular_reflectance
            weight_d = self._diffuse_value(F_i, wo_diffuse) / pdf_diffuse[:, None]
        weight = np.where(selected_s[:, None], weight_s, weight_d)
        pdf = np.where(selected_s, p_specular, pdf_diffuse)
        valid = active & (pdf > 0.0) & np.all(np.isfinite(weight), axis=1)
        return make_sample(wo, weight, pdf, delta=selected_s, eta=1.0, valid=valid)


@register("bsdf", "plastic")
def create(props: Props) -> Plastic:
    """``diffuse_reflectance`` (0.5), ``specular_reflectance`` (1), ``int_ior``
    (``polypropylene``), ``ext_ior`` (``air``), ``nonlinear`` (false)."""
    textures_only(props)
    int_ior, ext_ior = ior(props, "int_ior", "polypropylene"), ior(props, "ext_ior", "air")
    return Plastic(**plastic_parameters(props, int_ior, ext_ior))
