r"""The pieces of Mitsuba 3's ``principled`` BSDF that no other BSDF uses (Burley 2012, 2015).

All directions are in the local shading frame (:mod:`.base`); every function works on
(n,) or (n, 3) arrays.

Schlick's weight and his Fresnel approximation with Mitsuba's choice of cosine (the
transmitted one when light leaves the denser side, :math:`\eta_{it} < 1`):

.. math::
    S(c) = \operatorname{clip}(1 - c, 0, 1)^5,\qquad
    F_{Schlick}(R_0, c_i) = R_0 + (1 - R_0)\,S(c),\qquad R_0(\eta) = \left(\frac{\eta - 1}{\eta + 1}\right)^2.

The clearcoat's distribution (Burley's GTR with :math:`\gamma = 1`, no visible-normal
sampling) and its separable GGX masking at the fixed roughness 0.25:

.. math::
    D_{GTR1}(m) = \frac{\alpha^2 - 1}{\pi \log(\alpha^2)\,(1 + (\alpha^2 - 1)\cos^2\theta_m)},\qquad
    p(m) = D_{GTR1}(m)\cos\theta_m,\qquad
    \cos^2\theta_m = \frac{1 - (\alpha^2)^{1 - u_2}}{1 - \alpha^2}.

The main lobe's Fresnel factor blends the exact dielectric :math:`F_d` with Schlick terms
for the metal (tint :math:`c` = ``base_color``) and the tinted dielectric
(:math:`c / \mathrm{lum}(c)`):

.. math::
    F = (1 - m)(1 - t)\,F_d + m\,F_{Schlick}(c, c_i)
        + (1 - m)\,t\,F_{Schlick}\!\left(\tfrac{c}{\mathrm{lum}(c)} R_0(\eta_{it}), c_i\right)

on the front side (:math:`m` metallic, :math:`t` spec_tint), and
:math:`(1 - m)\,s\,F_d` from inside (:math:`s` spec_trans).
"""
from __future__ import annotations

import numpy as np

from ..core.color import LUMINANCE
from ..core.vec import dot_einsum
from ..textures.base import Texture

#: Smallest roughness of the main lobe (Mitsuba's ``calc_dist_params``).
ALPHA_FLOOR = 0.001
#: Roughness of the clearcoat's masking term (fixed, as in Burley's notes).
CLEARCOAT_G_ALPHA = 0.25


def lobe_is_on(value) -> bool:
    """A lobe is on when its parameter is a texture or a non-zero number (Mitsuba's get_flag)."""
    return isinstance(value, Texture) or float(value) != 0.0


def set_scalars(bsdf, kind: str, given: dict, defaults: dict, attribute: dict, always=()) -> None:
    """Set ``bsdf``'s scalar parameters (numbers or textures) from ``given`` over ``defaults``,
    and ``bsdf.on[name]`` (:func:`lobe_is_on`). An off lobe's parameter reads 0 (Mitsuba skips
    its texture) unless it is in ``always``; ``attribute`` renames a parameter's attribute."""
    unknown = set(given) - set(defaults)
    if unknown:
        raise TypeError(f"unknown {kind} parameters: {', '.join(sorted(unknown))}")
    bsdf.on = {}
    for name, default in defaults.items():
        value = given.get(name, default)
        bsdf.on[name] = lobe_is_on(value)
        value = value if bsdf.on[name] or name in always else 0.0
        setattr(bsdf, attribute.get(name, name),
                value if isinstance(value, Texture) else float(value))


def diffuse_retro(F_o, F_i, Rr):
    """Burley's diffuse with retro-reflection, without the ``base_color / pi``:
    ``(1 - F_i / 2)(1 - F_o / 2) + Rr (F_o + F_i + F_o F_i (Rr - 1))``, ``F`` the Schlick
    weights of the two directions and ``Rr = 2 roughness cos_d^2``."""
    return (1.0 - 0.5 * F_i) * (1.0 - 0.5 * F_o) + Rr * (F_o + F_i + F_o * F_i * (Rr - 1.0))


def subsurface_fresnel(F_o, F_i, Rr):
    """The fake subsurface lobe's ``F_ss = (1 - F_o + ss90 F_o)(1 - F_i + ss90 F_i)``,
    ``ss90 = Rr / 2``."""
    ss90 = 0.5 * Rr
    return (1.0 - F_o + ss90 * F_o) * (1.0 - F_i + ss90 * F_i)


