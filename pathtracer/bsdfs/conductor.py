r"""Smooth conductor (perfect mirror), Mitsuba's ``conductor`` plugin.

The BRDF is a Dirac delta around the mirror direction
:math:`w_r = (-x_i, -y_i, z_i)`:

.. math:: f(w_i, w_o)\,|\cos\theta_o| = F(\cos\theta_i)\,R_s\,\delta(w_o - w_r),

with ``specular_reflectance`` :math:`R_s` and the exact conductor Fresnel
factor :math:`F` of the complex index :math:`\eta + ik` (per RGB channel,
:func:`~pathtracer.bsdfs.fresnel.fresnel_conductor`). Mitsuba's default
``material="none"`` is :math:`0 + 1i`, for which :math:`F = 1` exactly; a
named material uses the RGB indices of
:mod:`~pathtracer.bsdfs.conductor_presets`. The sample weight is
:math:`F R_s`; one-sided (no reflection from below).
"""
from __future__ import annotations

import numpy as np

from .base import BSDF, BSDFSample, as_colour, make_sample, zero_eval, zero_pdf
from .fresnel import fresnel_conductor, reflect


class ConductorFresnel:
    r"""Conductor Fresnel factor times ``specular_reflectance``, shared by the smooth and rough conductors.

    Parameters
    ----------
    specular_reflectance : (3,) array_like
    eta, k : (3,) array_like
        Complex index of refraction :math:`\eta + ik` relative to the outside.
        The default :math:`0 + 1i` is Mitsuba's ``material="none"``: factor 1.
    """

    def __init__(self, specular_reflectance=1.0, eta=0.0, k=1.0):
        self.specular_reflectance = as_colour(specular_reflectance)
        self.eta_complex = as_colour(eta) + 1j * as_colour(k)
        self.perfect_mirror = bool(np.all(self.eta_complex == 1j))

    def __call__(self, cos_theta: np.ndarray) -> np.ndarray:
        """:math:`F(\\cos\\theta)\\,R_s` -> (n, 3)."""
        if self.perfect_mirror:
            return np.broadcast_to(self.specular_reflectance, (cos_theta.shape[0], 3))
        F = fresnel_conductor(cos_theta[:, None], self.eta_complex[None, :])
        return F * self.specular_reflectance


class Conductor(BSDF):
    """Perfect mirror tinted by ``specular_reflectance`` and the conductor Fresnel factor."""

    has_smooth = False
    is_delta = True

    def __init__(self, specular_reflectance=1.0, eta=0.0, k=1.0):
        self.fresnel = ConductorFresnel(specular_reflectance, eta, k)
        self.specular_reflectance = self.fresnel.specular_reflectance
        self.eta_complex = self.fresnel.eta_complex

    def eval(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """0: a delta lobe has no finite value."""
        return zero_eval(wi)

    def pdf(self, wi: np.ndarray, wo: np.ndarray, hemisphere: str = "cosine") -> np.ndarray:
        """0: a delta lobe has no finite density."""
        return zero_pdf(wi)

    def sample(self, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray,
               hemisphere: str = "cosine") -> BSDFSample:
        """The mirror direction with weight :math:`F R_s` (pdf 1, delta); invalid from below."""
        n = wi.shape[0]
        valid = wi[:, 2] > 0.0
        weight = self.fresnel(np.maximum(wi[:, 2], 0.0))
        return make_sample(reflect(wi), weight, np.ones(n), delta=True, eta=1.0, valid=valid)
