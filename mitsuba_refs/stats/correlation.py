r"""How a film's reconstruction filter correlates pixels, in the terms the tile tests need.

With a box filter every sample lands in one pixel and pixels are independent. A tent or
gaussian filter spreads each sample over neighbouring pixels, so neighbours share samples.
For a pixel sum weighted by a separable filter ``w`` and uniformly spread samples of locally
constant variance, two pixels at lag ``(a, b)`` are correlated by ``rho(a) rho(b)`` with
``rho(l) = ∫ w(x) w(x + l) dx / ∫ w^2`` (:func:`pathtracer.sensors.film.lag_correlations`). A tile
statistic built from pixel sums then has, for a ``T x T`` tile (``n_l = max(T - |l|, 0)``
pairs of pixels at lag ``l`` along an axis):

* design effect ``k_T = (sum_l rho(l) n_l / T)^2``: ``Var(sum over the tile) / sum of the
  pixel variances``; the tile holds ``T^2 / k_T`` effectively independent pixels;
* share ``s_T = k_T / (sum_l rho(l))^2``: the part of the pixels' covariance row sums
  that stays inside the tile (the per-sample variance of a filtered pixel, divided by n, is
  its covariance row sum: docs/statistics.md, "Reconstruction filters");
* neighbour correlation ``c_T = sum_{l>0} rho(l) min(l, 2T - l) / sum_l rho(l) n_l`` between
  the sums of two side-by-side tiles (``c_T^2`` diagonally), so the mean of a statistic
  over many tiles has ``(1 + 2 c_T)^2`` times the variance its tile-to-tile spread shows.

The box filter gives ``rho = [1]``: ``k = s = 1``, ``c = 0``, and every test is unchanged.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pathtracer.sensors.film import lag_correlations


@dataclass(frozen=True)
class PixelCorrelation:
    """The lag correlations ``rho`` of one axis, lags ``-L..L`` (odd length, ``rho[L] = 1``)."""

    rho: tuple = (1.0,)

    def _pairs(self, tile: int):
        rho = np.asarray(self.rho, dtype=np.float64)
        lags = np.arange(len(rho)) - len(rho) // 2
        return rho, lags, np.maximum(tile - np.abs(lags), 0)

    @property
    def independent(self) -> bool:
        """True when pixels are independent (box filter)."""
        return len(self.rho) == 1

    def design_effect(self, tile: int) -> float:
        """``k_T``: variance of a tile's pixel sum over the sum of its pixel variances."""
        rho, _, pairs = self._pairs(tile)
        return float(np.sum(rho * pairs) / tile) ** 2

    def within_tile_share(self, tile: int) -> float:
        """``s_T``: fraction of the pixels' covariance row sums that falls inside the tile."""
        rho, _, _ = self._pairs(tile)
        return self.design_effect(tile) / float(np.sum(rho)) ** 2

    def neighbour_correlation(self, tile: int) -> float:
        """``c_T``: correlation of the pixel sums of two side-by-side ``tile`` x ``tile`` tiles."""
        rho, lags, pairs = self._pairs(tile)
        across = np.where(lags > 0, np.maximum(np.minimum(lags, 2 * tile - lags), 0), 0)
        return float(np.sum(rho * across) / np.sum(rho * pairs))


INDEPENDENT = PixelCorrelation()


def pixel_correlation(rfilter) -> PixelCorrelation:
    """The :class:`PixelCorrelation` of a :class:`pathtracer.sensors.film.ReconstructionFilter`."""
    if rfilter is None or rfilter.is_box:
        return INDEPENDENT
    return PixelCorrelation(tuple(float(r) for r in lag_correlations(rfilter)))
