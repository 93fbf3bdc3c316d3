"""Reading images (environment maps, textures) as float arrays, as Mitsuba's ``Bitmap`` does.

* OpenEXR: linear floats, read as stored.
* 8- and 16-bit formats Pillow reads (PNG, JPEG, BMP, TGA, ...): the values
  are sRGB-encoded; unless ``raw``, they are scaled to [0, 1] and decoded
  with the exact sRGB transfer curve, as Mitsuba converts them to linear
  before rendering.

Alpha is dropped; a one-channel (grey) image stays one channel. Radiance HDR
(RGBE) files are refused: Pillow cannot read them.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np


class BitmapError(ValueError):
    """An image that cannot be read, with the reason."""


def srgb_to_linear(value: np.ndarray) -> np.ndarray:
    """The exact sRGB decoding curve (IEC 61966-2-1) on values in [0, 1]."""
    value = np.asarray(value, dtype=np.float64)
    return np.where(value <= 0.04045, value / 12.92, ((value + 0.055) / 1.055) ** 2.4)


def read_bitmap(path, *, raw: bool = False) -> np.ndarray:
    """Read an image file as an (H, W, C) float64 array, row 0 at the top.

    Parameters
    ----------
    path : str or Path
        An OpenEXR file, or any 8/16-bit image Pillow can open.
    raw : bool
        Keep 8/16-bit values sRGB-encoded (only scaled to [0, 1]); EXR data
        is linear either way.

    Returns
    -------
    (H, W, C) ndarray
        C is 3 for colour images, 1 for grey ones (alpha dropped).

    Raises
    ------
    BitmapError
        The file is missing, unreadable, or in a format we do not read.
    """
    path = Path(path)
    if not path.is_file():
        raise BitmapError(f"image file not found: {path}")
    suffix = path.suffix.lower()
    if suffix == ".exr":
        return _read_exr(path)
    if suffix in (".hdr", ".rgbe", ".pfm"):
        raise BitmapError(f"{path.name}: {suffix} images are not supported (convert to OpenEXR)")
    return _read_pillow(path, raw)


def _read_exr(path: Path) -> np.ndarray:
    import OpenEXR

    try:
        with OpenEXR.File(str(path), separate_channels=True) as exr:
            channels = {name: np.asarray(c.pixels, dtype=np.float64)
                        for name, c in exr.channels().items()}
    except Exception as error:  # OpenEXR raises plain exceptions on bad files
        raise BitmapError(f"{path.name}: not a readable OpenEXR file ({error})") from None
    for names in (("R", "G", "B"), ("Y",)):
        if all(n in channels for n in names):
            return np.stack([channels[n] for n in names], axis=2)
    raise BitmapError(f"{path.name}: no R, G, B (or Y) channels (has {', '.join(sorted(channels))})")


def _read_pillow(path: Path, raw: bool) -> np.ndarray:
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as image:
            image.load()
            pixels, full_scale = _pillow_pixels(image)
    except (UnidentifiedImageError, OSError) as error:
        raise BitmapError(f"{path.name}: not a readable image ({error})") from None
    value = pixels / full_scale
    return value if raw else srgb_to_linear(value)


def _pillow_pixels(image) -> tuple[np.ndarray, float]:
    """Pixels as float (H, W, C) without alpha, and the value of full scale."""
    if image.mode in ("I;16", "I;16B", "I;16L", "I"):     # 16-bit grey
        return np.asarray(image, dtype=np.float64)[:, :, None], 65535.0
    if image.mode in ("L", "LA", "1"):
        grey = image.convert("L")
        return np.asarray(grey, dtype=np.float64)[:, :, None], 255.0
    if image.mode == "F":
        raise OSError("32-bit float images need OpenEXR")
    return np.asarray(image.convert("RGB"), dtype=np.float64), 255.0
