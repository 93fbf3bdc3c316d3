"""Small vector helpers on (n, 3) arrays, shared by every module."""
from __future__ import annotations

import numpy as np


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot product of two (n, 3) arrays -> (n,)."""
    return np.einsum("ij,ij->i", a, b)


def norm(a: np.ndarray) -> np.ndarray:
    """Row-wise Euclidean length -> (n,)."""
    return np.sqrt(dot(a, a))


def normalize(a: np.ndarray) -> np.ndarray:
    """Rows scaled to unit length (zero rows stay zero)."""
    length = norm(a)
    return a / np.where(length > 0, length, 1.0)[:, None]


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of two (n, 3) arrays."""
    return np.stack(
        (a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
         a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
         a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]), axis=1)


def coordinate_system(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two tangents completing the unit normals ``n`` to orthonormal frames.

    Uses the branchless construction of Duff et al. (2017), "Building an
    orthonormal basis, revisited", the same construction Mitsuba uses.
    """
    sign = np.where(n[:, 2] >= 0, 1.0, -1.0)
    a = -1.0 / (sign + n[:, 2])
    b = n[:, 0] * n[:, 1] * a
    s = np.stack((1.0 + sign * n[:, 0] ** 2 * a, sign * b, -sign * n[:, 0]), axis=1)
    t = np.stack((b, sign + n[:, 1] ** 2 * a, -n[:, 1]), axis=1)
    return s, t


def to_local(v: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Express world vectors ``v`` in the frame (s, t, n) built around ``n``."""
    s, t = coordinate_system(n)
    return np.stack((dot(v, s), dot(v, t), dot(v, n)), axis=1)


def to_world(v: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Inverse of :func:`to_local`."""
    s, t = coordinate_system(n)
    return v[:, 0:1] * s + v[:, 1:2] * t + v[:, 2:3] * n


def max_abs(p: np.ndarray) -> np.ndarray:
    """Largest absolute coordinate of each row -> (n,)."""
    return np.max(np.abs(p), axis=1)
