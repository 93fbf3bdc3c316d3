r"""Directional albedos of a rough dielectric interface, tabulated as Mitsuba's ``roughplastic`` does.

A rough coating lets the fraction :math:`T(\mu)` of the light arriving at
:math:`\cos\theta = \mu` through (into the base), and reflects back the
fraction :math:`R(\mu)` of light that hits it from inside. With visible
normals :math:`m \sim D_{w_i}` (:meth:`MicrofacetDistribution.sample`, a map
of the unit square),

.. math::
    T(\mu) = \int_{[0,1]^2} (1 - F(w_i\cdot m))\,G_1(w_t, m)\,du,\qquad
    R(\mu) = \int_{[0,1]^2} F(w_i\cdot m)\,G_1(w_r, m)\,du,

where :math:`w_t` / :math:`w_r` are :math:`w_i` refracted / reflected about
:math:`m` (contributions on the wrong side are 0). Mitsuba evaluates both
integrals with an :math:`N \times N` Gauss-Legendre rule over the square
(:math:`N = 32` when :math:`\eta > 1`, 128 otherwise) at the 64 cosines
:math:`\mu_j = \max(10^{-6}, j/63)`, interpolates :math:`T` linearly between
them, and averages :math:`R` over the same cosines into the internal
diffuse reflectance :math:`2\,\overline{R(\mu_j)\mu_j}` (a rectangle rule
for :math:`2\int_0^1 R(\mu)\mu\,d\mu`). The same rule is used here so the
tracer's ``roughplastic`` equals Mitsuba's, not an idealisation of it.
"""
from __future__ import annotations

import functools

import numpy as np

from ..core.vec import dot_einsum
from .fresnel import fresnel_dielectric, reflect_about, refract_about
from .microfacet import MicrofacetDistribution

#: Number of tabulated cosines (Mitsuba's MI_ROUGH_TRANSMITTANCE_RES).
TABLE_SIZE = 64


def table_cosines() -> np.ndarray:
    """The cosines :math:`\\mu_j = \\max(10^{-6}, j/63)` of the tables."""
    return np.maximum(1e-6, np.linspace(0.0, 1.0, TABLE_SIZE))


def _quadrature_nodes(eta: float) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes on the unit square (n*n, 2) and their weights (n*n,)."""
    order = 32 if eta > 1.0 else 128
    x, w = np.polynomial.legendre.leggauss(order)
    x = 0.5 * x + 0.5
    nodes = np.stack(np.meshgrid(x, x, indexing="ij"), axis=-1).reshape(-1, 2)
    weights = np.outer(w, w).ravel() * 0.25
    return nodes, weights


def _integrate(distr: MicrofacetDistribution, eta: float, transmitted: bool) -> np.ndarray:
    """:math:`T(\\mu_j)` (``transmitted``) or :math:`R(\\mu_j)` for every table cosine -> (64,)."""
    nodes, weights = _quadrature_nodes(eta)
    result = np.empty(TABLE_SIZE)
    for j, mu in enumerate(table_cosines()):
        wi = np.tile([np.sqrt(1.0 - mu * mu), 0.0, mu], (nodes.shape[0], 1))
        m, _ = distr.sample(wi, nodes)
        F, cos_theta_t, _, eta_ti = fresnel_dielectric(dot_einsum(wi, m), eta)
        if transmitted:
            wo = refract_about(wi, m, cos_theta_t, eta_ti)
            value = (1.0 - F) * distr.smith_g1(wo, m)
            value = np.where(wo[:, 2] * wi[:, 2] >= 0.0, 0.0, value)
        else:
            wo = reflect_about(wi, m)
            value = F * distr.smith_g1(wo, m)
            value = np.where(wo[:, 2] <= 0.0, 0.0, value)
        result[j] = np.sum(np.where(np.isfinite(value), value, 0.0) * weights)
    return result


@functools.lru_cache(maxsize=16)
def coating_tables(distribution: str, alpha: float, eta: float) -> tuple[np.ndarray, float]:
    r"""External transmittance table :math:`T(\mu_j)` and internal diffuse reflectance.

    Parameters
    ----------
    distribution : {"beckmann", "ggx"}
    alpha : float
        Isotropic roughness.
    eta : float
        Relative index :math:`\eta_{int}/\eta_{ext}` of the coating.

    Returns
    -------
    transmittance : (64,) ndarray
        :math:`T` at :func:`table_cosines` for light arriving from outside.
    internal_reflectance : float
        :math:`2\,\overline{R(\mu_j)\,\mu_j}` for light inside (index ratio :math:`1/\eta`).
    """
    distr = MicrofacetDistribution(distribution, alpha, alpha)
    transmittance = _integrate(distr, eta, transmitted=True)
    internal = _integrate(distr, 1.0 / eta, transmitted=False)
    internal_reflectance = float(np.mean(internal * table_cosines()) * 2.0)
    transmittance.setflags(write=False)
    return transmittance, internal_reflectance


def interpolate(table: np.ndarray, cos_theta: np.ndarray) -> np.ndarray:
    """Linear interpolation of a table over :math:`[0, 1]` at ``cos_theta`` (as Mitsuba's lookup) -> (n,)."""
    x = np.asarray(cos_theta, dtype=np.float64) * (table.size - 1)
    index = np.clip(x.astype(np.int64), 0, table.size - 2)
    t = x - index
    return table[index] * (1.0 - t) + table[index + 1] * t
