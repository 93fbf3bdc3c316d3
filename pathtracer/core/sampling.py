r"""Warps of uniform samples to directions and points, with their densities.

Every function is vectorized: a sample array ``u`` of shape ``(n, 2)`` holds
``n`` independent points of the unit square and maps to ``n`` results. The
mappings follow Mitsuba 3's ``warp`` namespace (same parameterisations, so a
given ``u`` lands on the same direction in both renderers), and each comes
with the density of its output with respect to the natural measure (area on
the disk, solid angle on the sphere).

Conventions
-----------
Directions are unit vectors in a local frame whose :math:`z` axis is the
pole (the shading normal for BSDFs, the cone axis for cones).
"""
from __future__ import annotations

import numpy as np

INV_PI = 1.0 / np.pi
INV_TWO_PI = 0.5 / np.pi
INV_FOUR_PI = 0.25 / np.pi


def _safe_sqrt(x: np.ndarray) -> np.ndarray:
    r""":math:`\sqrt{\max(x, 0)}`: guards against tiny negative round-off."""
    return np.sqrt(np.maximum(x, 0.0))


def _xyz(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Stack three (n,) arrays into an (n, 3) array of vectors."""
    return np.stack((x, y, z), axis=1)


# --------------------------------------------------------------------------
# Disk
# --------------------------------------------------------------------------

def square_to_uniform_disk_concentric(u: np.ndarray) -> np.ndarray:
    r"""Shirley-Chiu concentric map of the square onto the unit disk.

    With :math:`(a, b) = 2u - 1`, the larger of :math:`|a|, |b|` becomes the
    radius and the ratio of the two the angle within that octant:

    .. math::
        |a| \ge |b|:\ r = a,\ \phi = \tfrac{\pi}{4}\,\tfrac{b}{a};\qquad
        |a| < |b|:\ r = b,\ \phi = \tfrac{\pi}{2} - \tfrac{\pi}{4}\,\tfrac{a}{b}.

    The map is area-preserving up to a constant, so the output is uniform
    with density :math:`1/\pi`, and it keeps strata compact (low distortion).

    The cosine and sine are taken in float32 (28x faster than in float64 here): the
    angle is within ~1e-7 of the exact one, far below anything a render can resolve
    (Mitsuba's own warps are float32); the radius is exact.

    Parameters
    ----------
    u : (n, 2) ndarray
        Uniform samples in :math:`[0, 1)^2`.

    Returns
    -------
    (n, 2) ndarray
        Points :math:`(r\cos\phi, r\sin\phi)` of the unit disk.
    """
    a = 2.0 * u[:, 0] - 1.0
    b = 2.0 * u[:, 1] - 1.0
    steep = np.abs(a) < np.abs(b)
    r = np.where(steep, b, a)
    # theta = pi/4 (other / r) in [-pi/4, pi/4]; phi = theta, or pi/2 - theta where steep,
    # whose cosine and sine are theta's sine and cosine: the axes come out exact.
    theta = np.where(steep, a, b) / np.where(r == 0.0, 1.0, r)   # r = 0: the centre
    theta *= 0.25 * np.pi
    theta = theta.astype(np.float32)
    cos_t, sin_t = np.cos(theta).astype(np.float64), np.sin(theta).astype(np.float64)
    # Rescaled to unit length in float64, so that the radius stays exact (a cosine-weighted
    # direction takes z = sqrt(1 - x^2 - y^2), which would magnify an error near the rim).
    r = r / np.sqrt(cos_t * cos_t + sin_t * sin_t)
    out = np.empty((len(r), 2))
    np.multiply(r, np.where(steep, sin_t, cos_t), out=out[:, 0])
    np.multiply(r, np.where(steep, cos_t, sin_t), out=out[:, 1])
    return out


# --------------------------------------------------------------------------
# Hemisphere and sphere
# --------------------------------------------------------------------------

def square_to_cosine_hemisphere(u: np.ndarray) -> np.ndarray:
    r"""Cosine-weighted direction on the upper hemisphere (Malley's method).

    A uniform point :math:`(x, y)` of the disk is lifted to
    :math:`z = \sqrt{1 - x^2 - y^2}`; projecting solid angle onto the disk
    costs a factor :math:`\cos\theta`, so the density is
    :math:`p(\omega) = \cos\theta / \pi`.

    Parameters
    ----------
    u : (n, 2) ndarray
        Uniform samples.

    Returns
    -------
    (n, 3) ndarray
        Unit directions with :math:`z \ge 0`.
    """
    p = square_to_uniform_disk_concentric(u)
    z = _safe_sqrt(1.0 - p[:, 0] ** 2 - p[:, 1] ** 2)
    return _xyz(p[:, 0], p[:, 1], z)


def square_to_cosine_hemisphere_pdf(v: np.ndarray) -> np.ndarray:
    r"""Solid-angle density of :func:`square_to_cosine_hemisphere`.

    .. math:: p(\omega) = \frac{\max(\cos\theta, 0)}{\pi}
    """
    return INV_PI * np.maximum(v[:, 2], 0.0)


def square_to_uniform_hemisphere(u: np.ndarray) -> np.ndarray:
    r"""Uniform direction on the upper hemisphere (low-distortion concentric variant).

    A uniform disk point :math:`p` with :math:`\rho^2 = |p|^2` maps to
    :math:`z = 1 - \rho^2` (uniform in :math:`[0, 1]`, Archimedes) and the
    horizontal part is rescaled by :math:`\sqrt{1 + z}` so that the result is
    a unit vector: :math:`|p|^2 (1 + z) = (1 - z)(1 + z) = 1 - z^2`.

    Returns
    -------
    (n, 3) ndarray
        Unit directions with density :math:`1 / (2\pi)`.
    """
    p = square_to_uniform_disk_concentric(u)
    z = 1.0 - (p[:, 0] ** 2 + p[:, 1] ** 2)
    scale = np.sqrt(z + 1.0)
    return _xyz(p[:, 0] * scale, p[:, 1] * scale, z)


def square_to_uniform_hemisphere_pdf(v: np.ndarray) -> np.ndarray:
    r"""Solid-angle density of :func:`square_to_uniform_hemisphere`: :math:`1/(2\pi)` for :math:`z \ge 0`, else 0."""
    return np.where(v[:, 2] >= 0.0, INV_TWO_PI, 0.0)


def square_to_uniform_sphere(u: np.ndarray) -> np.ndarray:
    r"""Uniform direction on the unit sphere.

    .. math::
        z = 1 - 2u_y,\quad \phi = 2\pi u_x,\quad
        \omega = (\sqrt{1-z^2}\cos\phi,\ \sqrt{1-z^2}\sin\phi,\ z)

    Returns
    -------
    (n, 3) ndarray
        Unit directions with density :math:`1/(4\pi)`.
    """
    z = 1.0 - 2.0 * u[:, 1]
    r = _safe_sqrt(1.0 - z * z)
    phi = 2.0 * np.pi * u[:, 0]
    return _xyz(r * np.cos(phi), r * np.sin(phi), z)


def square_to_uniform_sphere_pdf(v: np.ndarray) -> np.ndarray:
    r"""Solid-angle density of :func:`square_to_uniform_sphere`: :math:`1/(4\pi)`."""
    return np.full(v.shape[0], INV_FOUR_PI)


# --------------------------------------------------------------------------
# Cone
# --------------------------------------------------------------------------

def square_to_uniform_cone(u: np.ndarray, cos_cutoff) -> np.ndarray:
    r"""Uniform direction inside the cone :math:`\cos\theta \ge \cos\theta_{max}` around +z.

    Concentric variant: with :math:`c = 1 - \cos\theta_{max}` and a uniform
    disk point :math:`p` (:math:`\rho^2 = |p|^2`),

    .. math::
        z = \cos\theta_{max} + c\,(1 - \rho^2),\qquad
        (x, y) = p\,\sqrt{c\,(2 - c\rho^2)},

    so :math:`z` is uniform on :math:`[\cos\theta_{max}, 1]` and the vector is
    unit length.

    Parameters
    ----------
    u : (n, 2) ndarray
        Uniform samples.
    cos_cutoff : float or (n,) ndarray
        Cosine of the cone's half-angle.

    Returns
    -------
    (n, 3) ndarray
        Unit directions with density :math:`1 / (2\pi (1 - \cos\theta_{max}))`.
    """
    c = 1.0 - np.asarray(cos_cutoff, dtype=np.float64)
    p = square_to_uniform_disk_concentric(u)
    rho2 = p[:, 0] ** 2 + p[:, 1] ** 2
    z = (1.0 - c) + c * (1.0 - rho2)
    scale = _safe_sqrt(c * (2.0 - c * rho2))
    return _xyz(p[:, 0] * scale, p[:, 1] * scale, z)


def square_to_uniform_cone_pdf(v: np.ndarray, cos_cutoff) -> np.ndarray:
    r"""Solid-angle density of :func:`square_to_uniform_cone`.

    .. math:: p(\omega) = \frac{1}{2\pi\,(1 - \cos\theta_{max})}
              \quad\text{inside the cone, 0 outside.}
    """
    cos_cutoff = np.asarray(cos_cutoff, dtype=np.float64)
    inside = v[:, 2] >= cos_cutoff
    return np.where(inside, INV_TWO_PI / (1.0 - cos_cutoff), 0.0)


# --------------------------------------------------------------------------
# Triangle
# --------------------------------------------------------------------------

def square_to_uniform_triangle(u: np.ndarray) -> np.ndarray:
    r"""Uniform barycentric coordinates on a triangle (Mitsuba's parameterisation).

    .. math:: t = \sqrt{1 - u_x},\qquad (b_1, b_2) = (1 - t,\ t\,u_y)

    The point is :math:`p = (1 - b_1 - b_2)\,p_0 + b_1 p_1 + b_2 p_2`; for
    any triangle of area :math:`A` it has area density :math:`1/A`
    (the density on the reference triangle is 2).

    Returns
    -------
    (n, 2) ndarray
        Barycentrics :math:`(b_1, b_2)` of vertices 1 and 2.
    """
    t = _safe_sqrt(1.0 - u[:, 0])
    return np.stack((1.0 - t, t * u[:, 1]), axis=1)


def square_to_uniform_triangle_pdf(b: np.ndarray) -> np.ndarray:
    r"""Density of :func:`square_to_uniform_triangle` on the reference triangle: 2 inside, 0 outside."""
    inside = (b[:, 0] >= 0) & (b[:, 1] >= 0) & (b[:, 0] + b[:, 1] <= 1)
    return np.where(inside, 2.0, 0.0)


# --------------------------------------------------------------------------
# Discrete choices and MIS
# --------------------------------------------------------------------------

def sample_discrete(cdf: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""Pick an entry of a discrete distribution and recycle the sample.

    Entry :math:`i` is chosen when :math:`C_{i-1} \le u\,C_{n-1} < C_i`
    (with :math:`C_{-1} = 0`), i.e. with probability
    :math:`p_i = (C_i - C_{i-1}) / C_{n-1}`. The reused sample

    .. math:: u' = \frac{u\,C_{n-1} - C_{i-1}}{C_i - C_{i-1}}

    is again uniform on :math:`[0, 1)` and independent of :math:`i`
    (Mitsuba's ``DiscreteDistribution::sample_reuse``).

    Parameters
    ----------
    cdf : (k,) ndarray
        Inclusive cumulative sums :math:`C_i = \sum_{j \le i} w_j` of the
        non-negative weights (need not be normalised; no leading zero).
    u : (n,) ndarray
        Uniform samples in :math:`[0, 1)`.

    Returns
    -------
    index : (n,) int64
        Chosen entries (entries of zero weight are never chosen).
    u_reused : (n,) ndarray
        The recycled uniform samples.
    """
    cdf = np.asarray(cdf, dtype=np.float64)
    target = u * cdf[-1]
    index = np.searchsorted(cdf, target, side="right")
    index = np.minimum(index, cdf.shape[0] - 1)
    lower = np.where(index > 0, cdf[np.maximum(index - 1, 0)], 0.0)
    width = cdf[index] - lower
    u_reused = np.where(width > 0, (target - lower) / np.where(width > 0, width, 1.0), 0.0)
    return index, np.clip(u_reused, 0.0, np.nextafter(1.0, 0.0))


def power_heuristic(pdf_a: np.ndarray, pdf_b: np.ndarray) -> np.ndarray:
    r"""Veach's power heuristic (exponent 2) for one sample of each of two techniques.

    .. math:: w_a = \frac{p_a^2}{p_a^2 + p_b^2}

    Returns 0 where the ratio is not finite (both densities 0, or an
    infinite density), as Mitsuba does.
    """
    a2 = np.square(np.asarray(pdf_a, dtype=np.float64))
    b2 = np.square(np.asarray(pdf_b, dtype=np.float64))
    with np.errstate(divide="ignore", invalid="ignore"):
        w = a2 / (a2 + b2)
    return np.where(np.isfinite(w), w, 0.0)


# --------------------------------------------------------------------------
# 2-D distributions
# --------------------------------------------------------------------------

def _interval_to_linear(v0: np.ndarray, v1: np.ndarray, u: np.ndarray) -> np.ndarray:
    r"""Invert the CDF of the density :math:`\propto (1 - x) v_0 + x v_1` on [0, 1].

    Solving :math:`u = \frac{2 v_0 x + (v_1 - v_0) x^2}{v_0 + v_1}` for x and
    rationalising gives :math:`x = u (v_0 + v_1) / (v_0 + \sqrt{(1-u) v_0^2 + u v_1^2})`,
    which stays exact (no cancellation) when :math:`v_0 \approx v_1`.
    """
    root = np.sqrt(np.maximum((1.0 - u) * v0 * v0 + u * v1 * v1, 0.0))
    denominator = v0 + root
    with np.errstate(divide="ignore", invalid="ignore"):
        x = u * (v0 + v1) / denominator
    return np.where(denominator > 0, x, u)


def _pad_even(level: np.ndarray) -> np.ndarray:
    """Zero-pad a 2-D array to even numbers of rows and columns."""
    return np.pad(level, ((0, level.shape[0] % 2), (0, level.shape[1] % 2)))


class Distribution2D:
    r"""Sampling a bilinearly interpolated 2-D function on the unit square.

    ``values`` holds the function at the vertices of a regular grid: vertex
    ``(i, j)`` (row i, column j) sits at :math:`(x, y) = (j / (W - 1), i / (H - 1))`,
    and between vertices the function is bilinear. The density is that
    function normalised to integrate to one over :math:`[0, 1]^2`. This is
    Mitsuba's ``Hierarchical2D``: the same uniform numbers land on the same
    point (up to float32 round-off on Mitsuba's side).

    Sampling descends a pyramid of patch integrals (the finest level holds
    the integral of each bilinear patch, each coarser level the sums of
    2x2 blocks), choosing a row then a column at each level and rescaling
    the uniform numbers, then samples the chosen bilinear patch exactly
    (marginal in y, conditional in x, each a linear density).

    Parameters
    ----------
    values : (H, W) array_like
        Non-negative vertex values, H, W >= 2.
    """

    def __init__(self, values):
        values = np.asarray(values, dtype=np.float64)
        if values.ndim != 2 or min(values.shape) < 2:
            raise ValueError(f"Distribution2D needs an (H, W) array with H, W >= 2, got {values.shape}")
        if np.any(values < 0) or not np.all(np.isfinite(values)):
            raise ValueError("Distribution2D needs finite, non-negative values")
        self.patches = np.array(values.shape[::-1]) - 1          # (patches in x, patches in y)
        patch_mean = 0.25 * (values[:-1, :-1] + values[:-1, 1:] + values[1:, :-1] + values[1:, 1:])
        total = patch_mean.sum()
        #: Zero everywhere: sampling fails (pdf 0) and the density is 0.
        self.is_zero = total <= 0
        scale = 0.0 if self.is_zero else patch_mean.size / total
        self.vertices = values * scale
        self.levels = [_pad_even(patch_mean * scale)]
        while max(self.levels[-1].shape) > 2:
            fine = self.levels[-1]
            coarse = fine[0::2, 0::2] + fine[0::2, 1::2] + fine[1::2, 0::2] + fine[1::2, 1::2]
            self.levels.append(_pad_even(coarse))

    def sample(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Warp uniform numbers to points of the unit square.

        Parameters
        ----------
        u : (n, 2) ndarray
            Uniform numbers in :math:`[0, 1]^2`.

        Returns
        -------
        points : (n, 2) ndarray
            ``(x, y)`` in :math:`[0, 1]^2`.
        pdf : (n,) ndarray
            The density at ``points`` (0 when the function is zero).
        """
        ux, uy = np.clip(u[:, 0], 0.0, 1.0), np.clip(u[:, 1], 0.0, 1.0)
        ox = np.zeros(len(u), dtype=np.int64)
        oy = np.zeros(len(u), dtype=np.int64)
        for level in reversed(self.levels):
            ox, oy = 2 * ox, 2 * oy
            v00, v10 = level[oy, ox], level[oy, ox + 1]
            v01, v11 = level[oy + 1, ox], level[oy + 1, ox + 1]
            ux, uy = np.clip(ux, 0.0, 1.0), np.clip(uy, 0.0, 1.0)
            r0, r1 = v00 + v10, v01 + v11
            uy = uy * (r0 + r1)
            lower = uy > r0
            oy += lower
            uy = np.where(lower, uy - r0, uy)
            dy = np.where(lower, r1, r0)
            c0, c1 = np.where(lower, v01, v00), np.where(lower, v11, v10)
            ux = ux * dy
            right = ux > c0
            ox += right
            ux = np.where(right, ux - c0, ux)
            dx = np.where(right, c1, c0)
            with np.errstate(divide="ignore", invalid="ignore"):
                ux, uy = np.nan_to_num(ux / dx), np.nan_to_num(uy / dy)
        ox = np.minimum(ox, self.patches[0] - 1)
        oy = np.minimum(oy, self.patches[1] - 1)
        v00, v10, v01, v11 = self._corners(ox, oy)
        y = _interval_to_linear(v00 + v10, v01 + v11, np.clip(uy, 0.0, 1.0))
        c0, c1 = v00 + (v01 - v00) * y, v10 + (v11 - v10) * y
        x = _interval_to_linear(c0, c1, np.clip(ux, 0.0, 1.0))
        pdf = c0 + (c1 - c0) * x
        points = np.stack(((ox + x) / self.patches[0], (oy + y) / self.patches[1]), axis=1)
        return points, pdf

    def pdf(self, points: np.ndarray) -> np.ndarray:
        """Density at ``points`` (n, 2) of the unit square (clamped into it)."""
        pos = np.clip(points, 0.0, 1.0) * self.patches
        offset = np.minimum(pos.astype(np.int64), self.patches - 1)
        fx, fy = (pos - offset).T
        v00, v10, v01, v11 = self._corners(offset[:, 0], offset[:, 1])
        return (v00 * (1 - fx) + v10 * fx) * (1 - fy) + (v01 * (1 - fx) + v11 * fx) * fy

    def _corners(self, ox: np.ndarray, oy: np.ndarray):
        """Normalised values at the four corners of patches (ox, oy)."""
        v = self.vertices
        return v[oy, ox], v[oy, ox + 1], v[oy + 1, ox], v[oy + 1, ox + 1]
