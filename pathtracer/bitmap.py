"""Reading images (PNG, JPEG, EXR) into linear float arrays.

8- and 16-bit images (PNG, JPEG) hold sRGB-encoded values, as Mitsuba 3
assumes for them; unless ``raw`` is set they are decoded to linear values
with the sRGB transfer curve. Mitsuba 3.9.1 then holds 16-bit images as
half floats (measured: its bitmap texture returns exactly the float16
rounding of the decoded values), so they are rounded to float16 here too.
EXR files hold linear floats and are returned as stored. Row 0 of the array
is the top row of the image.
"""
from __future__ import annotations

import os

import numpy as np

EXR_EXTENSIONS = (".exr",)
LDR_EXTENSIONS = (".png", ".jpg", ".jpeg")


def srgb_to_linear(value: np.ndarray) -> np.ndarray:
    """Decode sRGB-encoded values in [0, 1] with the exact sRGB transfer curve."""
    value = np.asarray(value, np.float64)
    return np.where(value <= 0.04045, value / 12.92,
                    np.power((np.maximum(value, 0.04045) + 0.055) / 1.055, 2.4))


def read_bitmap(path, *, raw: bool = False) -> np.ndarray:
    """An image file as an (H, W, C) float64 array.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.png``, ``.jpg``/``.jpeg`` or ``.exr`` file.
    raw : bool
        Keep 8/16-bit values as stored (scaled to [0, 1]) instead of decoding
        sRGB to linear; EXR data is linear either way.

    Returns
    -------
    (H, W, C) float64 with C = 1 (grey), 2 (grey + alpha), 3 (RGB) or 4
    (RGBA), channels in that order; row 0 is the top of the image.

    Raises
    ------
    ValueError
        For an unknown extension or a file that cannot be decoded.
    """
    path = os.fspath(path)
    ext = os.path.splitext(path)[1].lower()
    if ext in EXR_EXTENSIONS:
        return _read_exr(path)
    if ext in LDR_EXTENSIONS:
        encoded, bits = _read_ldr(path)
        value = encoded if raw else srgb_to_linear(encoded)
        return value.astype(np.float16).astype(np.float64) if bits == 16 else value
    raise ValueError(f"unsupported image format \"{ext}\" (supported: PNG, JPEG, EXR)")


def _read_ldr(path: str) -> tuple[np.ndarray, int]:
    """An 8- or 16-bit image scaled to [0, 1], as (H, W, C), and its bits per channel."""
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as image:
            image.load()
            if image.mode == "P":  # palette images: expand to the colours they show
                image = image.convert("RGBA" if "transparency" in image.info else "RGB")
            if image.mode in ("I;16", "I;16B", "I;16L", "I"):
                data, bits = np.asarray(image, dtype=np.float64) / 65535.0, 16
            elif image.mode in ("L", "LA", "RGB", "RGBA"):
                data, bits = np.asarray(image, dtype=np.float64) / 255.0, 8
            else:
                data, bits = np.asarray(image.convert("RGB"), dtype=np.float64) / 255.0, 8
    except (OSError, UnidentifiedImageError) as e:
        raise ValueError(f"could not read image: {e}") from None
    return (data[:, :, None] if data.ndim == 2 else data), bits


def _read_exr(path: str) -> np.ndarray:
    """The Y, YA, RGB or RGBA channels of an EXR file, as (H, W, C)."""
    import OpenEXR

    try:
        with OpenEXR.File(path, separate_channels=True) as exr:
            channels = {name: np.asarray(ch.pixels, np.float64)
                        for name, ch in exr.channels().items()}
    except Exception as e:  # OpenEXR raises plain Exceptions for bad files
        raise ValueError(f"could not read EXR image: {e}") from None
    for names in (("R", "G", "B", "A"), ("R", "G", "B"), ("Y", "A"), ("Y",)):
        if all(n in channels for n in names):
            return np.stack([channels[n] for n in names], axis=2)
    raise ValueError(f"EXR image has no Y or R, G, B channels (has: {', '.join(sorted(channels))})")
