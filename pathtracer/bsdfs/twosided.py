r"""Two-sided adapter, Mitsuba's ``twosided`` plugin with one nested BSDF.

Seen from below (:math:`\cos\theta_i < 0`) the surface behaves as if it
were seen from above: the frame is mirrored through the tangent plane,

.. math::
    f_{2s}(w_i, w_o) = f(\bar w_i, \bar w_o)\ \text{if } \cos\theta_i < 0,
    \qquad \bar w = (x, y, -z),

and a direction sampled in the mirrored frame is mirrored back. Mitsuba
uses the sign bit of :math:`\cos\theta_i` (``mulsign``), so :math:`-0` counts
as the back side; this module does the same.
"""
from __future__ import annotations

import numpy as np

from .base import BSDF, BSDFSample


def _flip_z(v: np.ndarray, flip: np.ndarray) -> np.ndarray:
    """Copy of ``v`` with the z component negated where ``flip``."""
    out = v.copy()
    out[:, 2] = np.where(flip, -v[:, 2], v[:, 2])
    return out


class TwoSided(BSDF):
    """Make ``nested`` two-sided by mirroring back-side queries to the front."""

    def __init__(self, nested: BSDF):
        self.nested = nested
        self.has_smooth = nested.has_smooth
        self.is_delta = nested.is_delta

    @property
    def textured(self) -> bool:
        """The nested BSDF has a texture."""
        return self.nested.textured

    def at(self, uv: np.ndarray) -> "TwoSided":
        """Two-sided wrapper of the nested BSDF bound to the hits' ``uv``."""
        return TwoSided(self.nested.at(uv))

    def eval(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Nested ``eval`` with both directions mirrored where ``wi`` is on the back side."""
        back = np.signbit(wi[:, 2])
        return self.nested.eval(_flip_z(wi, back), _flip_z(wo, back))

    def pdf(self, wi: np.ndarray, wo: np.ndarray, hemisphere: str = "cosine") -> np.ndarray:
        """Nested ``pdf`` with both directions mirrored where ``wi`` is on the back side."""
        back = np.signbit(wi[:, 2])
        return self.nested.pdf(_flip_z(wi, back), _flip_z(wo, back), hemisphere=hemisphere)

    def sample(self, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray,
               hemisphere: str = "cosine") -> BSDFSample:
        """Sample the nested BSDF from the mirrored ``wi``; mirror the sampled ``wo`` back."""
        back = np.signbit(wi[:, 2])
        bs = self.nested.sample(_flip_z(wi, back), u1, u2, hemisphere=hemisphere)
        bs.wo = _flip_z(bs.wo, back)
        return bs
