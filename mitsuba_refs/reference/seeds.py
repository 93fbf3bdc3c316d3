"""The Mitsuba seeds of a reference's render passes (:mod:`mitsuba_refs.reference.render`,
:mod:`mitsuba_refs.reference.batch`)."""

import math

from . import config


def pass_seeds(seed, n_passes, width, height, stream=0):
    """Mitsuba seeds of the passes of a reference with seed ``seed``.

    Pass ``k`` uses ``((seed * 2^20 + stream) * SEED_STRIDE + k) * spacing``
    (mod 2^32), ``stream`` from :func:`stream_id`. In ``scalar_rgb``
    Mitsuba multiplies the seed by ``W * H`` and seeds each 32 x 32 block
    from there; ``spacing`` is the number of ``W * H`` strides the padded
    blocks span (1 when W, H are multiples of 32), so no two passes share a
    stream. JIT variants hash (seed, lane) and need no spacing, but it costs
    nothing.
    """
    if n_passes > config.SEED_STRIDE:
        raise ValueError(f"at most {config.SEED_STRIDE} passes")
    padded = math.ceil(width / 32) * math.ceil(height / 32) * 1024
    spacing = math.ceil(padded / (width * height))
    base = (seed * 2**20 + stream) * config.SEED_STRIDE
    return [((base + k) * spacing) % 2**32 for k in range(n_passes)]
