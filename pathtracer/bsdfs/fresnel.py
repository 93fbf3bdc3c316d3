r"""Fresnel equations and specular reflection/refraction in the local frame.

Local frame: :math:`z` is the surface normal. ``wi`` is a unit direction
pointing away from the surface (toward where the light goes after the
interaction, Mitsuba's convention); :math:`\cos\theta_i = w_{i,z}` is
positive on the side the normal points to ("outside") and negative inside.

The relative index of refraction is :math:`\eta = \eta_{int}/\eta_{ext}`
(interior over exterior); :math:`\eta > 1` means the normal points into the
optically thinner medium.
"""
from __future__ import annotations

import numpy as np

from ..core.vec import dot_einsum


def fresnel_dielectric(cos_theta_i: np.ndarray, eta) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    r"""Unpolarized Fresnel reflectance of a smooth dielectric interface.

    Let :math:`\eta_{it}` be the index ratio in the direction of travel
    (:math:`\eta` from outside, :math:`1/\eta` from inside) and
    :math:`\eta_{ti} = 1/\eta_{it}`. Snell's law gives

    .. math:: \cos^2\theta_t = 1 - \eta_{ti}^2\,(1 - \cos^2\theta_i),

    and with :math:`c_i = |\cos\theta_i|`, :math:`c_t = \sqrt{\max(\cos^2\theta_t, 0)}`
    the amplitude ratios of the s- and p-polarised reflected waves are

    .. math::
        r_s = \frac{c_i - \eta_{it} c_t}{c_i + \eta_{it} c_t},\qquad
        r_p = \frac{c_t - \eta_{it} c_i}{c_t + \eta_{it} c_i},\qquad
        F = \tfrac12 (r_s^2 + r_p^2).

    Under total internal reflection (:math:`\cos^2\theta_t < 0`) this gives
    :math:`c_t = 0` and :math:`F = 1`. Special cases as in Mitsuba: an
    index-matched interface (:math:`\eta = 1`) has :math:`F = 0`; grazing
    incidence (:math:`\cos\theta_i = 0`) has :math:`F = 1`.

    Parameters
    ----------
    cos_theta_i : (n,) ndarray
        Signed cosine of the incident direction with the normal.
    eta : float or (n,) ndarray
        Relative index :math:`\eta_{int} / \eta_{ext}`.

    Returns
    -------
    F : (n,) ndarray
        Fresnel reflectance.
    cos_theta_t : (n,) ndarray
        Signed cosine of the transmitted direction: opposite sign to
        :math:`\cos\theta_i` (the refracted ray is on the other side); 0 under TIR.
    eta_it : (n,) ndarray
        Relative index in the direction of travel (:math:`\eta` for
        :math:`\cos\theta_i \ge 0`, else :math:`1/\eta`).
    eta_ti : (n,) ndarray
        Its reciprocal; also the factor scaling the tangential components of
        the refracted direction.
    """
    cos_theta_i = np.asarray(cos_theta_i, dtype=np.float64)
    eta = np.broadcast_to(np.asarray(eta, dtype=np.float64), cos_theta_i.shape)
    outside = cos_theta_i >= 0.0
    eta_it = np.where(outside, eta, 1.0 / eta)
    eta_ti = np.where(outside, 1.0 / eta, eta)

    cos_theta_t_sqr = 1.0 - eta_ti * eta_ti * (1.0 - cos_theta_i * cos_theta_i)
    c_i = np.abs(cos_theta_i)
    c_t = np.sqrt(np.maximum(cos_theta_t_sqr, 0.0))

    with np.errstate(divide="ignore", invalid="ignore"):
        r_s = (c_i - eta_it * c_t) / (c_i + eta_it * c_t)
        r_p = (c_t - eta_it * c_i) / (c_t + eta_it * c_i)
    F = 0.5 * (r_s * r_s + r_p * r_p)

    index_matched = eta == 1.0
    grazing = c_i == 0.0
    F = np.where(index_matched, 0.0, np.where(grazing, 1.0, F))

    cos_theta_t = np.where(outside, -c_t, c_t)
    return F, cos_theta_t, eta_it, eta_ti


