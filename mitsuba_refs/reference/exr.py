"""Reference images as OpenEXR (no Mitsuba needed): the tracer's format
(:mod:`pathtracer.io.exr`: float32 mean and variance channels, ZIP-compressed) with a checksum.

The header holds ``spp``, ``seed``, ``integrator``, ``variant``, ``mitsuba_version``,
``scene_hash``, ``key``... and ``pixel_sha256``, the SHA-256 of the float32 mean and
variance bytes as stored, so that truncation or bit rot is detected
(:func:`mitsuba_refs.reference.cache.validate`). Read a reference with
:func:`pathtracer.io.exr.read_mean_variance`.
"""

import hashlib

import numpy as np

from pathtracer.io.exr import warn_clamped, write_mean_variance


def pixel_checksum(mean, var):
    """SHA-256 (hex) of the float32 C-order bytes of ``mean`` then ``var``."""
    h = hashlib.sha256()
    for a in (mean, var):
        h.update(np.ascontiguousarray(a, dtype="<f4").tobytes())
    return h.hexdigest()


def write_reference_exr(path, mean, var, attributes):
    """Write mean and variance (H, W, 3) as a reference EXR (float32).

    ``attributes`` (str/int/float values) are stored in the header;
    ``pixel_sha256`` is added. Returns the checksum.
    """
    mean = np.asarray(mean, dtype=np.float32)
    var = np.asarray(var, dtype=np.float32)
    checksum = pixel_checksum(mean, var)
    clamped = write_mean_variance(path, mean, var, {**attributes, "pixel_sha256": checksum})
    warn_clamped(path, clamped)
    return checksum
