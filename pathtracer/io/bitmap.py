"""Reading images (environment maps, textures) as float arrays, as Mitsuba's ``Bitmap`` does.

* OpenEXR: linear floats, read as stored.
* 8- and 16-bit formats Pillow reads (PNG, JPEG, BMP, TGA, ...): the values
  are sRGB-encoded; unless ``raw``, they are scaled to [0, 1] and decoded
  with the exact sRGB transfer curve, as Mitsuba converts them to linear
  before rendering.

* Radiance HDR (RGBE, ``.hdr``/``.rgbe``): linear, decoded here (Pillow
  cannot read it), ``mantissa * 2^(exponent - 136)`` as Mitsuba does.

Alpha is dropped; a one-channel (grey) image stays one channel. Mitsuba 3.9.1 holds 16-bit
images as half floats (measured: its bitmap texture returns exactly the float16 rounding of
the decoded values), so they are rounded to float16 here too.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core import interrupts
from .exr import read_channels
from .rgbe import MITSUBA_OFFSET, RGBEError, rgbe_pixels, rgbe_to_float


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
        An OpenEXR or Radiance HDR file, or any 8/16-bit image Pillow can open.
    raw : bool
        Keep 8/16-bit values sRGB-encoded (only scaled to [0, 1]); EXR and
        HDR data are linear either way.

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
    if suffix in (".hdr", ".rgbe"):
        return _read_rgbe(path)
    if suffix == ".pfm":
        raise BitmapError(f"{path.name}: PFM images are not supported (convert to OpenEXR)")
    return _read_pillow(path, raw)


def _read_exr(path: Path) -> np.ndarray:
    before = interrupts.count()
    try:
        channels, _ = read_channels(path)
    except Exception as error:  # OpenEXR raises plain exceptions on bad files
        interrupts.reraise_if_interrupted(before, error)     # a Ctrl-C, not a bad file
        raise BitmapError(f"{path.name}: not a readable OpenEXR file ({error})") from None
    for names in (("R", "G", "B"), ("Y",)):
        if all(n in channels for n in names):
            return np.stack([channels[n] for n in names], axis=2)
    raise BitmapError(f"{path.name}: no R, G, B (or Y) channels (has {', '.join(sorted(channels))})")


def _read_rgbe(path: Path) -> np.ndarray:
    """A Radiance picture: text header, blank line, ``-Y H +X W``, then scanlines."""
    data = path.read_bytes()
    header_end = data.find(b"\n\n")
    if not data.startswith(b"#?") or header_end < 0:
        raise BitmapError(f"{path.name}: not a Radiance HDR file (no '#?' header)")
    if b"FORMAT=32-bit_rle_xyze" in data[:header_end]:
        raise BitmapError(f"{path.name}: XYZE Radiance files are not supported (only RGBE)")
    size_end = data.find(b"\n", header_end + 2)
    size = data[header_end + 2:size_end].split()
    if len(size) != 4 or size[0] != b"-Y" or size[2] != b"+X":
        raise BitmapError(f"{path.name}: unsupported Radiance orientation {b' '.join(size).decode(errors='replace')!r} "
                          "(only the standard '-Y H +X W')")
    height, width = int(size[1]), int(size[3])
    try:
        rgbe = rgbe_pixels(data, size_end + 1, width, height, exact_end=False)
    except RGBEError:
        raise BitmapError(f"{path.name}: truncated or corrupt Radiance HDR pixel data") from None
    return rgbe_to_float(rgbe, MITSUBA_OFFSET)


def _read_pillow(path: Path, raw: bool) -> np.ndarray:
    # Pillow loads when an image is read: the student runtime renders with NumPy and SciPy
    # only (docs/architecture.md, "Deferred imports").
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as image:
            image.load()
            pixels, full_scale = _pillow_pixels(image)
    except (UnidentifiedImageError, OSError) as error:
        raise BitmapError(f"{path.name}: not a readable image ({error})") from None
    value = pixels / full_scale
    value = value if raw else srgb_to_linear(value)
    return value.astype(np.float16).astype(np.float64) if full_scale > 255 else value


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