def fresnel_conductor(cos_theta_i: np.ndarray, eta: complex | np.ndarray) -> np.ndarray:
    r"""Unpolarized Fresnel reflectance of a conductor with complex index :math:`\eta + i k`.

    Exact formulas for light arriving from outside (:math:`\cos\theta_i > 0`),
    written with :math:`a^2 + b^2 = \sqrt{(\eta^2 - k^2 - \sin^2\theta_i)^2 + 4\eta^2 k^2}`
    and :math:`a = \sqrt{\tfrac12 (a^2 + b^2 + \eta^2 - k^2 - \sin^2\theta_i)}`:

    .. math::
        R_s = \frac{a^2 + b^2 - 2a\cos\theta_i + \cos^2\theta_i}
                   {a^2 + b^2 + 2a\cos\theta_i + \cos^2\theta_i},\qquad
        R_p = R_s\,\frac{(a^2 + b^2)\cos^2\theta_i - 2a\cos\theta_i\sin^2\theta_i + \sin^4\theta_i}
                        {(a^2 + b^2)\cos^2\theta_i + 2a\cos\theta_i\sin^2\theta_i + \sin^4\theta_i},

    :math:`F = \tfrac12 (R_s + R_p)`. Mitsuba's conductors with
    ``material="none"`` use :math:`\eta + ik = 0 + 1i`, for which :math:`a = 0`
    and :math:`F = 1` exactly (a perfect mirror).

    Parameters
    ----------
    cos_theta_i : (n,) ndarray
        Cosine of the incident direction (assumed >= 0).
    eta : complex or (..., ) complex ndarray
        Complex relative index :math:`\eta + i k`, broadcast against
        ``cos_theta_i`` (use shape (n, 1) against (1, 3) colours, etc.).

    Returns
    -------
    ndarray
        Fresnel reflectance, broadcast shape of the inputs.
    """
    cos_theta_i = np.asarray(cos_theta_i, dtype=np.float64)
    eta = np.asarray(eta, dtype=np.complex128)
    eta_r, eta_k = eta.real, eta.imag
    cos2 = cos_theta_i * cos_theta_i
    sin2 = 1.0 - cos2
    sin4 = sin2 * sin2

    temp = eta_r * eta_r - eta_k * eta_k - sin2
    a2_plus_b2 = np.sqrt(np.maximum(temp * temp + 4.0 * eta_k * eta_k * eta_r * eta_r, 0.0))
    a = np.sqrt(np.maximum(0.5 * (a2_plus_b2 + temp), 0.0))

    term_1 = a2_plus_b2 + cos2
    term_2 = 2.0 * cos_theta_i * a
    r_s = (term_1 - term_2) / (term_1 + term_2)

    term_3 = a2_plus_b2 * cos2 + sin4
    term_4 = term_2 * sin2
    r_p = r_s * (term_3 - term_4) / (term_3 + term_4)
    return 0.5 * (r_s + r_p)


def fresnel_diffuse_reflectance(eta) -> float:
    r"""Fresnel reflectance averaged over a cosine-weighted hemisphere of incident directions.

    :math:`F_{dr}(\eta) = 2\int_0^1 F(\mu, \eta)\,\mu\,d\mu`, the fraction of
    diffuse light that an interface of relative index :math:`\eta` reflects.
    As Mitsuba, this uses polynomial fits instead of the integral: for
    :math:`\eta < 1` Egan and Hilgeman's (1973)

    .. math:: F_{dr} \approx -1.4399\,\eta^2 + 0.7099\,\eta + 0.6681 + 0.0636/\eta,

    otherwise d'Eon and Irving's (2011) quintic in :math:`1/\eta`,

    .. math:: F_{dr} \approx 0.919317 - 3.4793\,x + 6.75335\,x^2 - 7.80989\,x^3
              + 4.98554\,x^4 - 1.36881\,x^5,\qquad x = 1/\eta.

    Both fits are within 0.6 % of the integral for :math:`1 \le \eta \le 2`
    (and :math:`1/2 \le \eta \le 1`); ``plastic`` uses the value for its
    internal reflections, so matching Mitsuba needs the same fits.
    """
    eta = float(eta)
    x = 1.0 / eta
    if eta < 1.0:
        return -1.4399 * eta * eta + 0.7099 * eta + 0.6681 + 0.0636 * x
    return 0.919317 + x * (-3.4793 + x * (6.75335 + x * (-7.80989 + x * (4.98554 - 1.36881 * x))))


