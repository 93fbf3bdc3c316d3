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
    r_other = np.where(steep, a, b)
    safe_r = np.where(r == 0.0, 1.0, r)
    phi = 0.25 * np.pi * r_other / safe_r
    phi = np.where(steep, 0.5 * np.pi - phi, phi)
    phi = np.where(r == 0.0, 0.0, phi)
    return np.stack((r * np.cos(phi), r * np.sin(phi)), axis=1)


def square_to_uniform_disk_concentric_pdf(p: np.ndarray) -> np.ndarray:
    r"""Density of :func:`square_to_uniform_disk_concentric` per unit area: :math:`1/\pi`."""
    return np.full(p.shape[0], INV_PI)


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