def luminance(colour: np.ndarray) -> np.ndarray:
    """Luminance of (3,) or (n, 3) linear RGB -> () or (n,)."""
    return np.asarray(colour) @ LUMINANCE


def tint(colour: np.ndarray) -> np.ndarray:
    """``colour`` divided by its luminance (white where that is 0) -> (3,) or (n, 3)."""
    colour = np.asarray(colour, dtype=np.float64)
    lum = luminance(colour)[..., None]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(lum > 0.0, colour / np.where(lum > 0.0, lum, 1.0), 1.0)


def distribution_alphas(roughness, anisotropy, anisotropic: bool):
    r"""GGX roughnesses :math:`(\alpha_u, \alpha_v) = (r^2/a, r^2 a)`, :math:`a = \sqrt{1 - 0.9\,k}`
    (:math:`k` = ``anisotropic``), each at least 0.001; :math:`r^2` for both when isotropic."""
    r2 = np.square(roughness)
    if not anisotropic:
        alpha = np.maximum(ALPHA_FLOOR, r2)
        return alpha, alpha
    aspect = np.sqrt(1.0 - 0.9 * np.asarray(anisotropy, dtype=np.float64))
    return np.maximum(ALPHA_FLOOR, r2 / aspect), np.maximum(ALPHA_FLOOR, r2 * aspect)


def schlick_weight(cos: np.ndarray) -> np.ndarray:
    """:math:`\\operatorname{clip}(1 - c, 0, 1)^5`."""
    m = np.clip(1.0 - cos, 0.0, 1.0)
    return np.square(np.square(m)) * m


def schlick_r0(eta) -> np.ndarray:
    """Normal-incidence reflectance of a dielectric of relative index ``eta``."""
    eta = np.asarray(eta, dtype=np.float64)
    return np.square((eta - 1.0) / (eta + 1.0))


def schlick_fresnel(r0, cos_theta_i: np.ndarray, eta) -> np.ndarray:
    """Schlick's Fresnel term, with the transmitted cosine when leaving the denser side.

    ``r0`` is a number, (3,), (n,) or (n, 3); ``cos_theta_i`` (n,) is signed (negative
    inside). The result broadcasts like ``r0 * cos_theta_i[:, None]`` for colours.
    """
    outside = cos_theta_i >= 0.0
    eta_it = np.where(outside, eta, 1.0 / eta)
    eta_ti = 1.0 / eta_it
    cos_t = np.sqrt(np.maximum(1.0 - (1.0 - cos_theta_i * cos_theta_i) * eta_ti * eta_ti, 0.0))
    weight = np.where(eta_it > 1.0, schlick_weight(np.abs(cos_theta_i)), schlick_weight(cos_t))
    r0 = np.asarray(r0, dtype=np.float64)
    if r0.ndim and r0.shape[-1] == 3:
        weight = weight[:, None]
    return weight * (1.0 - r0) + r0


def principled_fresnel(F_dielectric, metallic, spec_tint, base_color, cos_theta_i,
                       front_side, bsdf_weight, eta) -> np.ndarray:
    """The main lobe's colour Fresnel factor (module docstring) -> (n, 3).

    ``metallic``, ``spec_tint``, ``bsdf_weight`` are numbers or (n,); ``base_color`` (3,) or
    (n, 3); ``cos_theta_i`` is ``wi . h`` (n,); ``front_side`` is ``cos(theta_i) > 0``.
    """
    metallic = np.asarray(metallic, dtype=np.float64)[..., None]
    spec_tint = np.asarray(spec_tint, dtype=np.float64)[..., None]
    eta_it = np.where(cos_theta_i >= 0.0, eta, 1.0 / eta)
    F_metal = schlick_fresnel(base_color, cos_theta_i, eta)
    F_tinted = schlick_fresnel(tint(base_color) * schlick_r0(eta_it)[:, None], cos_theta_i, eta)
    F_d = F_dielectric[:, None]
    front = (1.0 - metallic) * (1.0 - spec_tint) * F_d + metallic * F_metal \
        + (1.0 - metallic) * spec_tint * F_tinted
    back = np.asarray(bsdf_weight, dtype=np.float64)[..., None] * F_d
    return np.where(front_side[:, None], front, back)


