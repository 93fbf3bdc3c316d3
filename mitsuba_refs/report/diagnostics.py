"""Diagnostic PNGs for the statistical comparisons (matplotlib, Agg backend).

Each function writes one figure a person reads at a glance; the statistics themselves live
in :mod:`mitsuba_refs.stats` (pure functions).  All functions return the written path.
"""
from __future__ import annotations

import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import TwoSlopeNorm
from matplotlib.ticker import MaxNLocator

from pathtracer.core.color import LUMINANCE
from pathtracer.core.tonemap import auto_scale, tonemap

from ..stats.convergence import mse_levels
from .results import default_stem
from .wording import convergence_verdict, mean_verdict, variance_verdict

__all__ = ["plot_mean_comparison", "plot_convergence", "plot_variance_comparison", "write_pictures"]

Z_CLIP = 10.0


def _save(fig, path) -> str:
    path = os.fspath(path)
    d = os.path.dirname(path)
    if d:
        os.makedirs(d, exist_ok=True)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def _tile_grid(ax, tile, h, w):
    for y in range(tile, h, tile):
        ax.axhline(y - 0.5, color="k", lw=0.2, alpha=0.3)
    for x in range(tile, w, tile):
        ax.axvline(x - 0.5, color="k", lw=0.2, alpha=0.3)


def plot_mean_comparison(path, mean_test, mean_ref, agreement, title: str = "") -> str:
    """Four panels: test and reference (same exposure), signed tile z-map of the channel with
    the largest |z| per tile (diverging, symmetric, clipped at ±10), and the relative
    difference (test/ref - 1, luminance, clipped at ±50 %).  The verdict is the subtitle."""
    t = np.asarray(mean_test, dtype=np.float64)
    r = np.asarray(mean_ref, dtype=np.float64)
    if t.ndim == 2:
        t, r = t[..., None].repeat(3, 2), r[..., None].repeat(3, 2)
    h, w = t.shape[:2]
    exp = auto_scale(r)
    fig, axes = plt.subplots(1, 4, figsize=(19, 4.6))
    fig.subplots_adjust(wspace=0.45)
    axes[0].imshow(tonemap(t, exp), interpolation="nearest")
    axes[0].set_title("test (tonemapped)")
    axes[1].imshow(tonemap(r, exp), interpolation="nearest")
    axes[1].set_title("reference (same exposure)")

    z = np.asarray(agreement.z_tiles, dtype=np.float64)
    idx = np.argmax(np.abs(np.nan_to_num(z, posinf=1e9, neginf=-1e9)), axis=2)
    zz = np.take_along_axis(z, idx[..., None], axis=2)[..., 0]
    zz = np.clip(np.nan_to_num(zz, posinf=Z_CLIP, neginf=-Z_CLIP), -Z_CLIP, Z_CLIP)
    tile = agreement.tile
    im = axes[2].imshow(zz, cmap="RdBu_r", vmin=-Z_CLIP, vmax=Z_CLIP, interpolation="nearest",
                        extent=(-0.5, zz.shape[1] * tile - 0.5, zz.shape[0] * tile - 0.5, -0.5))
    axes[2].set_xlim(-0.5, w - 0.5)
    axes[2].set_ylim(h - 0.5, -0.5)
    axes[2].set_title(f"tile z (test − ref)/se, {tile}px tiles\nred: test brighter, blue: darker")
    cb = fig.colorbar(im, ax=axes[2], fraction=0.046, pad=0.04)
    cb.set_label("z (clipped ±10)")

    lum = LUMINANCE if t.shape[2] == 3 else np.full(t.shape[2], 1 / t.shape[2])
    yt, yr = t @ lum, r @ lum
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(yr > 0, yt / yr - 1.0, np.where(yt == yr, 0.0, np.nan))
    im2 = axes[3].imshow(np.clip(rel, -0.5, 0.5) * 100, cmap="PuOr_r", norm=TwoSlopeNorm(0, -50, 50),
                         interpolation="nearest")
    axes[3].set_title("relative difference, luminance\n(test/ref − 1, per pixel, noisy)")
    cb2 = fig.colorbar(im2, ax=axes[3], fraction=0.046, pad=0.04)
    cb2.set_label("%")
    for ax in axes:
        ax.set_xlabel("x [px]")
        ax.set_ylabel("y [px]")
    _tile_grid(axes[2], tile, h, w)
    fig.suptitle(f"{title}\n{mean_verdict(agreement)}", fontsize=10)
    return _save(fig, path)


