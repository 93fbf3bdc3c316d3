"""Reading and writing reference images as OpenEXR (no Mitsuba needed).

A reference file holds six float32 channels, ZIP-compressed:

====================  =============================================
``R``, ``G``, ``B``    per-pixel mean radiance
``var.R`` ... ``var.B``  unbiased per-*sample* variance (divide by
                       ``spp`` for the variance of the mean)
====================  =============================================

and string/int header attributes (``spp``, ``seed``, ``integrator``,
``variant``, ``mitsuba_version``, ``scene_hash``, ``key``,
``pixel_sha256``...). ``pixel_sha256`` is the SHA-256 of the float32 mean
and variance bytes as stored, so truncation or bit rot is detected.
"""

import hashlib

import numpy as np

MEAN_CHANNELS = ("R", "G", "B")
VAR_CHANNELS = ("var.R", "var.G", "var.B")


def pixel_checksum(mean, var):
    """SHA-256 (hex) of the float32 C-order bytes of ``mean`` then ``var``."""
    h = hashlib.sha256()
    for a in (mean, var):
        h.update(np.ascontiguousarray(a, dtype="<f4").tobytes())
    return h.hexdigest()


def write_reference_exr(path, mean, var, attributes):
    """Write mean and variance (H, W, 3) as a ZIP-compressed float32 EXR.

    ``attributes`` (str/int/float values) are stored in the header;
    ``pixel_sha256`` is added. Returns the checksum.
    """
    import OpenEXR

    mean = np.asarray(mean, dtype=np.float32)
    var = np.asarray(var, dtype=np.float32)
    if mean.shape != var.shape or mean.ndim != 3 or mean.shape[2] != 3:
        raise ValueError(f"expected two (H, W, 3) arrays, got {mean.shape}, {var.shape}")
    checksum = pixel_checksum(mean, var)
    header = {"compression": OpenEXR.ZIP_COMPRESSION,
              "type": OpenEXR.scanlineimage}
    for key, value in attributes.items():
        if isinstance(value, bool):
            value = int(value)
        if not isinstance(value, (str, int, float)):
            value = str(value)
        header[key] = value
    header["pixel_sha256"] = checksum
    channels = {}
    for i, name in enumerate(MEAN_CHANNELS):
        channels[name] = np.ascontiguousarray(mean[..., i])
    for i, name in enumerate(VAR_CHANNELS):
        channels[name] = np.ascontiguousarray(var[..., i])
    with OpenEXR.File(header, channels) as f:
        f.write(str(path))
    return checksum


def read_reference_exr(path):
    """Read ``(mean, var, attributes)``; mean and var are float64 (H, W, 3).

    Raises ``ValueError`` when a channel is missing; OpenEXR raises its own
    errors for unreadable files.
    """
    import OpenEXR

    with OpenEXR.File(str(path), separate_channels=True) as f:
        header = dict(f.header())
        channels = {name: np.array(ch.pixels) for name, ch in f.channels().items()}
    missing = [c for c in MEAN_CHANNELS + VAR_CHANNELS if c not in channels]
    if missing:
        raise ValueError(f"{path}: missing channels {missing}")
    mean = np.stack([channels[c] for c in MEAN_CHANNELS], axis=-1)
    var = np.stack([channels[c] for c in VAR_CHANNELS], axis=-1)
    attributes = {k: v for k, v in header.items()
                  if isinstance(v, (str, int, float)) and not isinstance(v, bool)}
    return mean.astype(np.float64), var.astype(np.float64), attributes
