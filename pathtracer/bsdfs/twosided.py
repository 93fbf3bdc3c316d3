r"""Two-sided adapter, Mitsuba's ``twosided`` plugin with one nested BSDF.

Seen from below (:math:`\cos\theta_i < 0`) the surface behaves as if it
were seen from above: the frame is mirrored through the tangent plane,

.. math::
    f_{2s}(w_i, w_o) = f(\bar w_i, \bar w_o)\ \text{if } \cos\theta_i < 0,
    \qquad \bar w = (x, y, -z),

and a direction sampled in the mirrored frame is mirrored back. Mitsuba
uses the sign bit of :math:`\cos\theta_i` (``mulsign``), so :math:`-0` counts
as the back side; this module does the same.

With two nested BSDFs (Mitsuba's ``twosided`` holding two ``<bsdf>``) the first serves
the front (:math:`\cos\theta_i > 0`) and the second, mirrored as above, the back; a
direction exactly in the tangent plane (:math:`\cos\theta_i = 0`) then sees neither, as
in Mitsuba.
"""
from __future__ import annotations

import numpy as np

from ..scene.properties import Props
from ..scene.registry import register
from .base import BSDF, BSDFSample, make_sample
from .parameters import nested_bsdfs


def _flip_z(v: np.ndarray, flip: np.ndarray) -> np.ndarray:
    """Copy of ``v`` with the z component negated where ``flip``."""
    out = v.copy()
    out[:, 2] = np.where(flip, -v[:, 2], v[:, 2])
    return out


class TwoSided(BSDF):
    """Make ``nested`` two-sided by mirroring back-side queries to the front; with a
    ``back`` BSDF, that one serves the (mirrored) back side."""

    def __init__(self, nested: BSDF, back: BSDF | None = None):
        self.nested = nested
        self.back = back
        sides = (nested,) if back is None else (nested, back)
        self.has_smooth = any(b.has_smooth for b in sides)
        self.is_delta = all(b.is_delta for b in sides)

    @property
    def textured(self) -> bool:
        """A nested BSDF has a texture."""
        return self.nested.textured or (self.back is not None and self.back.textured)

    @property
    def anisotropic(self) -> bool:
        """A nested BSDF sees the azimuth of the tangent frame."""
        return any(b is not None and b.anisotropic for b in (self.nested, self.back))

    @property
    def needs_geometry(self) -> bool:
        """A nested BSDF perturbs the shading normal."""
        return any(b is not None and b.needs_geometry for b in (self.nested, self.back))

    def at(self, uv: np.ndarray, geometry=None) -> "TwoSided":
        """Two-sided wrapper of the nested BSDF(s) bound to the hits' ``uv``."""
        if self.back is None:
            return TwoSided(self.nested.at(uv, geometry))
        return TwoSided(*(b.at(uv, geometry) if b.textured else b
                          for b in (self.nested, self.back)))

    def eval(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Nested ``eval`` with both directions mirrored where ``wi`` is on the back side."""
        back = np.signbit(wi[:, 2])
        if self.back is not None:
            return self._per_side(wi, lambda b, side: b.eval(_flip_z(wi, side), _flip_z(wo, side)))
        return self.nested.eval(_flip_z(wi, back), _flip_z(wo, back))

    def pdf(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Nested ``pdf`` with both directions mirrored where ``wi`` is on the back side."""
        back = np.signbit(wi[:, 2])
        if self.back is not None:
            return self._per_side(wi, lambda b, side: b.pdf(_flip_z(wi, side), _flip_z(wo, side)))
        return self.nested.pdf(_flip_z(wi, back), _flip_z(wo, back))

    def _per_side(self, wi: np.ndarray, query):
        """``query(bsdf, flip)`` of the front BSDF where cos > 0, of the back one (mirrored)
        where cos < 0, zero at cos = 0. Both run on every row: bound BSDFs need all rows."""
        front, back = wi[:, 2] > 0.0, wi[:, 2] < 0.0
        value_front = query(self.nested, np.zeros(len(wi), dtype=bool))
        value_back = query(self.back, np.ones(len(wi), dtype=bool))
        shape = (-1,) + (1,) * (value_front.ndim - 1)
        return np.where(front.reshape(shape), value_front,
                        np.where(back.reshape(shape), value_back, 0.0))

    def sample(self, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray) -> BSDFSample:
        """Sample the nested BSDF from the mirrored ``wi``; mirror the sampled ``wo`` back."""
        back = np.signbit(wi[:, 2])
        if self.back is not None:
            return self._sample_two(wi, u1, u2)
        bs = self.nested.sample(_flip_z(wi, back), u1, u2)
        bs.wo = _flip_z(bs.wo, back)
        return bs

    def _sample_two(self, wi, u1, u2) -> BSDFSample:
        """The front BSDF's sample where cos > 0, the back one's (mirrored) where cos < 0."""
        everywhere = np.ones(len(wi), dtype=bool)
        bs_front = self.nested.sample(wi, u1, u2)
        bs_back = self.back.sample(_flip_z(wi, everywhere), u1, u2)
        bs_back.wo = _flip_z(bs_back.wo, everywhere)
        front = wi[:, 2] > 0.0
        fields = {}
        for name in ("wo", "weight", "pdf", "delta", "eta", "valid"):
            a, b = getattr(bs_front, name), getattr(bs_back, name)
            fields[name] = np.where(front.reshape((-1,) + (1,) * (a.ndim - 1)), a, b)
        fields["valid"] &= wi[:, 2] != 0.0
        return make_sample(**fields)


@register("bsdf", "twosided")
def create(props: Props) -> TwoSided:
    """One nested BSDF for both sides, or two: front and back."""
    return TwoSided(*nested_bsdfs(props, 1, 2))