def fresnel_schlick(cos_theta_i: np.ndarray, f0) -> np.ndarray:
    r"""Schlick's approximation of the Fresnel reflectance.

    .. math:: F \approx F_0 + (1 - F_0)\,(1 - |\cos\theta_i|)^5,
              \qquad F_0 = \left(\frac{\eta - 1}{\eta + 1}\right)^2

    Only for comparisons in the lecture: none of Mitsuba's BSDFs used here
    relies on it. Note that it ignores total internal reflection; pass the
    cosine on the optically thinner side when light leaves a dense medium.

    Parameters
    ----------
    cos_theta_i : (n,) ndarray
        Cosine of the incident angle.
    f0 : float or array
        Reflectance at normal incidence (see :func:`schlick_f0`).
    """
    m = 1.0 - np.abs(np.asarray(cos_theta_i, dtype=np.float64))
    return f0 + (1.0 - f0) * m ** 5


def schlick_f0(eta) -> np.ndarray:
    r"""Normal-incidence reflectance :math:`F_0 = ((\eta - 1)/(\eta + 1))^2` of a dielectric."""
    eta = np.asarray(eta, dtype=np.float64)
    return ((eta - 1.0) / (eta + 1.0)) ** 2


def reflect(wi: np.ndarray) -> np.ndarray:
    r"""Mirror reflection about the local normal: :math:`(-x, -y, z)`."""
    return wi * np.array([-1.0, -1.0, 1.0])


def reflect_about(wi: np.ndarray, m: np.ndarray) -> np.ndarray:
    r"""Mirror reflection about the unit normals ``m``: :math:`2\,(w_i\cdot m)\,m - w_i`."""
    d = dot_einsum(wi, m)
    return 2.0 * d[:, None] * m - wi


def refract_about(wi: np.ndarray, m: np.ndarray, cos_theta_t: np.ndarray,
                  eta_ti: np.ndarray) -> np.ndarray:
    r"""Refraction through the unit microfacet normals ``m``.

    .. math:: w_t = m\,(\eta_{ti}\,(w_i\cdot m) + \cos\theta_t) - \eta_{ti}\,w_i

    with ``cos_theta_t`` and ``eta_ti`` from :func:`fresnel_dielectric` of
    :math:`w_i\cdot m` (so :math:`\cos\theta_t` has the sign opposite to
    :math:`w_i\cdot m`). For :math:`m = (0, 0, 1)` this is :func:`refract`.
    """
    d = dot_einsum(wi, m)
    eta_ti = np.asarray(eta_ti, dtype=np.float64)
    return m * (eta_ti * d + cos_theta_t)[:, None] - eta_ti[:, None] * wi


def refract(wi: np.ndarray, cos_theta_t: np.ndarray, eta_ti: np.ndarray) -> np.ndarray:
    r"""Refraction through the local normal (the :math:`z = 0` plane).

    Snell's law scales the tangential part by :math:`\eta_{ti}` and flips it
    (the refracted ray continues through the surface):

    .. math:: w_t = (-\eta_{ti}\,x,\ -\eta_{ti}\,y,\ \cos\theta_t)

    with ``cos_theta_t`` and ``eta_ti`` from :func:`fresnel_dielectric`.
    """
    eta_ti = np.asarray(eta_ti, dtype=np.float64)
    return np.stack((-eta_ti * wi[:, 0], -eta_ti * wi[:, 1], cos_theta_t), axis=1)
