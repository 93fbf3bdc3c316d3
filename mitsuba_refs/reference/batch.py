r"""Per-pixel mean and per-sample variance from single Mitsuba samples, no Python per sample.

Mitsuba's ``moment`` integrator gives second moments of X, Y, Z only (no RGB
cross terms, so no RGB variance), and wrapping the estimator in a Python
integrator (:mod:`mitsuba_refs.reference.moments`) costs one Python call per sample in
``scalar_rgb``. Here each render call puts ``k`` copies of the scene's camera
side by side in Mitsuba's ``batch`` sensor and takes **one** sample per pixel:
the film (box filter) then holds ``k`` independent single samples of every
pixel, one per copy, rendered by the C++ estimator alone. NumPy reduces them:
per call the block mean and :math:`M_2 = \sum (L_i - \bar L)^2`, merged over
calls with Chan's formula, so

.. math::

    \bar L = \frac1n \sum L_i, \qquad s^2 = \frac{M_2}{n - 1}

are exactly the statistics of :mod:`mitsuba_refs.reference.moments` (same samples model,
float64 sums, and exactly zero variance where all samples agree).

Every call has its own seed (:func:`mitsuba_refs.reference.seeds.pass_seeds`, spaced
for the ``k`` times wider film); a copy's pixel is a different film pixel, so
it draws its own random stream.
"""

import math

import numpy as np

from pathtracer.render.moments import merge_statistics, two_pass_block_statistics

from .seeds import pass_seeds

#: Film pixels per render call (``k * W * H``): bounded memory, and large enough that the
#: per-call cost (block setup, developing the film) is small next to the path tracing.
BATCH_PIXELS = 1 << 18


def copies_per_call(spp, width, height):
    """``(k, calls)``: camera copies per call and number of calls for ``spp`` samples
    (``k * calls >= spp``, balanced so that at most ``calls - 1`` samples are wasted)."""
    k_max = max(1, BATCH_PIXELS // (width * height))
    calls = math.ceil(spp / k_max)
    return math.ceil(spp / calls), calls


def batch_sensor(sensor, k, width, height):
    """Mitsuba ``batch`` sensor of ``k`` copies of ``sensor`` on a ``k*width x height`` box-filtered film."""
    import mitsuba as mi
    desc = {"type": "batch",
            "film": {"type": "hdrfilm", "width": k * width, "height": height,
                     "rfilter": {"type": "box"}, "pixel_format": "rgb",
                     "component_format": "float32"}}
    for i in range(k):
        desc[f"copy{i}"] = sensor
    return mi.load_dict(desc)


class SampleStatistics:
    """Running per-pixel count, mean and M2 of blocks of single samples (Chan's merge,
    :mod:`pathtracer.render.moments`)."""

    def __init__(self):
        self.n, self.mean, self.m2 = 0, None, None

    def add(self, samples):
        """Add ``samples`` of shape (H, k, W, 3): ``k`` samples of every pixel."""
        block = two_pass_block_statistics(np.asarray(samples, dtype=np.float64))
        self.n, self.mean, self.m2 = merge_statistics((self.n, self.mean, self.m2), block)

    def variance(self):
        """Unbiased per-sample variance ``M2 / (n - 1)``."""
        if self.n < 2:
            raise ValueError("variance needs at least 2 samples per pixel")
        return self.m2 / (self.n - 1)


def call_takes(spp, k, calls):
    """Samples kept from each of the ``calls`` render calls of ``k`` copies (the last call's
    surplus copies are dropped)."""
    return [max(0, min(k, spp - i * k)) for i in range(calls)]


def render_call(scene, batch, integrator, call_seed, take):
    """One render call's block statistics ``(n, mean, M2)`` of its first ``take`` copies
    (:func:`~pathtracer.render.moments.two_pass_block_statistics`)."""
    import mitsuba as mi

    width = int(scene.sensors()[0].film().crop_size()[0])
    image = mi.render(scene, sensor=batch, integrator=integrator, spp=1, seed=call_seed)
    samples = np.array(image, dtype=np.float64)[..., :3]
    height, k = samples.shape[0], samples.shape[1] // width
    return two_pass_block_statistics(samples.reshape(height, k, width, 3)[:, :take])


def render_moments(scene, integrator, spp, seed, stream, progress=None, split=None):
    """Render ``spp`` single samples per pixel of ``scene``'s first sensor.

    Parameters
    ----------
    scene : mitsuba.Scene
    integrator : mitsuba.Integrator
        The estimator itself (no wrapper).
    spp, seed, stream : int
        Samples per pixel; base seed and stream of :func:`mitsuba_refs.reference.seeds.pass_seeds`.
    progress : pathtracer.core.progress.Progress, optional
        Told the samples done after every call.
    split : callable, optional
        ``split(calls)``: the block statistics of render calls ``0 .. calls - 1``, in call
        order, rendered elsewhere (a cluster, :mod:`mitsuba_refs.cluster.build`) by
        :func:`render_call` with the same seeds. The blocks are merged here in call order,
        whoever rendered them, so the result is the same bit for bit.

    Returns
    -------
    (mean, var, n, calls, k, seeds)
        (H, W, 3) float64 mean and per-sample variance, ``n = spp``, and how it was cut.
    """
    sensor = scene.sensors()[0]
    width, height = (int(v) for v in sensor.film().crop_size())
    k, calls = copies_per_call(spp, width, height)
    seeds = pass_seeds(seed, calls, k * width, height, stream)
    if split is None:
        batch = batch_sensor(sensor, k, width, height)
        blocks = (render_call(scene, batch, integrator, call_seed, take)
                  for call_seed, take in zip(seeds, call_takes(spp, k, calls)))
    else:
        blocks = split(calls)
    stats = SampleStatistics()
    for block in blocks:
        stats.n, stats.mean, stats.m2 = merge_statistics((stats.n, stats.mean, stats.m2), block)
        if progress:
            progress.advance(block[0])
    return stats.mean, stats.variance(), stats.n, calls, k, seeds
