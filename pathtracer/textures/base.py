r"""Textures: RGB values that vary over a surface, looked up by texture coordinates.

Mitsuba 3's ``bitmap``, ``checkerboard`` and ``rawconstant`` plugins, in its RGB variants,
one module each; here what they share.

A texture is evaluated at the surface's ``uv`` (see
:func:`pathtracer.shapes.intersect.texture_uv`) after the optional ``to_uv``
transform. Mitsuba reads ``to_uv`` as a 4x4 matrix and keeps its upper-left
3x3 block, applied to :math:`(u, v, 1)` without a projective divide:

.. math:: (u', v') = M_{0:2,0:2}\,(u, v) + M_{0:2,2}.

(So a ``<translate>`` of the 4x4 form moves nothing; a 9-value ``<matrix>``
shifts ``uv`` by its third column.)
"""
from __future__ import annotations

import numpy as np

from ..core.color import LUMINANCE


class Texture:
    """An RGB function of texture coordinates.

    Subclasses implement :meth:`eval_uv` (coordinates already through
    ``to_uv``) and :meth:`max_value`.

    Parameters
    ----------
    to_uv : (4, 4) array_like, optional
        Mitsuba's ``to_uv`` as the scene loader reads it (see the module
        docstring); a (3, 3) array is taken as a 2-D homogeneous matrix.
    """

    def __init__(self, to_uv=None):
        m = np.eye(4) if to_uv is None else np.asarray(to_uv, np.float64)
        last = 3 if m.shape == (4, 4) else 2
        self.uv_linear = m[:2, :2].copy()
        self.uv_offset = m[:2, last].copy()
        self._identity = bool(np.array_equal(self.uv_linear, np.eye(2))
                              and not self.uv_offset.any())

    def transform_uv(self, uv: np.ndarray) -> np.ndarray:
        """Apply ``to_uv`` to (n, 2) coordinates."""
        if self._identity:
            return uv
        return uv @ self.uv_linear.T + self.uv_offset

    def eval(self, uv: np.ndarray) -> np.ndarray:
        """RGB values (n, 3) at surface coordinates ``uv`` (n, 2); 0 where ``uv`` is not finite."""
        uv, undefined = finite_uv(uv)
        value = self.eval_uv(self.transform_uv(uv))
        if undefined is not None:
            value[undefined] = 0.0
        return value

    def eval_uv(self, uv: np.ndarray) -> np.ndarray:
        """RGB values at coordinates already mapped by ``to_uv``."""
        raise NotImplementedError

    def max_value(self) -> np.ndarray:
        """(3,) upper bound of every channel over the surface (for roulette heuristics)."""
        raise NotImplementedError

    def eval_1(self, uv: np.ndarray) -> np.ndarray:
        """One value per hit (n,), Mitsuba's ``eval_1``: the luminance of :meth:`eval`
        (for a grey texture, its value): how a texture gives a roughness, a blend weight
        or an opacity."""
        return self.eval(uv) @ LUMINANCE

    def mean(self) -> float:
        """Mitsuba's ``Texture::mean()``: the number BSDFs pick lobes by (see subclasses)."""
        raise NotImplementedError

    #: Mitsuba's ``is_spatially_varying``: an area light with such a radiance samples its
    #: surface through :meth:`sample_position` in uv space instead of by area.
    spatially_varying = False

    def sample_position(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Surface coordinates (n, 2) drawn from uniform ``u`` (n, 2) and their density
        over the unit square: Mitsuba's default, ``u`` itself with density 1."""
        return np.asarray(u, np.float64), np.ones(len(u))

    def pdf_position(self, uv: np.ndarray) -> np.ndarray:
        """The density (n,) with which :meth:`sample_position` picks ``uv``."""
        return np.ones(len(uv))


def finite_uv(uv):
    """(n, 2) float64 coordinates with non-finite rows set to 0, and the mask of those
    rows (None if there are none). Mesh corners without texture coordinates have NaN
    uv; Mitsuba's lookup is undefined there, ours gives black."""
    uv = np.asarray(uv, np.float64).reshape(-1, 2)
    undefined = ~np.isfinite(uv).all(axis=1)
    if not undefined.any():
        return uv, None
    return np.where(undefined[:, None], 0.0, uv), undefined


class ConstantTexture(Texture):
    """The same RGB value everywhere (a plain ``<rgb>`` or ``<float>`` parameter)."""

    def __init__(self, value):
        super().__init__()
        self.value = np.broadcast_to(np.asarray(value, np.float64), (3,)).copy()

    def eval_uv(self, uv: np.ndarray) -> np.ndarray:
        """``value`` repeated for every coordinate."""
        return np.broadcast_to(self.value, (len(uv), 3)).copy()

    def max_value(self) -> np.ndarray:
        """The value itself."""
        return self.value.copy()

    def eval_1(self, uv: np.ndarray) -> np.ndarray:
        """The channel mean everywhere (Mitsuba's ``srgb``/``uniform`` ``eval_1`` is their mean)."""
        return np.full(len(uv), self.mean())

    def mean(self) -> float:
        """Mean of the three channels, as Mitsuba's constant colours report it."""
        return float(np.mean(self.value))
