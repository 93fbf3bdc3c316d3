"""Radiance RGBE pixels: the scanlines of a ``.hdr`` picture, decoded to floats.

One decoder for both readers of the format: environment maps and textures
(:mod:`pathtracer.io.bitmap`, which must decode as Mitsuba does) and images of other renderers
(:mod:`mitsuba_refs.external.images`, which decode as Radiance does). The two differ only in
the value a stored mantissa stands for (:func:`rgbe_to_float`'s ``offset``).
"""
from __future__ import annotations

import numpy as np

#: Stored mantissa m, exponent e -> (m + offset) * 2^(e - 136); e = 0 is black.
MITSUBA_OFFSET = 0.0        # Mitsuba 3's reader: m * 2^(e - 136)
RADIANCE_OFFSET = 0.5       # Radiance's colr_color: the middle of the truncated interval


class RGBEError(ValueError):
    """Truncated or corrupt RGBE pixel data (the message says where; the caller names the file)."""


def rgbe_to_float(rgbe: np.ndarray, offset: float) -> np.ndarray:
    """(H, W, 3) floats of (H, W, 4) RGBE bytes: ``(m + offset) * 2^(e - 136)``, 0 where e = 0."""
    exponent = rgbe[:, :, 3].astype(np.int32)
    unit = np.where(exponent > 0, np.ldexp(1.0, exponent - (128 + 8)), 0.0)[:, :, None]
    return (rgbe[:, :, :3] + offset) * unit


def rgbe_pixels(data: bytes, start: int, width: int, height: int, *, exact_end: bool = True) -> np.ndarray:
    """The (H, W, 4) uint8 RGBE values of the ``height`` scanlines from ``start`` in ``data``.

    ``exact_end``: the last scanline must end at the end of ``data`` (else bytes after it
    are ignored).

    Raises
    ------
    RGBEError
        For truncated or corrupt pixel data and old-style run-length codes.
    """
    run_length_possible = 8 <= width <= 0x7FFF
    flat_size = 4 * width
    smallest_scanline = min(flat_size, 4 + 8 * -(-width // 127)) if run_length_possible else flat_size
    available = len(data) - start
    if available < height * smallest_scanline:
        raise RGBEError(f"truncated: {height} scanlines of {width} pixels need at least "
                           f"{height * smallest_scanline} bytes, the file has {available}")
    buffer = np.frombuffer(data, dtype=np.uint8)
    if not run_length_possible:                   # only flat scanlines: one array
        if available < height * flat_size or (exact_end and available != height * flat_size):
            raise RGBEError(f"{width}x{height} flat RGBE pixels are {height * flat_size} bytes, the file "
                               f"has {available} after its header")
        pixels = buffer[start:start + height * flat_size].reshape(height, width, 4)
        _refuse_old_run_length(pixels)
        return pixels
    pixels = np.empty((height, width, 4), dtype=np.uint8)
    flat_rows = []
    position = start
    for row in range(height):
        if data[position:position + 2] == b"\x02\x02" and position + 4 <= len(data) and data[position + 2] < 128:
            encoded_width = data[position + 2] << 8 | data[position + 3]
            if encoded_width != width:
                raise RGBEError(f"scanline {row} says it is {encoded_width} pixels wide, the picture is {width}")
            position = _run_length_scanline(data, buffer, position + 4, pixels[row], row)
        else:
            if position + flat_size > len(data):
                raise RGBEError(f"truncated in scanline {row} of {height} (flat pixels)")
            pixels[row] = buffer[position:position + flat_size].reshape(width, 4)
            flat_rows.append(row)
            position += flat_size
    if exact_end and position != len(data):
        raise RGBEError(f"{len(data) - position} bytes after the last of {height} scanlines "
                           "(is the resolution line's height right?)")
    _refuse_old_run_length(pixels[flat_rows])
    return pixels


def _run_length_scanline(data: bytes, buffer: np.ndarray, position: int, row_pixels: np.ndarray,
                         row: int) -> int:
    """Decode one new-style run-length scanline (four channels one after the other, each as
    runs, a count byte over 128 then one value, and literals, a count up to 128 then the
    values) into ``row_pixels``; returns the position after it."""
    width = len(row_pixels)
    for channel in range(4):
        x = 0
        while x < width:
            if position >= len(data):
                raise RGBEError(f"truncated in scanline {row} (run-length encoded)")
            count = data[position]
            if count > 128:
                count -= 128
                value_end = position + 2
                values = data[position + 1] if value_end <= len(data) else None
            else:
                value_end = position + 1 + count
                values = buffer[position + 1:value_end] if value_end <= len(data) else None
            if count == 0 or x + count > width:
                raise RGBEError(f"corrupt run-length data in scanline {row}: a run of {count} at pixel {x} "
                                   f"of {width}")
            if values is None:
                raise RGBEError(f"truncated in scanline {row} (run-length encoded)")
            row_pixels[x:x + count, channel] = values
            position = value_end
            x += count
    return position


def _refuse_old_run_length(flat_pixels: np.ndarray) -> None:
    """Refuse flat pixels (1, 1, 1, n): old-style Radiance run-length codes, not read here."""
    if np.any(np.all(flat_pixels[..., :3] == 1, axis=-1)):
        raise RGBEError("old-style Radiance run-length encoding (pixels 1, 1, 1, n) is not read")
