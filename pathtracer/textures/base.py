r"""Textures: RGB values that vary over a surface, looked up by texture coordinates.

Mitsuba 3's ``bitmap`` and ``checkerboard`` plugins, in its RGB variants.
A texture is evaluated at the surface's ``uv`` (see
:func:`pathtracer.geometry.texture_uv`) after the optional ``to_uv``
transform. Mitsuba reads ``to_uv`` as a 4x4 matrix and keeps its upper-left
3x3 block, applied to :math:`(u, v, 1)` without a projective divide:

.. math:: (u', v') = M_{0:2,0:2}\,(u, v) + M_{0:2,2}.

(So a ``<translate>`` of the 4x4 form moves nothing; a 9-value ``<matrix>``
shifts ``uv`` by its third column.)

Bitmap lookup (image row 0 is looked up at :math:`v' \in [0, 1/H)`: no
vertical flip; mesh loaders flip ``v`` instead)::

    nearest:   texel (floor(u' W), floor(v' H)), wrapped
    bilinear:  x = u' W - 1/2, y = v' H - 1/2; the four texels around (x, y),
               each wrapped, weighted by the fractional parts

Wrap modes map an integer texel index ``i`` into ``[0, N)``: ``repeat``
takes ``i mod N``, ``clamp`` clips to the edge, ``mirror`` reflects
``i mod 2N`` back into range (period ``2N``, edge texels repeated).
"""
from __future__ import annotations

import numpy as np

FILTER_TYPES = ("bilinear", "nearest")
# Rec. 709 luminance weights, Mitsuba's ``luminance()``: how an RGB texture becomes one
# number (``eval_1``: a roughness, a blend weight, an opacity) and a bitmap's ``mean``.
LUMINANCE = np.array([0.212671, 0.715160, 0.072169])
WRAP_MODES = ("repeat", "mirror", "clamp")


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
        uv, undefined = _finite_uv(uv)
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
        (for a grey texture, its value)."""
        return self.eval(uv) @ LUMINANCE

    def mean(self) -> float:
        """Mitsuba's ``Texture::mean()``: the number BSDFs pick lobes by (see subclasses)."""
        raise NotImplementedError


def _finite_uv(uv):
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

    def __init__(self, color0=0.4, color1=0.2, to_uv=None):
        super().__init__(to_uv)
        self.color0 = _as_texture(color0)
        self.color1 = _as_texture(color1)

    def eval(self, uv: np.ndarray) -> np.ndarray:
        """RGB values (n, 3) at surface coordinates ``uv`` (n, 2); 0 where ``uv`` is not finite."""
        uv, undefined = _finite_uv(uv)
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
        uv, undefined = _finite_uv(uv)
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


def wrap_index(i: np.ndarray, size: int, mode: str) -> np.ndarray:
    """Integer texel indices mapped into ``[0, size)`` by a wrap mode (see the module docstring)."""
    if mode == "repeat":
        return np.mod(i, size)
    if mode == "clamp":
        return np.clip(i, 0, size - 1)
    if mode == "mirror":
        i = np.mod(i, 2 * size)
        return np.where(i >= size, 2 * size - 1 - i, i)
    raise ValueError(f"wrap_mode must be one of {', '.join(WRAP_MODES)}, not \"{mode}\"")


