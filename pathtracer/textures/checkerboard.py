"""Mitsuba's ``checkerboard`` texture: two colours (or textures) in alternating cells."""
from __future__ import annotations

import numpy as np

from ..scene.properties import Props, children
from ..scene.registry import register
from .base import ConstantTexture, Texture, finite_uv


def _as_texture(value) -> Texture:
    return value if isinstance(value, Texture) else ConstantTexture(value)


class Checkerboard(Texture):
    """Mitsuba's ``checkerboard``: ``color0`` where the fractional parts of u' and v'
    are both above 1/2 or both at most 1/2, ``color1`` elsewhere.

    Parameters
    ----------
    color0, color1 : (3,) array_like or Texture
        Mitsuba's defaults are 0.4 and 0.2. Nested textures are evaluated at
        the surface ``uv`` (not the checkerboard's transformed one), as in
        Mitsuba.
    to_uv : see :class:`Texture`
    """

    spatially_varying = True   # sampled uniformly in uv (Mitsuba's default sample_position)

    def __init__(self, color0=0.4, color1=0.2, to_uv=None):
        super().__init__(to_uv)
        self.color0 = _as_texture(color0)
        self.color1 = _as_texture(color1)

    def eval(self, uv: np.ndarray) -> np.ndarray:
        """RGB values (n, 3) at surface coordinates ``uv`` (n, 2); 0 where ``uv`` is not finite."""
        uv, undefined = finite_uv(uv)
        t = self.transform_uv(uv)
        upper = (t - np.floor(t)) > 0.5
        first = upper[:, 0] == upper[:, 1]
        out = np.empty((len(uv), 3))
        out[first] = self.color0.eval(uv[first])
        out[~first] = self.color1.eval(uv[~first])
        if undefined is not None:
            out[undefined] = 0.0
        return out

    def max_value(self) -> np.ndarray:
        """Channel-wise maximum of the two colours."""
        return np.maximum(self.color0.max_value(), self.color1.max_value())

    def eval_1(self, uv: np.ndarray) -> np.ndarray:
        """``eval_1`` of ``color0`` or ``color1`` per cell (n,).

        Mitsuba 3.9.1's ``eval_1`` picks the cells the other way round from its ``eval``
        (``color0`` where exactly one fractional part is above 1/2); a roughness, blend
        weight or opacity from a checkerboard follows that, so we do the same.
        """
        uv, undefined = finite_uv(uv)
        t = self.transform_uv(uv)
        upper = (t - np.floor(t)) > 0.5
        first = upper[:, 0] != upper[:, 1]
        out = np.empty(len(uv))
        out[first] = self.color0.eval_1(uv[first])
        out[~first] = self.color1.eval_1(uv[~first])
        if undefined is not None:
            out[undefined] = 0.0
        return out

    def mean(self) -> float:
        """Half the sum of the two colours' means (the cells cover equal areas)."""
        return 0.5 * (self.color0.mean() + self.color1.mean())


@register("texture", "checkerboard")
def create(props: Props) -> Checkerboard:
    """``color0`` (0.4), ``color1`` (0.2), each a colour or a nested texture; ``to_uv``."""
    children(props.plugin, {"texture": 2})
    to_uv = props.transform("to_uv")
    texture = Checkerboard(props.texture_value("color0", 0.4),
                           props.texture_value("color1", 0.2), to_uv)
    props.finish()
    return texture