def plot_convergence(path, spp, mse, result, title: str = "") -> str:
    """RMSE vs spp, log-log: replica min-max band, replica mean with ±1 se bars, the fitted
    law with slope and CI, and an N^-1/2 guide through the first level.  ``mse`` is a
    (K, L) table or one array per level.  Non-positive MSEs (possible after the
    reference-noise subtraction) are not drawn."""
    N = np.asarray(spp, dtype=np.float64)
    levels, _ = mse_levels(mse, N.size)
    sizes = np.array([level.size for level in levels])
    ybar = np.array([level.mean() for level in levels])
    low = np.array([level.min() for level in levels])
    high = np.array([level.max() for level in levels])
    with np.errstate(invalid="ignore", divide="ignore"):
        rm = np.sqrt(np.where(ybar > 0, ybar, np.nan))
        rlo = np.sqrt(np.where(low > 0, low, np.nan))
        rhi = np.sqrt(np.where(high > 0, high, np.nan))
        se = np.array([level.std(ddof=1) if level.size > 1 else 0.0 for level in levels]) / np.sqrt(sizes)
        err = 0.5 * se / np.where(ybar > 0, np.sqrt(ybar), np.nan)        # d sqrt(y) = dy / (2 sqrt y)
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    ax.fill_between(N, rlo, rhi, color="C0", alpha=0.2, label=band_label(N, sizes))
    ax.errorbar(N, rm, yerr=err, fmt="o", color="C0", label="RMSE (from the renders' mean MSE) ± se")
    ok = np.isfinite(rm)
    if ok.any():
        x0, y0 = N[ok][0], rm[ok][0]
        Ng = np.geomspace(N.min(), N.max(), 50)
        ax.plot(Ng, y0 * (Ng / x0) ** -0.5, "k--", lw=1, label="N^-1/2 (independent samples)")
        lx = np.log(N[ok])
        b = result.slope / 2
        a = np.mean(np.log(rm[ok]) - b * lx)
        ax.plot(Ng, np.exp(a) * Ng ** b, color="C3", label=fit_label(result))
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("samples per pixel N")
    ax.set_ylabel("RMSE vs reference (radiance units)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(f"{title}\n{convergence_verdict(result)}", fontsize=8, wrap=True)
    return _save(fig, path)


def band_label(spp, renders) -> str:
    """The legend of the convergence plot's band: how many renders give each level's range."""
    if np.all(renders == renders[0]):
        return f"range over {renders[0]} renders per N"
    return (f"range over the renders ({renders[0]} at N={spp[0]:g} to {renders[-1]} "
            f"at N={spp[-1]:g})")


def fit_label(result) -> str:
    """The legend of the fitted law, in the plot's own quantity: the RMSE's exponent, half the
    MSE's slope that the test fits."""
    low, high = (s / 2 for s in result.slope_ci)
    return f"fit: RMSE ∝ N^{result.slope / 2:.3f} [{low:.3f}, {high:.3f}]"


def plot_variance_comparison(path, var_test, var_ref, agreement, title: str = "") -> str:
    """Three panels: per-sample standard deviation of test and reference (channel sum, same
    log colour scale), and the per-tile log2 variance ratio (diverging, symmetric)."""
    vt = np.asarray(var_test, dtype=np.float64)
    vr = np.asarray(var_ref, dtype=np.float64)
    if vt.ndim == 3:
        vt, vr = vt.sum(axis=2), vr.sum(axis=2)
    st, sr = np.sqrt(np.maximum(vt, 0)), np.sqrt(np.maximum(vr, 0))
    pos = np.concatenate([st[st > 0], sr[sr > 0]])
    lo, hi = (np.percentile(pos, 1), np.percentile(pos, 99.5)) if pos.size else (1e-3, 1.0)
    from matplotlib.colors import LogNorm  # matplotlib: heavy, imported only to draw
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    fig.subplots_adjust(wspace=0.5)     # room for each colour bar's label before the next panel
    norm = LogNorm(vmin=max(lo, 1e-12), vmax=max(hi, lo * 10, 1e-11))
    for ax, img, name in ((axes[0], st, "test"), (axes[1], sr, "reference")):
        im = ax.imshow(np.where(img > 0, img, np.nan), norm=norm, cmap="magma", interpolation="nearest")
        ax.set_title(f"{name}: per-sample std. dev. (RGB sum)")
        fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04).set_label("radiance")
    lr = np.asarray(agreement.tile_log_ratio, dtype=np.float64) / np.log(2)
    lim = max(1.0, float(np.nanmax(np.abs(lr))) if np.isfinite(lr).any() else 1.0)
    lim = min(lim, 4.0)
    im = axes[2].imshow(np.clip(lr, -lim, lim), cmap="RdBu_r", vmin=-lim, vmax=lim, interpolation="nearest")
    axes[2].set_title(f"per-tile log2(var test / var ref), {agreement.tile}px tiles")
    fig.colorbar(im, ax=axes[2], fraction=0.046, pad=0.04).set_label("log2 ratio (1 = 2x)")
    for ax in axes[:2]:
        ax.set_xlabel("x [px]")
        ax.set_ylabel("y [px]")
    for axis in (axes[2].xaxis, axes[2].yaxis):
        axis.set_major_locator(MaxNLocator(integer=True))     # tiles are counted, not measured
    axes[2].set_xlabel("tile column")
    axes[2].set_ylabel("tile row")
    fig.suptitle(f"{title}\n{variance_verdict(agreement)}", fontsize=10)
    return _save(fig, path)


def write_pictures(result, out_dir: Path, mean, variance, reference) -> dict:
    """Diagnostic PNGs of a :class:`~mitsuba_refs.verdicts.compare.Comparison` for its verdicts
    (mean always, variance and convergence where they ran); {name: path}."""
    out_dir.mkdir(parents=True, exist_ok=True)
    stem = default_stem(result)
    title = f"{result.integrator} vs Mitsuba on {result.scene}"
    pictures = {"mean": plot_mean_comparison(out_dir / f"{stem}-mean.png", mean, reference.mean,
                                             result.mean, title)}
    if result.variance is not None:
        pictures["variance"] = plot_variance_comparison(out_dir / f"{stem}-variance.png", variance,
                                                        reference.var, result.variance, title)
    if result.convergence is not None:
        pictures["convergence"] = plot_convergence(out_dir / f"{stem}-convergence.png",
                                                   np.array(result.ladder), result.convergence_mse,
                                                   result.convergence, title)
    return {k: str(v) for k, v in pictures.items()}