def thin_fresnel(F_dielectric, spec_tint, base_color, cos_theta_i, eta) -> np.ndarray:
    r"""``principledthin``'s Fresnel factor -> (n, 3):
    :math:`\mathrm{lerp}(F_d, F_{Schlick}(c/\mathrm{lum}(c)\,R_0(\eta), c_i), t)`."""
    spec_tint = np.asarray(spec_tint, dtype=np.float64)[..., None]
    F_tinted = schlick_fresnel(tint(base_color) * schlick_r0(eta)[..., None], cos_theta_i, eta)
    return (1.0 - spec_tint) * F_dielectric[:, None] + spec_tint * F_tinted


def clearcoat_alpha(clearcoat_gloss) -> np.ndarray:
    """The clearcoat's GTR1 roughness: 0.1 at gloss 0 down to 0.001 at gloss 1."""
    gloss = np.asarray(clearcoat_gloss, dtype=np.float64)
    return 0.1 * (1.0 - gloss) + 0.001 * gloss


def gtr1_eval(m: np.ndarray, alpha) -> np.ndarray:
    """:math:`D_{GTR1}(m)` -> (n,); 0 where :math:`D\\cos\\theta_m \\le 10^{-20}`."""
    cos2 = m[:, 2] ** 2
    a2 = np.square(alpha)
    with np.errstate(divide="ignore", invalid="ignore"):
        d = (a2 - 1.0) / (np.pi * np.log(a2) * (1.0 + (a2 - 1.0) * cos2))
    return np.where(d * m[:, 2] > 1e-20, d, 0.0)


def gtr1_pdf(m: np.ndarray, alpha) -> np.ndarray:
    """Density of :func:`gtr1_sample`, :math:`D_{GTR1}(m)\\cos\\theta_m` (0 below) -> (n,)."""
    return np.where(m[:, 2] < 0.0, 0.0, m[:, 2] * gtr1_eval(m, alpha))


def gtr1_sample(u: np.ndarray, alpha) -> np.ndarray:
    """Normals distributed as :math:`D_{GTR1}(m)\\cos\\theta_m` from uniforms (n, 2) -> (n, 3)."""
    phi = 2.0 * np.pi * u[:, 0]
    a2 = np.square(alpha)
    cos2 = (1.0 - np.power(a2, 1.0 - u[:, 1])) / (1.0 - a2)
    sin_t, cos_t = np.sqrt(np.maximum(0.0, 1.0 - cos2)), np.sqrt(np.maximum(0.0, cos2))
    return np.stack((np.cos(phi) * sin_t, np.sin(phi) * sin_t, cos_t), axis=1)


def smith_ggx1(v: np.ndarray, m: np.ndarray, alpha: float) -> np.ndarray:
    r"""Isotropic GGX :math:`G_1(v, m) = 2/(1 + \sqrt{1 + \alpha^2\tan^2\theta_v})`, 1 at normal
    incidence, 0 where ``v`` sees the back of ``m`` -> (n,)."""
    cos2 = v[:, 2] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        tan2 = (1.0 - cos2) / cos2
        g1 = 2.0 / (1.0 + np.sqrt(1.0 + alpha * alpha * tan2))
    g1 = np.where(v[:, 2] == 1.0, 1.0, g1)
    return np.where(dot_einsum(v, m) * v[:, 2] <= 0.0, 0.0, g1)


def clearcoat_G(wi: np.ndarray, wo: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Separable masking-shadowing of the clearcoat -> (n,)."""
    return smith_ggx1(wi, m, CLEARCOAT_G_ALPHA) * smith_ggx1(wo, m, CLEARCOAT_G_ALPHA)


def macro_micro_agree(m: np.ndarray, wi: np.ndarray, wo: np.ndarray, cos_theta_i: np.ndarray,
                      reflection: bool) -> np.ndarray:
    """``wi`` on the side of ``m`` that faces it, and ``wo`` on the same side (reflection)
    or the other (transmission), ``m`` turned to ``wi``'s side of the macrosurface."""
    m_side = np.where(np.signbit(cos_theta_i)[:, None], -m, m)
    wo_side = dot_einsum(wo, m_side) if reflection else -dot_einsum(wo, m_side)
    return (dot_einsum(wi, m_side) > 0.0) & (wo_side > 0.0)
