r"""Filtered (tent, gaussian) references in ``scalar_rgb``: single samples at known positions.

Mitsuba's scalar film weights samples with a 31-entry table of the filter
(:mod:`mitsuba_refs.rfilter`); the references need the exact weights, which the tracer and
Mitsuba's vectorised variants use. So the samples are rendered as for a box film
(:mod:`mitsuba_refs.batch`: ``k`` copies of the camera side by side, one sample per pixel,
the C++ estimator alone), the film position of each is computed exactly as Mitsuba drew it
(:mod:`mitsuba_refs.positions`), and NumPy splats them with the tracer's own filter code
(:func:`pathtracer.sensors.film.splat`). Per pixel ``p`` this accumulates over all
``n`` samples of the whole film

.. math::

    W_p = \sum_i w_i(p), \qquad m_{1,p} = \frac{\sum_i w_i(p) f_i}{W_p}, \qquad
    m_{2,p} = \frac{\sum_i w_i(p) f_i^2}{W_p},

``w_i(p) = w(c_p - x_i)`` the separable filter weight, weights outside the image dropped:
exactly what Mitsuba's ``hdrfilm`` holds with the ``rgb_moments`` AOVs in ``llvm_ad_rgb``,
so :func:`mitsuba_refs.rfilter.per_sample_variance` turns them into the same per-sample
variance ``(m_2 - m_1^2) n_eff / (n_eff - 1)``. The samples have the distribution of the
filtered film's: ``n`` per pixel, uniform in it (no sample border).

A sample is grouped with the pixel the box film stored it in; the rare one whose traced
position lies outside that pixel (float32 rounding of ``pixel + u`` up to the pixel's right
edge, or of the batch sensor's copy index across a copy boundary) is moved to where it was
traced (:func:`_move`).
"""

import numpy as np

from pathtracer.sensors.film import splat

from .batch import batch_sensor, copies_per_call
from .positions import BLOCK_SIZE, batch_positions, check_positions
from .seeds import pass_seeds


class FilteredSums:
    """Running per-pixel ``sum w``, ``sum w f``, ``sum w f^2`` (float64) of one film."""

    def __init__(self, rfilter, width, height):
        self.rfilter, self.width, self.height = rfilter, width, height
        size = width * height
        self.w, self.wf, self.wf2 = np.zeros(size), np.zeros((size, 3)), np.zeros((size, 3))

    def add(self, values, x, y):
        """Add samples ``values`` (H, S, W, 3) traced at film positions ``x``, ``y`` (H, S, W):
        ``S`` samples of every pixel, each stored in the pixel of its row and column."""
        height, samples, width = x.shape
        rows = np.arange(height)[:, None, None]
        cols = np.arange(width)[None, None, :]
        u = np.stack([x - cols, y - rows], axis=-1)                       # (H, S, W, 2)
        clipped = np.clip(u, 0.0, 1.0)
        pixel = np.arange(height * width)
        per_pixel = [a.transpose(0, 2, 1, 3).reshape(height * width, samples, -1)
                     for a in (clipped, values)]
        self._accumulate(1.0, splat(self.rfilter, width, height, pixel, *per_pixel))
        moved = np.nonzero(np.any(u != clipped, axis=-1))
        if moved[0].size:
            row, col = moved[0], moved[2]
            self._move(row * width + col, clipped[moved], values[moved], x[moved], y[moved])

    def _move(self, stored, u_stored, values, x, y):
        """Take samples out of the pixels ``stored`` (at ``u_stored``, where :meth:`add` put
        them) and splat them where they were traced, ``(x, y)``."""
        col = np.clip(np.floor(x).astype(np.int64), 0, self.width - 1)
        row = np.clip(np.floor(y).astype(np.int64), 0, self.height - 1)
        traced = row * self.width + col
        u_traced = np.stack([x - col, y - row], axis=-1)
        self._scattered(-1.0, stored, u_stored, values)
        self._scattered(1.0, traced, u_traced, values)

    def _scattered(self, sign, pixel, u, values):
        """Splat one sample per entry; entries that share a pixel go in separate rounds
        (:func:`splat` takes distinct pixels)."""
        left = np.arange(pixel.size)
        while left.size:
            _, first = np.unique(pixel[left], return_index=True)
            now = left[first]
            sums = splat(self.rfilter, self.width, self.height, pixel[now],
                         u[now][:, None, :], values[now][:, None, :])
            self._accumulate(sign, sums)
            left = np.delete(left, first)

    def _accumulate(self, sign, sums):
        w, wf, wf2 = sums
        self.w += sign * w
        self.wf += sign * wf
        self.wf2 += sign * wf2

    def moments(self):
        """``(m1, m2)``: (H, W, 3) weighted first and second moments."""
        shape = (self.height, self.width, 3)
        w = self.w[:, None]
        return (self.wf / w).reshape(shape), (self.wf2 / w).reshape(shape)


def integrator_with_blocks(nested):
    """The integrator dictionary with Mitsuba's block size fixed (:data:`BLOCK_SIZE`),
    which the sample positions depend on."""
    return dict(nested, block_size=BLOCK_SIZE)


def render_filtered_moments(scene, integrator, spp, seed, stream, rfilter, log=None):
    """Render ``spp`` single samples per pixel and reconstruct them with ``rfilter``.

    Parameters
    ----------
    scene : mitsuba.Scene
    integrator : mitsuba.Integrator
        The estimator, loaded from :func:`integrator_with_blocks`'s dictionary.
    spp, seed, stream : int
        As for :func:`mitsuba_refs.batch.render_moments`.
    rfilter : pathtracer.sensors.film.ReconstructionFilter
    log : callable, optional

    Returns
    -------
    (m1, m2, n, calls, k, seeds)
        (H, W, 3) filter-weighted moments, ``n = spp``, and how it was cut.
    """
    import mitsuba as mi

    check_positions()
    sensor = scene.sensors()[0]
    width, height = (int(v) for v in sensor.film().crop_size())
    k, calls = copies_per_call(spp, width, height)
    batch = batch_sensor(sensor, k, width, height)
    seeds = pass_seeds(seed, calls, k * width, height, stream)
    sums, remaining = FilteredSums(rfilter, width, height), spp
    for i, call_seed in enumerate(seeds):
        image = mi.render(scene, sensor=batch, integrator=integrator, spp=1, seed=call_seed)
        values = np.array(image, dtype=np.float64)[..., :3].reshape(height, k, width, 3)
        x, y = (a.reshape(height, k, width) for a in batch_positions(call_seed, k, width, height))
        take = min(k, remaining)
        sums.add(values[:, :take], x[:, :take], y[:, :take])
        remaining -= take
        if log and (i + 1) % max(1, calls // 8) == 0:
            log(f"  {spp - remaining}/{spp} spp")
    m1, m2 = sums.moments()
    return m1, m2, spp, calls, k, seeds
