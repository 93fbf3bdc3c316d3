"""OpenEXR files of a mean and a variance image: the one format of renders and references.

A file holds six channels, ZIP-compressed scanlines:

======================  ==============================================
``R``, ``G``, ``B``      per-pixel mean radiance
``var.R`` ... ``var.B``  per-*sample* variance of each pixel (divide by
                         the sample count for the variance of the mean)
======================  ==============================================

and header attributes saying how it was made (strings, ints, floats: a render's ``spp``,
``seed``, ``integrator``...; a reference's ``key``, ``pixel_sha256``...). Values beyond
the stored float type's range are stored as its largest value and counted in the header
(``clamped_mean``, ``clamped_variance``); NaN stays NaN. :mod:`pathtracer.io.output`
writes renders with it, :mod:`mitsuba_refs.reference.exr` references.
"""
from __future__ import annotations

import warnings

import numpy as np

MEAN_CHANNELS = ("R", "G", "B")
VARIANCE_CHANNELS = ("var.R", "var.G", "var.B")
#: Largest int an EXR ``int`` attribute (signed 32-bit) holds; larger ones are stored as text.
EXR_INT_MAX = 2 ** 31 - 1


class PrecisionWarning(UserWarning):
    """Values that do not fit the EXR's float type were clamped to its largest value."""


def _stored(values: np.ndarray, dtype, what: str, clamped: dict) -> np.ndarray:
    """``values`` as ``dtype``, magnitudes beyond its range clamped to its largest value."""
    largest = float(np.finfo(dtype).max)
    too_large = int(np.count_nonzero(np.abs(values) > largest))
    if too_large:
        clamped[what] = clamped.get(what, 0) + too_large
        values = np.clip(values, -largest, largest)
    return np.ascontiguousarray(values, dtype=dtype)


def _attribute(value):
    """A header value OpenEXR stores: a bool as an int, an int beyond 32 bits and anything
    that is not a str, int or float as text."""
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, int):
        return value if -EXR_INT_MAX - 1 <= value <= EXR_INT_MAX else str(value)
    return value if isinstance(value, (str, float)) else str(value)


def write_mean_variance(path, mean, variance, attributes: dict, dtype=np.float32) -> dict:
    """Write (H, W, 3) ``mean`` and ``variance`` images and the header ``attributes`` to ``path``.

    Returns the counts of values clamped to ``dtype``'s range, ``{"mean": n, "variance": n}``
    for the images that had any (also in the header as ``clamped_mean``, ``clamped_variance``);
    :func:`warn_clamped` says so once the file is in place.

    Raises
    ------
    ValueError
        When the images are not two (H, W, 3) arrays of the same shape.
    """
    mean, variance = np.asarray(mean), np.asarray(variance)
    if mean.shape != variance.shape or mean.ndim != 3 or mean.shape[2] != 3:
        raise ValueError(f"expected two (H, W, 3) arrays, got {mean.shape}, {variance.shape}")
    channels, clamped = {}, {}
    for c, name in enumerate(MEAN_CHANNELS):
        channels[name] = _stored(mean[:, :, c], dtype, "mean", clamped)
    for c, name in enumerate(VARIANCE_CHANNELS):
        channels[name] = _stored(variance[:, :, c], dtype, "variance", clamped)
    import OpenEXR  # loaded when a file is written: see read_channels
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    header.update({key: _attribute(value) for key, value in attributes.items()})
    header.update({f"clamped_{what}": count for what, count in clamped.items()})
    with OpenEXR.File(header, channels) as exr:
        exr.write(str(path))
    return clamped


def warn_clamped(path, clamped: dict, dtype=np.float32, stacklevel: int = 2) -> None:
    """A :class:`PrecisionWarning` per image of ``path`` that had values clamped (counts from
    :func:`write_mean_variance`)."""
    for what, count in clamped.items():
        warnings.warn(PrecisionWarning(
            f"{path}: {count} {what} values exceed the EXR's {np.dtype(dtype).name} range and "
            f"were stored as its largest value, {np.finfo(dtype).max:.3g} (header clamped_{what})"),
            stacklevel=stacklevel + 1)


def read_channels(path) -> tuple[dict, dict]:
    """``(channels, header)`` of any EXR file: every channel as a float64 (H, W) array by
    name, and the header. OpenEXR raises its own errors for unreadable files."""
    # Loaded when a file is read: the student runtime renders with NumPy and SciPy only
    # (docs/architecture.md, "Deferred imports").
    import OpenEXR
    # separate_channels: OpenEXR would otherwise group R, G, B (and var.*) into one array.
    with OpenEXR.File(str(path), separate_channels=True) as exr:
        header = dict(exr.header())       # the file's own dict is cleared on close
        channels = {name: np.asarray(c.pixels, dtype=np.float64) for name, c in exr.channels().items()}
    return channels, header


def read_mean_variance(path) -> tuple[np.ndarray, np.ndarray, dict]:
    """``(mean, variance, attributes)`` of a file written by :func:`write_mean_variance`:
    float64 (H, W, 3) images and the header's str, int and float attributes.

    Raises
    ------
    ValueError
        When a channel is missing.
    """
    channels, header = read_channels(path)
    missing = [c for c in MEAN_CHANNELS + VARIANCE_CHANNELS if c not in channels]
    if missing:
        raise ValueError(f"{path}: missing channels {missing}")
    mean = np.stack([channels[c] for c in MEAN_CHANNELS], axis=-1)
    variance = np.stack([channels[c] for c in VARIANCE_CHANNELS], axis=-1)
    attributes = {k: v for k, v in header.items()
                  if isinstance(v, (str, int, float)) and not isinstance(v, bool)}
    return mean, variance, attributes
