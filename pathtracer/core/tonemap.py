"""Linear radiance to displayable sRGB: the one tonemap of the PNG previews and every figure."""
from __future__ import annotations

import numpy as np

__all__ = ["tonemap", "auto_scale", "to_8bit"]


def tonemap(rgb, scale: float | None = None) -> np.ndarray:
    """Scale linear radiance, clip to [0, 1] and apply the sRGB transfer curve.

    Parameters
    ----------
    rgb : array_like
        Linear values, any shape (an (H, W, 3) image, usually).
    scale : float, optional
        Factor applied before clipping (``2 ** stops`` for an exposure in stops); None maps
        the image's 99th percentile to white (:func:`auto_scale`). Give images that are
        compared side by side the same scale.

    Returns
    -------
    ndarray of float64
        sRGB values in [0, 1]; NaN shows black and +inf white, so a broken render still
        displays.
    """
    x = np.asarray(rgb, dtype=np.float64)
    if scale is None:
        scale = auto_scale(x)
    x = np.clip(np.nan_to_num(x * scale), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def auto_scale(rgb) -> float:
    """The scale that maps the 99th percentile of the finite values of ``rgb`` to white (1 if none is > 0)."""
    x = np.asarray(rgb, dtype=np.float64)
    finite = x[np.isfinite(x)]
    q = float(np.percentile(finite, 99)) if finite.size else 0.0
    return 1.0 / q if q > 0 else 1.0


def to_8bit(srgb) -> np.ndarray:
    """sRGB values in [0, 1] (:func:`tonemap`'s) as rounded 8-bit integers."""
    return (np.asarray(srgb) * 255 + 0.5).astype(np.uint8)
