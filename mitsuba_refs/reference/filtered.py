r"""Filtered (tent, gaussian) references in ``scalar_rgb``: single samples at known positions.

Mitsuba's scalar film weights samples with a 31-entry table of the filter
(:mod:`mitsuba_refs.reference.rfilter`); the references need the exact weights, which the tracer and
Mitsuba's vectorised variants use. So the samples are rendered as for a box film
(:mod:`mitsuba_refs.reference.batch`: ``k`` copies of the camera side by side, one sample per pixel,
the C++ estimator alone), the film position of each is computed exactly as Mitsuba drew it
(:mod:`mitsuba_refs.reference.positions`), and NumPy splats them with the tracer's filter weights
(:meth:`pathtracer.sensors.film.ReconstructionFilter.eval`). Per pixel ``p`` this accumulates over all
``n`` samples of the whole film

.. math::

    W_p = \sum_i w_i(p), \qquad m_{1,p} = \frac{\sum_i w_i(p) f_i}{W_p}, \qquad
    m_{2,p} = \frac{\sum_i w_i(p) f_i^2}{W_p},

``w_i(p) = w(c_p - x_i)`` the separable filter weight, weights outside the image dropped:
exactly what Mitsuba's ``hdrfilm`` holds with the ``rgb_moments`` AOVs in ``llvm_ad_rgb``,
so :func:`mitsuba_refs.reference.rfilter.per_sample_variance` turns them into the same per-sample
variance ``(m_2 - m_1^2) n_eff / (n_eff - 1)``. The samples have the distribution of the
filtered film's: ``n`` per pixel, uniform in it (no sample border).

A sample is grouped with the pixel the box film stored it in; the rare one whose traced
position lies outside that pixel (float32 rounding of ``pixel + u`` up to the pixel's right
edge, or of the batch sensor's copy index across a copy boundary) is moved to where it was
traced (:meth:`FilteredSums.add`).
"""

import numpy as np

from .batch import batch_sensor, copies_per_call
from .positions import BLOCK_SIZE, batch_positions, check_positions
from .seeds import pass_seeds


class FilteredSums:
    """Running per-pixel ``sum w``, ``sum w f``, ``sum w f^2`` (float64) of one film.

    The sums are kept on the film padded by the filter's reach on every side, so that a
    sample's weights on pixels outside the image land in the padding and are dropped
    (:meth:`moments` crops it), as Mitsuba's film drops them.
    """

    def __init__(self, rfilter, width, height):
        self.rfilter, self.width, self.height = rfilter, width, height
        self.reach = rfilter.reach
        pad = 2 * self.reach
        # channels: w, w f (R, G, B), w f^2 (R, G, B)
        self.sums = np.zeros((height + pad, width + pad, 7))

    def _weights(self, u):
        """Per-axis weights (..., K) of samples at offsets ``u`` in their pixels for the
        pixel offsets ``-reach..reach``, from the tracer's filter (:meth:`eval`)."""
        offsets = np.arange(-self.reach, self.reach + 1, dtype=np.float64)
        return self.rfilter.eval(offsets + 0.5 - u[..., None])

    @staticmethod
    def _terms(values):
        """``(1, f, f^2)`` per sample: (..., 7)."""
        ones = np.ones(values.shape[:-1] + (1,))
        return np.concatenate([ones, values, values * values], axis=-1)

    def add(self, values, x, y):
        """Add samples ``values`` (H, S, W, 3) traced at film positions ``x``, ``y`` (H, S, W):
        ``S`` samples of every pixel, each stored in the pixel of its row and column."""
        height, samples, width = x.shape
        u = np.stack([x - np.arange(width)[None, None, :],
                      y - np.arange(height)[:, None, None]], axis=-1)       # (H, S, W, 2)
        clipped = np.clip(u, 0.0, 1.0)
        # per pixel and pixel offset (oy, ox): sum over its samples of wy wx (1, f, f^2)
        wx = self._weights(clipped[..., 0]).transpose(0, 2, 1, 3)          # (H, W, S, K)
        wy = self._weights(clipped[..., 1]).transpose(0, 2, 3, 1)          # (H, W, K, S)
        terms = self._terms(values).transpose(0, 2, 1, 3)                   # (H, W, S, 7)
        k = 2 * self.reach + 1
        for c in range(terms.shape[-1]):
            block = (wy * terms[:, :, None, :, c]) @ wx                    # (H, W, K, K)
            for oy in range(k):
                for ox in range(k):
                    self.sums[oy:oy + height, ox:ox + width, c] += block[:, :, oy, ox]
        moved = np.nonzero(np.any(u != clipped, axis=-1))
        if moved[0].size:
            rows, cols = moved[0], moved[2]
            self._scatter(-1.0, rows, cols, clipped[moved], values[moved])
            self._move(values[moved], x[moved], y[moved])

    def _move(self, values, x, y):
        """Splat samples where they were traced, ``(x, y)`` (pixels), after :meth:`add` has
        taken them out of the pixel the box film stored them in."""
        cols = np.clip(np.floor(x).astype(np.int64), 0, self.width - 1)
        rows = np.clip(np.floor(y).astype(np.int64), 0, self.height - 1)
        self._scatter(1.0, rows, cols, np.stack([x - cols, y - rows], axis=-1), values)

    def _scatter(self, sign, rows, cols, u, values):
        """Add ``sign`` times the weighted terms of single samples in pixels ``(rows,
        cols)`` at offsets ``u`` (M, 2) (repeated pixels allowed)."""
        k = 2 * self.reach + 1
        wx, wy = self._weights(u[:, 0]), self._weights(u[:, 1])            # (M, K)
        weights = wy[:, :, None] * wx[:, None, :]                           # (M, K, K)
        terms = sign * weights[..., None] * self._terms(values)[:, None, None, :]
        target_rows = rows[:, None, None] + np.arange(k)[None, :, None]     # padded rows
        target_cols = cols[:, None, None] + np.arange(k)[None, None, :]
        np.add.at(self.sums, (np.broadcast_to(target_rows, weights.shape),
                              np.broadcast_to(target_cols, weights.shape)), terms)

    def moments(self):
        """``(m1, m2)``: (H, W, 3) weighted first and second moments."""
        r = self.reach
        inner = self.sums[r:r + self.height, r:r + self.width]
        w = inner[..., :1]
        return inner[..., 1:4] / w, inner[..., 4:7] / w


def integrator_with_blocks(nested):
    """The integrator dictionary with Mitsuba's block size fixed (:data:`BLOCK_SIZE`),
    which the sample positions depend on."""
    return dict(nested, block_size=BLOCK_SIZE)


def render_filtered_moments(scene, integrator, spp, seed, stream, rfilter, progress=None):
    """Render ``spp`` single samples per pixel and reconstruct them with ``rfilter``.

    Parameters
    ----------
    scene : mitsuba.Scene
    integrator : mitsuba.Integrator
        The estimator, loaded from :func:`integrator_with_blocks`'s dictionary.
    spp, seed, stream : int
        As for :func:`mitsuba_refs.reference.batch.render_moments`.
    rfilter : pathtracer.sensors.film.ReconstructionFilter
    progress : pathtracer.core.progress.Progress, optional

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
        if progress:
            progress.advance(take)
    m1, m2 = sums.moments()
    return m1, m2, spp, calls, k, seeds
