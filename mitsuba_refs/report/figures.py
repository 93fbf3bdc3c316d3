"""The pictures of the HTML report, each a PNG as a ``data:`` URI (nothing to fetch).

The test and reference images share one exposure, chosen from the reference (its 99th
percentile luminance maps to white), so that a brightness difference shows. The maps use
diverging colour maps with symmetric ranges (red: test brighter or noisier; blue: darker
or smoother). Drawn with matplotlib's object API (no pyplot state), imported only to draw.
"""
from __future__ import annotations

import base64
import io
import math

import numpy as np

from pathtracer.core.color import LUMINANCE
from pathtracer.core.tonemap import to_8bit, tonemap

__all__ = ["reference_exposure", "image_uri", "zmap_uri", "relative_difference_uri",
           "variance_ratio_uri", "convergence_uri"]

#: |z| at which the tile z-map saturates (the diagnostics' Z_CLIP).
Z_LIMIT = 10.0
#: The relative difference map saturates at +-this (per pixel, so noisy).
RELATIVE_LIMIT = 0.5
#: Colour map of every signed map.
DIVERGING = "RdBu_r"


def _luminance(rgb: np.ndarray) -> np.ndarray:
    rgb = np.asarray(rgb, dtype=np.float64)
    return rgb @ LUMINANCE if rgb.ndim == 3 and rgb.shape[2] == 3 else rgb.reshape(rgb.shape[:2])


def reference_exposure(reference_mean) -> float:
    """The scale that maps the 99th percentile of the reference's finite, positive luminance
    to white (1 when it has none)."""
    y = _luminance(reference_mean)
    y = y[np.isfinite(y) & (y > 0)]
    q = float(np.percentile(y, 99)) if y.size else 0.0
    return 1.0 / q if q > 0 else 1.0


def _figure(width: float = 3.5, height: float = 3.1, colorbar: bool = True):
    """A figure with fixed margins for a two-line title, axis labels and, on the right, a
    colour bar with its label (a layout engine would take twice as long to draw)."""
    from matplotlib.figure import Figure  # matplotlib: heavy, imported only to draw
    figure = Figure(figsize=(width, height), dpi=100)
    figure.subplots_adjust(left=0.15, right=0.86 if colorbar else 0.97, bottom=0.14, top=0.85)
    return figure


def _whole_ticks(axes) -> None:
    """Ticks at whole numbers only: tiles are counted (no "tile row 0.5")."""
    from matplotlib.ticker import MaxNLocator  # matplotlib: heavy, imported only to draw
    axes.xaxis.set_major_locator(MaxNLocator(integer=True))
    axes.yaxis.set_major_locator(MaxNLocator(integer=True))


