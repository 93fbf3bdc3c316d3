"""Small shared helpers: tiling, Šidák adjustment, region names.  Pure functions, no I/O."""
from __future__ import annotations

import math

import numpy as np

__all__ = [
    "tile_sums",
    "tile_counts",
    "sidak",
    "sidak_per_test",
    "as_image",
    "as_count",
    "noiseless_pixels",
    "REL_NOISE_FLOOR",
]

#: Per-sample variance, relative to the squared mean, below which a pixel counts as noiseless
#: (float32 moment rounding: :mod:`mitsuba_refs.stats.variance`, "Noiseless pixels").
REL_NOISE_FLOOR = 1e-6


def as_image(x, name: str) -> np.ndarray:
    """Return ``x`` as a float64 array of shape (H, W, C); a (H, W) array gets C=1."""
    a = np.asarray(x, dtype=np.float64)
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3:
        raise ValueError(f"{name} must have shape (H, W) or (H, W, C), got {a.shape}")
    return a


def as_count(n, shape: tuple[int, int], name: str) -> np.ndarray:
    """Sample counts as a float64 (H, W) array (a scalar is broadcast).  Requires n >= 2."""
    a = np.asarray(n, dtype=np.float64)
    if a.ndim == 3:
        if a.shape[2] != 1 and not np.all(a == a[:, :, :1]):
            raise ValueError(f"{name}: per-channel sample counts must be equal across channels")
        a = a[:, :, 0]
    a = np.broadcast_to(a, shape).astype(np.float64)
    if not np.all(np.isfinite(a)) or np.any(a < 2):
        raise ValueError(f"{name}: sample counts must be finite and >= 2 (a variance needs 2 samples)")
    return a


def tile_sums(x: np.ndarray, tile: int) -> np.ndarray:
    """Sum ``x`` (H, W, ...) over non-overlapping ``tile`` x ``tile`` blocks.

    Edge tiles are partial when H or W is not a multiple of ``tile`` (zero padding,
    so the sum is over the pixels that exist; see :func:`tile_counts`).
    Returns shape (ceil(H/tile), ceil(W/tile), ...).
    """
    h, w = x.shape[:2]
    th, tw = -(-h // tile), -(-w // tile)
    ph, pw = th * tile - h, tw * tile - w
    if ph or pw:
        pad = [(0, ph), (0, pw)] + [(0, 0)] * (x.ndim - 2)
        x = np.pad(x, pad)
    x = x.reshape((th, tile, tw, tile) + x.shape[2:])
    return x.sum(axis=(1, 3))


def tile_counts(h: int, w: int, tile: int) -> np.ndarray:
    """Number of pixels in each tile, shape (ceil(H/tile), ceil(W/tile))."""
    return tile_sums(np.ones((h, w)), tile)


def sidak(p_min, m):
    """Šidák family p-value of the smallest of ``m`` independent p-values: 1-(1-p_min)^m."""
    p_min = np.asarray(p_min, dtype=np.float64)
    m = np.asarray(m, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = -np.expm1(m * np.log1p(-np.clip(p_min, 0.0, 1.0)))
    out = np.where(m <= 0, 1.0, out)
    out = np.where(p_min >= 1.0, 1.0, out)
    return float(out) if out.ndim == 0 else out


def sidak_per_test(alpha: float, m: int) -> float:
    """Per-test level giving family level ``alpha`` over ``m`` independent tests: 1-(1-alpha)^(1/m)."""
    if m <= 0:
        return float(alpha)
    return float(-math.expm1(math.log1p(-alpha) / m))


def _magnitude(mean) -> np.ndarray:
    """Per-pixel Euclidean norm over channels of ``mean`` (H, W, C), without overflow."""
    m = np.abs(as_image(mean, "mean"))
    largest = m.max(axis=2)
    with np.errstate(divide="ignore", invalid="ignore"):
        relative = np.where(largest[..., None] > 0, m / largest[..., None], 0.0)
    return largest * np.sqrt((relative * relative).sum(axis=2))


def noiseless_pixels(var_a, var_b, mean_a, mean_b, *, rel_floor: float = REL_NOISE_FLOOR,
                     scale: float = 1.0) -> np.ndarray:
    """Pixels (H, W) that carry no noise on either side: the channel-summed per-sample
    variances ``var_a``, ``var_b`` (H, W; divided by ``scale``) are both below ``rel_floor``
    times the larger channel-summed squared mean of ``mean_a``, ``mean_b`` (H, W, C)."""
    size_a, size_b = _magnitude(mean_a), _magnitude(mean_b)
    if not size_a.shape == size_b.shape == np.shape(var_a):
        raise ValueError(f"means of shape {size_a.shape} / {size_b.shape} for variances of "
                         f"{np.shape(var_a)}")
    size = np.maximum(size_a, size_b)
    deviation = np.sqrt(np.maximum(var_a, var_b)) * math.sqrt(scale)
    return deviation < math.sqrt(rel_floor) * size
