"""Mitsuba's ``hdrfilm`` and its reconstruction filters: ``box``, ``tent`` and ``gaussian``.

A camera sample at film position ``(x, y)`` (pixels; pixel ``(i, j)`` spans
``[i, i + 1) x [j, j + 1)`` and has its centre at ``(i + 0.5, j + 0.5)``) adds
``w(i + 0.5 - x) * w(j + 0.5 - y)`` times its value to every pixel whose centre lies
within the filter's radius along both axes, and the pixel's value is the weighted
sum divided by the sum of the weights. Samples are drawn uniformly inside their own
pixel; weights that would fall outside the image are dropped, so the edge pixels are
normalised by the weights they did receive.

With ``sample_border`` (Mitsuba's ``hdrfilm`` option), samples are also drawn in a border of
:attr:`ReconstructionFilter.border` pixels around the image (``ceil(radius - 0.5)``, the
filter's reach; none for the box), ``spp`` per border pixel as inside: the pixels of the
sample grid are ``(W + 2b) x (H + 2b)``, column ``-b`` first. Their weights that land inside
the image count, so the edge pixels get the filter's full support, as inside.

One-dimensional weights, as Mitsuba 3.9.1 evaluates them in its vectorised (LLVM)
variants, which render the references:

* ``tent``: ``max(0, 1 - |d| / radius)``, ``radius`` default 1;
* ``gaussian``: ``max(0, exp(-d^2 / (2 s^2)) - exp(-r^2 / (2 s^2)))`` with ``s`` =
  ``stddev`` (default 0.5) and ``r = 4 s``: a Gaussian shifted down to reach zero at
  its radius. (Mitsuba evaluates it by a polynomial fit of the exponential; it matches
  this formula to ~1e-7, ``tests/test_film.py``.)

Mitsuba's *scalar* variants instead read the weights from a table of 31 values
(``eval_discretized``: the weight at ``floor(31 |d| / r) r / 31``), a step function that
lies up to 1/31 of the peak above these weights; see docs/scene-format.md for how much
that moves pixel values.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..core.names import suggestion
from ..scene.properties import Props, children, registered
from ..scene.registry import factory, names, register
from ..scene.xml import Plugin

#: Filters the film accepts, with their parameter and its default.
FILTER_PARAMS = {"box": ("radius", 0.5), "tent": ("radius", 1.0), "gaussian": ("stddev", 0.5)}


@dataclass(frozen=True)
class ReconstructionFilter:
    """A separable reconstruction filter.

    Attributes
    ----------
    kind : {'box', 'tent', 'gaussian'}
    radius : float
        Support half-width in pixels (the box's is 0.5: a pixel is the plain mean of its
        samples; the gaussian's is 4 standard deviations).
    stddev : float
        The gaussian's standard deviation in pixels (unused by the others).
    """

    kind: str = "box"
    radius: float = 0.5
    stddev: float = 0.0
    #: The film's ``sample_border``: samples are drawn in :attr:`border` pixels around the image.
    sample_border: bool = False

    @classmethod
    def make(cls, kind: str, value: float | None = None,
             sample_border: bool = False) -> "ReconstructionFilter":
        """The filter ``kind`` with its parameter (``radius``, or ``stddev`` for the gaussian)
        and the film's ``sample_border``."""
        name, default = FILTER_PARAMS[kind]
        value = default if value is None else float(value)
        if kind == "gaussian":
            return cls("gaussian", 4.0 * value, value, sample_border)
        return cls(kind, value, 0.0, sample_border)

    @property
    def is_box(self) -> bool:
        """True for the 0.5-radius box: each sample counts in its own pixel with weight one."""
        return self.kind == "box" and self.radius == 0.5

    @property
    def reach(self) -> int:
        """Largest pixel offset a sample's weights can reach from its own pixel."""
        return max(0, math.ceil(self.radius + 0.5) - 1)

    @property
    def border(self) -> int:
        """Pixels of samples drawn beyond each edge of the image: the reach with
        ``sample_border`` (Mitsuba's ``border_size``, ``ceil(radius - 0.5)``), else 0."""
        return self.reach if self.sample_border else 0

    def describe(self) -> str:
        """``'gaussian (stddev 0.5)'``, ``'tent (radius 1)'``: for metadata and messages."""
        border = ", sample border" if self.border else ""
        if self.kind == "gaussian":
            return f"gaussian (stddev {self.stddev:g}{border})"
        return f"{self.kind} (radius {self.radius:g}{border})"

    def eval(self, d: np.ndarray) -> np.ndarray:
        """One-dimensional weight at signed distance ``d`` (pixels) from a pixel centre."""
        d = np.abs(np.asarray(d, dtype=np.float64))
        if self.kind == "tent":
            return np.maximum(0.0, 1.0 - d / self.radius)
        if self.kind == "gaussian":
            alpha = -0.5 / (self.stddev * self.stddev)
            return np.maximum(0.0, np.exp(alpha * d * d) - math.exp(alpha * self.radius ** 2))
        if self.kind == "box":
            return (d <= self.radius).astype(np.float64)
        raise ValueError(f"unknown reconstruction filter {self.kind!r}")


BOX = ReconstructionFilter()


def splat(rfilter: ReconstructionFilter, width: int, height: int, pixel: np.ndarray,
          u_film: np.ndarray, values: np.ndarray, lo: int = 0, hi: int | None = None):
    """Filter-weighted sums of samples over the pixels ``lo:hi`` (flat indices).

    Parameters
    ----------
    rfilter : ReconstructionFilter
    width, height : int
        Film size.
    pixel : (P,) int
        Distinct flat indices of the pixels the samples belong to, in the sample grid: row *
        width + column, or with a sample border ``b`` (:attr:`ReconstructionFilter.border`)
        ``(row + b) * (width + 2b) + column + b``.
    u_film : (P, S, 2) float
        Position of each sample inside its pixel, in [0, 1)^2.
    values : (P, S, C) float
        Sample values.
    lo, hi : int
        The flat pixel range to return (default: the whole film); every weight of the
        samples must fall inside it.

    Returns
    -------
    (weight, weighted, weighted_square) : ((hi-lo,), (hi-lo, C), (hi-lo, C)) float64
        Per pixel ``sum w``, ``sum w f`` and ``sum w f^2``, added offset by offset in a
        fixed order (deterministic).
    """
    hi = width * height if hi is None else hi
    size, channels = hi - lo, values.shape[2]
    b = rfilter.border
    col, row = pixel % (width + 2 * b) - b, pixel // (width + 2 * b) - b
    offsets = np.arange(-rfilter.reach, rfilter.reach + 1)
    # weights of every sample for every pixel offset along each axis: (P, K, S)
    wx = rfilter.eval(offsets[None, :, None] + 0.5 - u_film[:, None, :, 0])
    wy = rfilter.eval(offsets[None, :, None] + 0.5 - u_film[:, None, :, 1])
    wx_t = wx.transpose(0, 2, 1)
    # per source pixel and offset (oy, ox): sum over its samples of wy * wx * (1, f, f^2)
    per_offset = [wy @ wx_t]
    for c in range(channels):
        f = values[:, None, :, c]
        per_offset += [(wy * f) @ wx_t, (wy * (f * f)) @ wx_t]
    w_sum, wf, wf2 = np.zeros(size), np.zeros((size, channels)), np.zeros((size, channels))
    for iy, oy in enumerate(offsets):
        rows = row + oy
        for ix, ox in enumerate(offsets):
            cols = col + ox
            inside = (rows >= 0) & (rows < height) & (cols >= 0) & (cols < width)
            target = rows[inside] * width + cols[inside] - lo
            if target.size and (target.min() < 0 or target.max() >= size):
                raise ValueError("splat: a sample's weights fall outside the requested pixels")
            # one source pixel per target at a given offset: no repeated indices
            w_sum[target] += per_offset[0][inside, iy, ix]
            for c in range(channels):
                wf[target, c] += per_offset[1 + 2 * c][inside, iy, ix]
                wf2[target, c] += per_offset[2 + 2 * c][inside, iy, ix]
    return w_sum, wf, wf2


def _axis_integrals(rfilter: ReconstructionFilter, size: int, power: int, steps: int = 512):
    """``∫ w(c_i - x)^power dx`` over the film ``[0, size)`` for every pixel centre ``c_i``.

    Midpoint rule with ``steps`` points per pixel (the weights are smooth within a pixel
    except at the tent's kinks, which the fine grid resolves to ~1e-6). With a sample border
    the film is ``[-b, size + b)``.
    """
    k = rfilter.reach
    u = (np.arange(steps) + 0.5) / steps
    d = np.concatenate([o + 0.5 - u for o in range(-k, k + 1)])          # centre minus x
    w = rfilter.eval(d) ** power / steps
    per_offset = w.reshape(2 * k + 1, steps).sum(axis=1)                   # offset o = i - column
    out = np.zeros(size)
    b = rfilter.border
    for o, value in zip(range(-k, k + 1), per_offset):
        # pixel i receives from the samples of column i - o, which must lie in [-b, size + b)
        lo, hi = max(0, o - b), min(size, size + o + b)
        out[lo:hi] += value
    return out


def effective_counts(rfilter: ReconstructionFilter, width: int, height: int,
                     spp: int) -> np.ndarray:
    """Kish's effective number of samples of each pixel, ``(E sum w)^2 / E sum w^2``, (H, W).

    ``spp`` for the box filter. It turns the weighted spread of a pixel's samples,
    ``sum w (f - mean)^2 / sum w``, into an unbiased per-sample variance (factor
    ``n_eff / (n_eff - 1)``), and ``v / n_eff`` is the variance of the pixel value itself.
    """
    if rfilter.is_box:
        return np.full((height, width), float(spp))
    ix, jx = _axis_integrals(rfilter, width, 1), _axis_integrals(rfilter, width, 2)
    iy, jy = _axis_integrals(rfilter, height, 1), _axis_integrals(rfilter, height, 2)
    return spp * np.outer(iy * iy, ix * ix) / np.outer(jy, jx)


def lag_correlations(rfilter: ReconstructionFilter, steps: int = 512) -> np.ndarray:
    """Correlation of two pixels' filtered sums at pixel lags ``-2k..2k`` along one axis.

    ``rho(l) = ∫ w(x) w(x + l) dx / ∫ w(x)^2 dx`` (interior pixels, a sample density and
    variance that are uniform across the footprint); the 2-D correlation at lag
    ``(a, b)`` is ``rho(a) rho(b)``. The box filter gives ``[1]``.
    """
    k = rfilter.reach
    u = (np.arange(steps) + 0.5) / steps
    x = np.concatenate([o + u for o in range(-k - 1, k + 1)])               # covers the support
    lags = np.arange(-2 * k, 2 * k + 1)
    w0 = rfilter.eval(x)                                                    # centre at 0
    rho = np.array([np.sum(w0 * rfilter.eval(x - lag)) for lag in lags])
    return rho / rho[2 * k]


def build_rfilter(plugin: Plugin | None) -> ReconstructionFilter:
    """The film's ``<rfilter>``: box, tent or gaussian (Mitsuba's default when absent)."""
    if plugin is None:
        return ReconstructionFilter.make("gaussian")
    create = factory("rfilter", plugin.type)
    if create is None:
        raise plugin.error(f"unsupported reconstruction filter \"{plugin.type}\" ("
                           f"{suggestion(plugin.type, names('rfilter'))}supported: "
                           f"{', '.join(names('rfilter'))}; Mitsuba's lanczos and mitchell have "
                           "negative lobes, not implemented here)")
    return create(Props(plugin))


@register("rfilter", *FILTER_PARAMS)
def create_rfilter(props: Props) -> ReconstructionFilter:
    """A filter of :data:`FILTER_PARAMS` with its parameter (the box's radius must be 0.5)."""
    plugin = props.plugin
    children(plugin, {})
    name, default = FILTER_PARAMS[plugin.type]
    value = props.float(name, default)
    if plugin.type == "box" and value != 0.5:
        raise plugin.error("box filter radius must be 0.5 (one pixel)", props.line(name))
    if not 0.0 < value <= 64.0:
        raise plugin.error(f"{plugin.type} filter {name} must lie in (0, 64] pixels",
                           props.line(name))
    props.finish()
    return ReconstructionFilter.make(plugin.type, value)


def build_film(plugin: Plugin) -> tuple[int, int, ReconstructionFilter]:
    """``(width, height, rfilter)`` of a sensor's ``<film>``."""
    create = registered(plugin, "film")
    return create(Props(plugin))


@register("film", "hdrfilm")
def create_hdrfilm(props: Props) -> tuple[int, int, ReconstructionFilter]:
    """``width`` (768), ``height`` (576) and the ``<rfilter>`` (with the film's
    ``sample_border``); crops are refused, storage formats accepted."""
    plugin = props.plugin
    filters = children(plugin, {"rfilter": 1})["rfilter"]
    rfilter = build_rfilter(filters[0] if filters else None)
    width, height = props.int("width", 768), props.int("height", 576)
    if width <= 0 or height <= 0:
        raise plugin.error("film width and height must be positive")
    for name in ("crop_offset_x", "crop_offset_y", "crop_width", "crop_height"):
        if props.has(name):
            raise plugin.error(f"{name} is not supported: the tracer renders the whole film "
                               "(remove the crop, or render at the cropped size)",
                               props.line(name))
    # Mitsuba's sample border is ceil(radius - 0.5) pixels: empty for the box filter.
    if props.bool("sample_border", False) and not rfilter.is_box:
        rfilter = replace(rfilter, sample_border=True)
    # Formats change storage, not values; compensate only changes summation accuracy; a
    # banner is drawn on LDR output only.
    props.ignore("pixel_format", "component_format", "file_format", "compensate", "banner")
    props.finish()
    return width, height, rfilter
