r"""Smooth conductor (perfect mirror), Mitsuba's ``conductor`` plugin with ``material="none"``.

The BRDF is a Dirac delta around the mirror direction
:math:`w_r = (-x_i, -y_i, z_i)`:

.. math:: f(w_i, w_o)\,|\cos\theta_o| = F\,R_s\,\delta(w_o - w_r),

with Fresnel factor :math:`F = 1` (``material="none"``, i.e. complex index
:math:`0 + 1i`) and ``specular_reflectance`` :math:`R_s`. The sample weight
is :math:`R_s`; one-sided (no reflection from below).
"""
from __future__ import annotations

import numpy as np

from .base import (BSDF, BSDFSample, as_colour_or_texture, make_sample, zero_eval,
                   zero_pdf)
from .fresnel import reflect


class Conductor(BSDF):
    """Perfect mirror tinted by ``specular_reflectance``."""

    texture_params = ("specular_reflectance",)
    has_smooth = False
    is_delta = True

    def __init__(self, specular_reflectance=1.0):
        self.specular_reflectance = as_colour_or_texture(specular_reflectance)

    def eval(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """0: a delta lobe has no finite value."""
        return zero_eval(wi)

    def pdf(self, wi: np.ndarray, wo: np.ndarray, hemisphere: str = "cosine") -> np.ndarray:
        """0: a delta lobe has no finite density."""
        return zero_pdf(wi)

    def sample(self, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray,
               hemisphere: str = "cosine") -> BSDFSample:
        """The mirror direction with weight ``specular_reflectance`` (pdf 1, delta); invalid from below."""
        n = wi.shape[0]
        valid = wi[:, 2] > 0.0
        weight = np.broadcast_to(self.specular_reflectance, (n, 3))
        return make_sample(reflect(wi), weight, np.ones(n), delta=True, eta=1.0, valid=valid)
