"""4x4 affine transforms of Mitsuba's ``<transform name="to_world">``.

Each function returns a new (4, 4) float64 matrix acting on column vectors
``p' = M @ [x, y, z, 1]``. In the XML, every listed operation is applied
*after* the previous ones, so the loader left-multiplies:
``M = op_n @ ... @ op_2 @ op_1``.
"""
from __future__ import annotations

import numpy as np


def translate(v) -> np.ndarray:
    """Translation by the vector ``v``."""
    m = np.eye(4)
    m[:3, 3] = v
    return m


def scale(v) -> np.ndarray:
    """Axis-aligned scaling by the three factors ``v``."""
    return np.diag([float(v[0]), float(v[1]), float(v[2]), 1.0])


def rotate(axis, angle_deg: float) -> np.ndarray:
    """Rotation by ``angle_deg`` degrees about ``axis`` (right-handed).

    Rodrigues' formula ``cos I + sin [a]x + (1 - cos) a a^T`` applied to the
    axis *as given*, as Mitsuba 3.9.1 does: a non-unit axis is not
    normalised, so the matrix then also scales and shears. (Mitsuba also
    keeps the transpose as its inverse; the loader reproduces that for
    normals, see :func:`pathtracer.scene.xml.Prop.normal_matrix`.)
    """
    a = np.asarray(axis, dtype=float)
    theta = np.deg2rad(angle_deg)
    c, s = np.cos(theta), np.sin(theta)
    skew = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    m = np.eye(4)
    m[:3, :3] = c * np.eye(3) + s * skew + (1.0 - c) * np.outer(a, a)
    return m


def default_up(direction: np.ndarray) -> np.ndarray:
    """Mitsuba's fallback ``up`` when a lookat gives none: the first tangent of
    the orthonormal basis around ``direction`` (Duff et al. 2017)."""
    x, y, z = direction
    sign = 1.0 if z >= 0 else -1.0
    a = -1.0 / (sign + z)
    b = x * y * a
    return np.array([1.0 + sign * x * x * a, sign * b, -sign * x])


def look_at(origin, target, up=None) -> np.ndarray:
    """Camera-to-world matrix looking from ``origin`` towards ``target``.

    Columns are (left, up', dir, origin) with ``dir = normalize(target - origin)``,
    ``left = normalize(cross(up, dir))`` and ``up' = cross(dir, left)``, as in
    Mitsuba's ``Transform::look_at``: camera +x is the image's *left*.

    Raises
    ------
    ValueError
        If ``target == origin`` or ``up`` is parallel to the viewing direction.
    """
    origin = np.asarray(origin, dtype=float)
    d = np.asarray(target, dtype=float) - origin
    if np.linalg.norm(d) == 0:
        raise ValueError("degenerate lookat: target equals origin")
    d = d / np.linalg.norm(d)
    up = np.zeros(3) if up is None else np.asarray(up, dtype=float)
    if not np.any(up):
        up = default_up(d)
    left = np.cross(up, d)
    # Relative threshold: an up vector within ~1e-9 rad of the view direction
    # gives a left vector dominated by rounding noise.
    if np.linalg.norm(left) <= 1e-9 * np.linalg.norm(up):
        raise ValueError("degenerate lookat: 'up' is parallel to the viewing direction")
    left /= np.linalg.norm(left)
    new_up = np.cross(d, left)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = left, new_up, d, origin
    return m


def from_values(values) -> np.ndarray:
    """Matrix from 16 row-major values, or 9 values of the linear 3x3 part."""
    values = np.asarray(values, dtype=float)
    m = np.eye(4)
    if values.size == 16:
        m[:, :] = values.reshape(4, 4)
    elif values.size == 9:
        m[:3, :3] = values.reshape(3, 3)
    else:
        raise ValueError(f"matrix needs 9 or 16 values, got {values.size}")
    return m


def check_affine(m: np.ndarray) -> None:
    """Raise ValueError if ``m`` is projective, non-finite or singular."""
    if not np.all(np.isfinite(m)):
        raise ValueError("transform contains non-finite values")
    if not np.allclose(m[3], [0.0, 0.0, 0.0, 1.0], rtol=0, atol=1e-12):
        raise ValueError("transform has a projective last row (must be 0 0 0 1)")
    sv = np.linalg.svd(m[:3, :3], compute_uv=False)
    # Scale-invariant test: a uniformly tiny (but invertible) scale is fine.
    if sv[0] == 0 or sv[-1] <= 1e-10 * sv[0]:
        raise ValueError("degenerate (singular) transform")


def apply_points(m: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Transform (n, 3) points by the affine matrix ``m``."""
    return p @ m[:3, :3].T + m[:3, 3]


def apply_normal_matrix(normal_m: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Transform (n, 3) normals by ``normal_m`` (an inverse transpose given
    explicitly) and renormalise."""
    out = n @ normal_m[:3, :3].T
    length = np.linalg.norm(out, axis=1, keepdims=True)
    return out / np.where(length > 0, length, 1.0)


def is_orthonormal(m: np.ndarray, tol: float = 1e-6) -> bool:
    """True if the linear part of ``m`` is a rotation or mirror (to ``tol``)."""
    lin = m[:3, :3]
    return bool(np.all(np.abs(lin @ lin.T - np.eye(3)) <= tol))


def apply_normals(m: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Transform (n, 3) normals by the inverse transpose and renormalise."""
    out = n @ np.linalg.inv(m[:3, :3])  # == (M^-T n^T)^T
    length = np.linalg.norm(out, axis=1, keepdims=True)
    return out / np.where(length > 0, length, 1.0)


def has_scale(m: np.ndarray, tol: float = 1e-3) -> bool:
    """True unless the linear part is orthonormal (rotation, possibly mirrored).

    Same tolerance as Mitsuba's ``has_scale`` (used to reject cameras with scale).
    """
    lin = m[:3, :3]
    return bool(np.any(np.abs(lin @ lin.T - np.eye(3)) > tol))
