r"""Mean and variance of an image from ``K`` independent replicas (pure functions on arrays).

When the per-pixel variance of a render cannot be taken from the renderer (an external renderer
that writes none, a light tracer whose splats belong to no pixel, a grader that must not believe
the student process), it comes from the spread of ``K`` renders with seeds of their own, each
of ``n / K`` samples per pixel:

.. math::

    \bar I = \frac{1}{K}\sum_k I_k, \qquad
    s^2 = \frac{n}{K}\,\frac{1}{K-1}\sum_k (I_k - \bar I)^2 ,

so that :math:`s^2 / n` estimates the variance of :math:`\bar I`, as a render's own per-sample
variance does (``K - 1`` degrees of freedom per pixel; the mean and variance tests sum pixels
over tiles and the image, so a tile's variance keeps hundreds of them).

Replicas that share part of their noise (a seed ignored, one random stream reused) make the
spread too small. Two that share a fraction :math:`s` of their noise have *standardised*
deviations that correlate near :math:`s`, independent ones near 0 (:func:`shared_noise`): each
pixel and channel's deviations from the replicas' median, divided by their RMS over the
replicas. The median, not the average: one replica with a huge sample in a pixel moves the
average there, so that every other replica's deviation from it would carry the same large
value. Standardised: otherwise a few pixels of high variance (a light's edge) carry the whole
correlation, which is then the noise of a handful of values (0.56 for 8 independent renders of
``direct`` on the Cornell box, against -0.04 standardised).

Replicas can also share noise at a pixel offset: a renderer that seeds each pixel's stream with
the seed plus a pixel index replays, at seed ``s + 1``, the streams of seed ``s`` one pixel
further on, and the correlation at the same pixel stays near 0. :func:`offset_shared_noise`
looks at every 2-D offset (the harness's check, :mod:`mitsuba_refs.external.renders`);
:func:`shared_noise` at the same pixel only (the grader's, whose renders hash their seeds).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def replica_moments(stack, samples_per_replica: int = 1):
    """``(mean, per-sample variance)`` of replica images.

    Parameters
    ----------
    stack : array (K, H, W, C), K >= 2
        The replicas' mean images.
    samples_per_replica : int
        Samples per pixel of each replica (``n / K``): the spread times this is a per-sample
        variance.
    """
    stack = np.asarray(stack, dtype=np.float64)
    if stack.shape[0] < 2:
        raise ValueError(f"need at least 2 replicas, got {stack.shape[0]}")
    return stack.mean(axis=0), stack.var(axis=0, ddof=1) * samples_per_replica


def shared_noise(stack):
    """The most correlated pair of replicas: ``(k, l, correlation)`` of their standardised
    deviations (module docstring), or None for fewer than 3 replicas or an image without noise.

    Independent replicas give about 0 (-0.09 for 8 Gaussian ones, -0.25 for 4); the standard
    error of one pair's correlation is about ``1 / sqrt(H W C)`` (0.01 for 64 x 48 x 3).
    """
    stack = np.asarray(stack, dtype=np.float64)
    count = stack.shape[0]
    if count < 3:
        return None
    deviations = stack - np.median(stack, axis=0)
    scale = np.sqrt(np.mean(deviations ** 2, axis=0))
    noisy = scale > 0
    deviations = (deviations[:, noisy] / scale[noisy]).reshape(count, -1)
    norms = np.sqrt(np.einsum("ij,ij->i", deviations, deviations))
    if not np.all(norms > 0):
        return None
    correlation = (deviations @ deviations.T) / np.outer(norms, norms)
    np.fill_diagonal(correlation, -np.inf)
    k, l = np.unravel_index(int(np.argmax(correlation)), correlation.shape)
    return int(k), int(l), float(correlation[k, l])


#: Offsets whose overlap holds fewer noisy pixels than this are not compared (too few to tell).
MIN_OVERLAP_PIXELS = 64
#: ... nor those whose overlap is below this fraction of the noisy pixels.
MIN_OVERLAP_FRACTION = 0.25
#: Images larger than this on a side are compared on their central crop of this size (the
#: memory and time of the FFTs; offsets up to this many pixels are still found).
MAX_SIDE = 256
#: A replica's own neighbouring pixels are correlated (a tent or gaussian film, splats) up to
#: this many pixels apart along x and y: the range of the variance factor of the sums.
NEIGHBOURHOOD = 3


@dataclass(frozen=True)
class SharedNoise:
    """The most significant shared noise between two replicas (:func:`offset_shared_noise`).

    Attributes
    ----------
    first, second : int
        The two replicas (0-based indices into the stack, ``first < second``).
    dx, dy : int
        The offset: replica ``second`` at pixel ``(x + dx, y + dy)`` shares its noise with
        replica ``first`` at ``(x, y)`` (``y`` grows downwards, as rows do).
    correlation : float
        The correlation of their standardised deviations over the overlap (at offset 0 the
        excess over the -1/(K-1) of independent replicas).
    z : float
        Its significance: about a standard normal for independent replicas.
    pixels : int
        The noisy pixels of the overlap.
    tests : int
        How many (pair, offset) were compared: the largest ``z`` of independent replicas grows
        with it as the largest of that many standard normals.
    """

    first: int
    second: int
    dx: int
    dy: int
    correlation: float
    z: float
    pixels: int
    tests: int


def offset_shared_noise(stack, max_side: int = MAX_SIDE) -> SharedNoise | None:
    r"""The pair of replicas and the 2-D pixel offset at which their noise is most significantly
    shared; None for fewer than 3 replicas or an image without noise.

    A renderer that derives each pixel's random stream from the seed plus a pixel index replays,
    at seed :math:`s + d`, the streams of seed :math:`s` :math:`d` pixels further on: the two
    images share noise at a pixel offset, not at the same pixel. A shift of a row-major index is
    a 2-D shift (``d mod W``, ``d // W``); one of a block-local Morton index moves most pixels of
    a block by one 2-D offset (half of them for ``d = 1``).

    **Deviations.** Each channel's deviation from the replicas' per-pixel average, divided by
    their RMS there, summed over the channels and standardised again the same way, is
    :math:`u_k(p)`: one number per replica and pixel, :math:`\sum_k u_k(p) = 0`,
    :math:`\sum_k u_k(p)^2 = K`. The average, not the median: then :math:`E[u_k(p)] = 0` for
    exchangeable replicas whatever the skew of a pixel's distribution, so that for independent
    pixels :math:`E[u_k(p)\, u_l(p + \delta)] = 0` at every offset :math:`\delta \neq 0`.

    **Statistic.** For each pair :math:`k < l` and offset, zero-padded FFTs give
    :math:`S = \sum_p u_k(p)\, u_l(p + \delta)` over the overlap, the correlation
    :math:`r = S / \sqrt{\sum u_k^2 \sum u_l^2}`, and the self-normalised sum

    .. math::

        t = \frac{S}{\sqrt{f \sum_p u_k(p)^2\, u_l(p + \delta)^2}},
        \qquad f = \sum_{|\delta'_x|, |\delta'_y| \le 3} \bar\rho(\delta')^2 ,

    :math:`\bar\rho` the replicas' average autocorrelation (:math:`f = 1` for independent
    pixels; a tent or gaussian film's neighbours raise it). Self-normalised, :math:`t` keeps
    nearly Gaussian tails where :math:`r \sqrt N` does not: at one sample per pixel most pixels
    have one bright replica, and the products are rare large values. At offset 0 independent
    replicas average :math:`S = -N/(K - 1)` (the deviations sum to 0), which is added back.
    Offsets whose overlap holds fewer than :data:`MIN_OVERLAP_PIXELS` noisy pixels, or less
    than :data:`MIN_OVERLAP_FRACTION` of them, are left out. The result is the pair and offset
    of largest :math:`t`.

    Parameters
    ----------
    stack : array (K, H, W, C) or (K, H, W)
        The replicas' mean images.
    max_side : int
        Larger images are compared on their central ``max_side`` x ``max_side`` crop.
    """
    stack = np.asarray(stack, dtype=np.float64)
    if stack.ndim == 3:
        stack = stack[..., None]
    count, height, width = stack.shape[:3]
    if count < 3:
        return None
    top, left = max(0, (height - max_side) // 2), max(0, (width - max_side) // 2)
    stack = stack[:, top:top + max_side, left:left + max_side]
    height, width = stack.shape[1:3]
    u = _standardised(_standardised(stack).sum(axis=-1))
    noisy = np.any(u != 0, axis=0)
    if not noisy.any():
        return None
    shape = (2 * height, 2 * width)

    def spectrum(image):
        return np.fft.rfft2(np.asarray(image, dtype=np.float32), s=shape, axes=(-2, -1))

    def correlate(a, b):
        """sum_p a(p) b(p + delta) for every delta (circular indices), from spectra."""
        return np.fft.irfft2(np.conj(a) * b, s=shape, axes=(-2, -1))

    inside, spectra, squares = spectrum(noisy), spectrum(u), spectrum(u * u)
    overlap = np.rint(correlate(inside, inside))
    wanted = max(MIN_OVERLAP_PIXELS, MIN_OVERLAP_FRACTION * float(noisy.sum()))
    valid = overlap >= wanted
    if not valid.any():
        return None
    rows, columns = np.arange(shape[0]), np.arange(shape[1])
    dy = np.where(rows < height, rows, rows - shape[0])            # circular index -> offset
    dx = np.where(columns < width, columns, columns - shape[1])
    factor = _variance_factor(correlate(spectra, spectra), dx, dy)
    baseline = np.zeros(shape)
    baseline[0, 0] = overlap[0, 0] / (count - 1)                   # offset 0: sum_k u_k = 0
    best, tests = None, int(valid.sum()) * count * (count - 1) // 2
    for k in range(count):
        leading = correlate(squares[k], inside)                    # sum u_k(p)^2, p + d inside
        for l in range(k + 1, count):
            trailing = correlate(inside, squares[l])               # sum u_l(p + d)^2, p inside
            products = correlate(spectra[k], spectra[l]) + baseline
            spread = correlate(squares[k], squares[l])
            ok = valid & (spread > 0) & (leading * trailing > 0)
            t = np.where(ok, products / np.sqrt(np.where(ok, factor * spread, 1.0)), -np.inf)
            i, j = np.unravel_index(int(np.argmax(t)), t.shape)
            if best is None or t[i, j] > best.z:
                r = products[i, j] / np.sqrt(leading[i, j] * trailing[i, j])
                best = SharedNoise(k, l, int(dx[j]), int(dy[i]), float(r), float(t[i, j]),
                                   int(overlap[i, j]), tests)
    return best


def _standardised(values):
    """Deviations from the replicas' average (axis 0), divided by their RMS; 0 where they
    are all equal."""
    deviations = values - values.mean(axis=0)
    scale = np.sqrt(np.mean(deviations ** 2, axis=0))
    return np.where(scale > 0, deviations / np.where(scale > 0, scale, 1.0), 0.0)


def _variance_factor(autocorrelations, dx, dy) -> float:
    """``sum rho(d)^2`` over the offsets within :data:`NEIGHBOURHOOD` of 0 (at least 1), from
    the replicas' circular autocorrelations (K, 2H, 2W)."""
    near = (np.abs(dy) <= NEIGHBOURHOOD)[:, None] & (np.abs(dx) <= NEIGHBOURHOOD)[None, :]
    zero = autocorrelations[:, :1, :1]
    rho = np.where(zero > 0, autocorrelations / np.where(zero > 0, zero, 1.0), 0.0).mean(axis=0)
    return max(1.0, float(np.sum(rho[near] ** 2)))
