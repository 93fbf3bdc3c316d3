r"""An anisotropic BSDF seen in Mitsuba's tangent frame.

The tracer's local frame at a hit is built from the shading normal alone
(:func:`pathtracer.core.vec.coordinate_system`); Mitsuba's tangent is
:math:`\partial p/\partial u` made orthogonal to the normal (:mod:`pathtracer.shapes.tangents`).
The two differ by a rotation about the normal, which an isotropic BSDF does not see but
an anisotropic one (``alpha_u != alpha_v``, or a textured roughness) does: its ``alpha_u``
runs along Mitsuba's tangent. :class:`InTangentFrame` turns directions by that rotation
before the BSDF sees them and turns sampled directions back.
"""
from __future__ import annotations

import numpy as np

from .base import BSDF, BSDFSample


def _rotate(v: np.ndarray, cos: np.ndarray, sin: np.ndarray) -> np.ndarray:
    """Rows of ``v`` turned about z by the angle whose cosine and sine are given."""
    out = v.copy()
    out[:, 0] = cos * v[:, 0] - sin * v[:, 1]
    out[:, 1] = sin * v[:, 0] + cos * v[:, 1]
    return out


class InTangentFrame(BSDF):
    """``bsdf`` queried in the frame whose x axis is ``tangent`` (rows, local coordinates)."""

    def __init__(self, bsdf: BSDF, tangent: np.ndarray):
        self.bsdf = bsdf
        self.has_smooth, self.is_delta = bsdf.has_smooth, bsdf.is_delta
        # Refraction (and its relative index) for the adjoint scaling of the light tracer.
        self.refracts, self.eta = bsdf.refracts, getattr(bsdf, "eta", 1.0)
        length = np.hypot(tangent[:, 0], tangent[:, 1])
        ok = length > 0.0
        self.cos = np.where(ok, tangent[:, 0] / np.where(ok, length, 1.0), 1.0)
        self.sin = np.where(ok, tangent[:, 1] / np.where(ok, length, 1.0), 0.0)

    def _into(self, v):
        return _rotate(v, self.cos, -self.sin)

    def eval(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """The BSDF's value for the turned directions -> (n, 3)."""
        return self.bsdf.eval(self._into(wi), self._into(wo))

    def pdf(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """The BSDF's density for the turned directions -> (n,)."""
        return self.bsdf.pdf(self._into(wi), self._into(wo))

    def sample(self, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray) -> BSDFSample:
        """Sample in the tangent frame; the direction is turned back."""
        bs = self.bsdf.sample(self._into(wi), u1, u2)
        bs.wo = _rotate(bs.wo, self.cos, self.sin)
        return bs

    def lobes(self, wi: np.ndarray):
        """Both Dirac lobes of a smooth dielectric (isotropic: no turn needed)."""
        return self.bsdf.lobes(wi)