def _uri(png: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def _figure_uri(figure) -> str:
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png")
    return _uri(buffer.getvalue())


def image_uri(rgb, scale: float) -> str:
    """A linear (H, W, 3) image tonemapped to sRGB with ``scale``, as a PNG at its own size."""
    from matplotlib.image import imsave  # matplotlib: heavy, imported only to draw
    buffer = io.BytesIO()
    imsave(buffer, to_8bit(tonemap(rgb, scale)), format="png")
    return _uri(buffer.getvalue())


def _largest_channel(z: np.ndarray) -> np.ndarray:
    """Per tile, the signed z of the channel with the largest |z| (NaN as 0, clipped)."""
    z = np.nan_to_num(np.asarray(z, dtype=np.float64), nan=0.0, posinf=Z_LIMIT, neginf=-Z_LIMIT)
    if z.ndim == 2:
        z = z[..., None]
    index = np.argmax(np.abs(z), axis=2)[..., None]
    return np.clip(np.take_along_axis(z, index, axis=2)[..., 0], -Z_LIMIT, Z_LIMIT)


def zmap_uri(z_tiles, significant_cells, tile: int, critical_z) -> str:
    """The signed tile z-map (largest-|z| channel), symmetric range +-:data:`Z_LIMIT`, the
    significant tiles (``(row, col)`` pairs) outlined."""
    from matplotlib.patches import Rectangle  # matplotlib: heavy, imported only to draw
    z = _largest_channel(z_tiles)
    figure = _figure()
    axes = figure.subplots()
    shown = axes.imshow(z, cmap=DIVERGING, vmin=-Z_LIMIT, vmax=Z_LIMIT, interpolation="nearest")
    for row, col in sorted(set(significant_cells)):
        axes.add_patch(Rectangle((col - 0.5, row - 0.5), 1, 1, fill=False, edgecolor="black", lw=1.8))
    outlined = (f"outlined: |z| > {critical_z:.2f} ({len(set(significant_cells))} tiles)"
                if critical_z is not None and math.isfinite(critical_z) else "no tile over the critical |z|")
    axes.set_title(f"tile z = (test − ref)/se, {tile}px tiles\n{outlined}", fontsize=8)
    axes.set_xlabel("tile column", fontsize=8)
    axes.set_ylabel("tile row", fontsize=8)
    _whole_ticks(axes)
    axes.tick_params(labelsize=7)
    figure.colorbar(shown, ax=axes, shrink=0.85).set_label(f"z (clipped ±{Z_LIMIT:g})", fontsize=8)
    return _figure_uri(figure)


def relative_difference_uri(test_mean, reference_mean) -> str:
    """Per-pixel luminance test/reference − 1, clipped to +-:data:`RELATIVE_LIMIT`."""
    test, reference = _luminance(test_mean), _luminance(reference_mean)
    with np.errstate(divide="ignore", invalid="ignore"):
        relative = np.where(reference > 0, test / reference - 1.0, np.where(test == reference, 0.0, np.nan))
    figure = _figure()
    axes = figure.subplots()
    shown = axes.imshow(100 * np.clip(relative, -RELATIVE_LIMIT, RELATIVE_LIMIT), cmap=DIVERGING,
                        vmin=-100 * RELATIVE_LIMIT, vmax=100 * RELATIVE_LIMIT, interpolation="nearest")
    axes.set_title("relative difference (luminance)\ntest / reference − 1, per pixel", fontsize=8)
    axes.set_xlabel("x [px]", fontsize=8)
    axes.set_ylabel("y [px]", fontsize=8)
    axes.tick_params(labelsize=7)
    figure.colorbar(shown, ax=axes, shrink=0.85).set_label(f"% (clipped ±{100 * RELATIVE_LIMIT:g})",
                                                           fontsize=8)
    return _figure_uri(figure)


def variance_ratio_uri(tile_log_ratio, tile: int) -> str:
    """Per-tile log2(variance test / variance reference), symmetric range of at least +-1."""
    ratio = np.asarray(tile_log_ratio, dtype=np.float64) / math.log(2.0)
    finite = ratio[np.isfinite(ratio)]
    limit = min(max(1.0, float(np.max(np.abs(finite))) if finite.size else 1.0), 4.0)
    figure = _figure()
    axes = figure.subplots()
    shown = axes.imshow(np.clip(ratio, -limit, limit), cmap=DIVERGING, vmin=-limit, vmax=limit,
                        interpolation="nearest")
    axes.set_title(f"variance ratio per {tile}px tile\nlog2(test / reference)", fontsize=8)
    axes.set_xlabel("tile column", fontsize=8)
    axes.set_ylabel("tile row", fontsize=8)
    _whole_ticks(axes)
    axes.tick_params(labelsize=7)
    figure.colorbar(shown, ax=axes, shrink=0.85).set_label("log2 ratio (1 = 2x)", fontsize=8)
    return _figure_uri(figure)


def convergence_uri(ladder, mse_mean, mse_se, slope: float, slope_ci) -> str:
    """MSE against the reference vs spp, log-log: each level's mean MSE with +-2 standard
    errors, the expected slope −1 and the fitted slope, both through the levels' geometric
    centre."""
    spp = np.asarray(ladder, dtype=np.float64)
    mean = np.asarray(mse_mean, dtype=np.float64)
    error = 2 * np.nan_to_num(np.asarray(mse_se, dtype=np.float64), nan=0.0)
    if error.shape != mean.shape:        # no standard errors: no bars
        error = np.zeros_like(mean)
    shown = np.isfinite(mean) & (mean > 0)
    figure = _figure(3.8, 3.1, colorbar=False)
    axes = figure.subplots()
    lower = np.minimum(error, 0.95 * mean)         # a bar below 0 cannot be drawn in log scale
    axes.errorbar(spp[shown], mean[shown], yerr=(lower[shown], error[shown]), fmt="o", color="C0",
                  capsize=3, label="mean MSE ± 2 se")
    if shown.sum() >= 1:
        centre_x = float(np.exp(np.mean(np.log(spp[shown]))))
        centre_y = float(np.exp(np.mean(np.log(mean[shown]))))
        grid = np.geomspace(spp.min(), spp.max(), 20)
        axes.plot(grid, centre_y * (grid / centre_x) ** -1.0, "k--", lw=1, label="slope −1 (expected)")
        if math.isfinite(slope):
            low_ci, high_ci = slope_ci
            axes.plot(grid, centre_y * (grid / centre_x) ** slope, color="C3", lw=1.2,
                      label=f"fit {slope:.2f} [{low_ci:.2f}, {high_ci:.2f}]")
    axes.set_xscale("log")
    axes.set_yscale("log")
    axes.set_xlabel("samples per pixel", fontsize=8)
    axes.set_ylabel("MSE vs reference", fontsize=8)
    axes.tick_params(labelsize=7)
    axes.grid(True, which="both", alpha=0.3)
    axes.legend(fontsize=7)
    axes.set_title("convergence: MSE ∝ N^−1", fontsize=8)
    return _figure_uri(figure)
