r"""Mitsuba's ``bitmap`` texture: an image looked up by texture coordinates.

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

import os

import numpy as np

from ..core.color import LUMINANCE
from ..core.sampling import sample_discrete
from ..io.bitmap import read_bitmap
from ..scene.properties import Props, children, find_file
from ..scene.registry import register
from .base import Texture, finite_uv

FILTER_TYPES = ("bilinear", "nearest")
WRAP_MODES = ("repeat", "mirror", "clamp")


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
        :func:`pathtracer.io.bitmap.read_bitmap`).
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
        uv, undefined = finite_uv(uv)
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

    # -- sampling positions by the image (an area light's radiance) ------------------------

    spatially_varying = True

    def _texel_pmf(self) -> tuple[np.ndarray, np.ndarray]:
        """The texels' probabilities (row-major, proportional to luminance) and their
        cumulative sums, built once."""
        if getattr(self, "_pmf", None) is None:
            lum = np.maximum(self.texels.astype(np.float64) @ LUMINANCE, 0.0)
            total = lum.sum()
            pmf = lum / total if total > 0 else np.full(len(lum), 1.0 / len(lum))
            self._pmf, self._cdf = pmf, np.cumsum(pmf)
        return self._pmf, self._cdf

    def sample_position(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r"""Mitsuba's ``BitmapTexture::sample_position`` (``to_uv`` not applied): a texel
        with probability :math:`p_i` proportional to its luminance, then a point in it:
        uniform for ``nearest``; for ``bilinear`` the texel's centre plus a tent of one
        texel each way, folded back into the unit square (repeat: wrapped; clamp and
        mirror: reflected). Density: :meth:`pdf_position`."""
        _, cdf = self._texel_pmf()
        index, u_x = sample_discrete(cdf, np.asarray(u[:, 0], np.float64))
        texel = np.stack((index % self.width, index // self.width), axis=1).astype(np.float64)
        offset = np.stack((u_x, u[:, 1]), axis=1)
        res = np.array([self.width, self.height], np.float64)
        if self.filter_type == "nearest":
            uv = (texel + offset) / res
        else:
            uv = (texel + 0.5 + _square_to_tent(offset)) / res
            if self.wrap_mode == "repeat":
                uv = np.where(uv < 0.0, uv + 1.0, np.where(uv > 1.0, uv - 1.0, uv))
            else:
                uv = np.where(uv < 0.0, -uv, np.where(uv > 1.0, 2.0 - uv, uv))
        return uv, self.pdf_position(uv)

    def pdf_position(self, uv: np.ndarray) -> np.ndarray:
        """Density over the unit square: ``W H p`` of the texel (``nearest``), or the
        bilinear interpolation of the texels' ``W H p`` with the lookup's weights and wrap
        mode (``bilinear``), as Mitsuba's ``pdf_position``."""
        pmf, _ = self._texel_pmf()
        uv = np.asarray(uv, np.float64)
        scale = self.width * self.height

        def p(x, y):
            x = wrap_index(x, self.width, self.wrap_mode)
            y = wrap_index(y, self.height, self.wrap_mode)
            return pmf[y * self.width + x]

        x, y = uv[:, 0] * self.width, uv[:, 1] * self.height
        if self.filter_type == "nearest":
            return p(np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)) * scale
        x, y = x - 0.5, y - 0.5
        x0, y0 = np.floor(x), np.floor(y)
        fx, fy = x - x0, y - y0
        x0, y0 = x0.astype(np.int64), y0.astype(np.int64)
        top = (1.0 - fx) * p(x0, y0) + fx * p(x0 + 1, y0)
        bottom = (1.0 - fx) * p(x0, y0 + 1) + fx * p(x0 + 1, y0 + 1)
        return ((1.0 - fy) * top + fy * bottom) * scale


def _square_to_tent(u: np.ndarray) -> np.ndarray:
    """Mitsuba's ``square_to_tent``: each coordinate to [-1, 1] with density ``1 - |x|``."""
    return np.where(u < 0.5, np.sqrt(2.0 * u) - 1.0, 1.0 - np.sqrt(2.0 - 2.0 * u))


@register("texture", "bitmap")
def create(props: Props) -> BitmapTexture:
    """``filename`` (looked up in ``props.folders``), ``filter_type``, ``wrap_mode``, ``raw``
    (false), ``to_uv``."""
    plugin = props.plugin
    children(plugin, {"texture": 2})
    to_uv = props.transform("to_uv")
    filter_type = props.string("filter_type", "bilinear").strip().lower()
    wrap_mode = props.string("wrap_mode", "repeat").strip().lower()
    for name, value, allowed in (("filter_type", filter_type, FILTER_TYPES),
                                 ("wrap_mode", wrap_mode, WRAP_MODES)):
        if value not in allowed:
            raise plugin.error(f"unknown {name} \"{value}\" (supported: "
                               f"{', '.join(allowed)})", props.line(name))
    raw = props.bool("raw", False)
    # accel only picks hardware texture units on GPUs, format the storage precision
    # (half or the variant's float): the values are the same up to rounding.
    props.ignore("accel", "format")
    path = find_file(plugin, props, "filename", props.folders)
    try:
        data = read_bitmap(path, raw=raw)
    except ValueError as e:
        raise plugin.error(f"{os.path.basename(path)}: {e}", props.line("filename")) from None
    props.finish()
    return BitmapTexture(data, filter_type, wrap_mode, to_uv)