class BitmapTexture(Texture):
    """Mitsuba's ``bitmap``: an image looked up with nearest or bilinear filtering.

    Parameters
    ----------
    data : (H, W, C) array_like
        Texel values, row 0 at ``v' = 0``; C = 1 or 2 (grey, grey + alpha)
        or 3 or 4 (RGB, RGBA). Alpha is dropped and grey repeated to RGB;
        values are kept in float32.
        Values are used as given: decode sRGB before (see
        :func:`pathtracer.bitmap.read_bitmap`).
    filter_type : {'bilinear', 'nearest'}
    wrap_mode : {'repeat', 'mirror', 'clamp'}
    to_uv : see :class:`Texture`
    """

    def __init__(self, data, filter_type: str = "bilinear", wrap_mode: str = "repeat",
                 to_uv=None):
        super().__init__(to_uv)
        if filter_type not in FILTER_TYPES:
            raise ValueError(f"filter_type must be one of {', '.join(FILTER_TYPES)}, "
                             f"not \"{filter_type}\"")
        if wrap_mode not in WRAP_MODES:
            raise ValueError(f"wrap_mode must be one of {', '.join(WRAP_MODES)}, not \"{wrap_mode}\"")
        data = np.asarray(data, np.float64)
        if data.ndim == 2:
            data = data[:, :, None]
        if data.ndim != 3 or data.shape[2] not in (1, 2, 3, 4) or not data.shape[0] * data.shape[1]:
            raise ValueError(f"bitmap data must be (H, W, 1-4 channels), got shape {data.shape}")
        rgb = data[:, :, :1].repeat(3, axis=2) if data.shape[2] <= 2 else data[:, :, :3]
        self.height, self.width = rgb.shape[:2]
        # Stored in float32, as Mitsuba stores them (and half the memory of float64);
        # lookups compute in float64. Row-major: texel (x, y) is row y * W + x.
        self.texels = np.ascontiguousarray(rgb.reshape(-1, 3), dtype=np.float32)
        self.filter_type = filter_type
        self.wrap_mode = wrap_mode

    def _fetch(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        x = wrap_index(x, self.width, self.wrap_mode)
        y = wrap_index(y, self.height, self.wrap_mode)
        return self.texels[y * self.width + x]

    def eval_uv(self, uv: np.ndarray) -> np.ndarray:
        """Filtered texel values (n, 3) at transformed coordinates."""
        x = uv[:, 0] * self.width
        y = uv[:, 1] * self.height
        if self.filter_type == "nearest":
            texels = self._fetch(np.floor(x).astype(np.int64), np.floor(y).astype(np.int64))
            return texels.astype(np.float64)
        x, y = x - 0.5, y - 0.5
        x0, y0 = np.floor(x), np.floor(y)
        fx, fy = (x - x0)[:, None], (y - y0)[:, None]
        x0, y0 = x0.astype(np.int64), y0.astype(np.int64)
        top = (1.0 - fx) * self._fetch(x0, y0) + fx * self._fetch(x0 + 1, y0)
        bottom = (1.0 - fx) * self._fetch(x0, y0 + 1) + fx * self._fetch(x0 + 1, y0 + 1)
        return (1.0 - fy) * top + fy * bottom

    def max_value(self) -> np.ndarray:
        """Channel-wise maximum texel (bilinear weights are convex, so it bounds every lookup)."""
        return self.texels.max(axis=0).astype(np.float64)

    def eval_1_grad(self, uv: np.ndarray) -> np.ndarray:
        """Gradient (n, 2) of :meth:`eval_1` with respect to the surface ``uv``, as Mitsuba's
        ``eval_1_grad``: the derivative of the bilinear interpolation of the four texels'
        luminances (0 for ``nearest`` filtering), through ``to_uv`` by its transpose."""
        uv, undefined = _finite_uv(uv)
        if self.filter_type == "nearest":
            return np.zeros((len(uv), 2))
        t = self.transform_uv(uv)
        x, y = t[:, 0] * self.width - 0.5, t[:, 1] * self.height - 0.5
        x0, y0 = np.floor(x), np.floor(y)
        wx1, wy1 = x - x0, y - y0
        wx0, wy0 = 1.0 - wx1, 1.0 - wy1
        x0, y0 = x0.astype(np.int64), y0.astype(np.int64)

        def lum(dx, dy):
            return self._fetch(x0 + dx, y0 + dy).astype(np.float64) @ LUMINANCE

        f00, f10, f01, f11 = lum(0, 0), lum(1, 0), lum(0, 1), lum(1, 1)
        d_x = wy0 * (f10 - f00) + wy1 * (f11 - f01)
        d_y = wx0 * (f01 - f00) + wx1 * (f11 - f10)
        grad = np.stack((d_x, d_y), axis=1) @ self.uv_linear   # transpose applied to (d_x, d_y)
        grad *= np.array([self.width, self.height], dtype=np.float64)
        if undefined is not None:
            grad[undefined] = 0.0
        return grad

    def mean(self) -> float:
        """Mean texel luminance, as Mitsuba's RGB variants compute a bitmap's mean."""
        return float(np.mean(self.texels.astype(np.float64) @ LUMINANCE))
