"""Small vector helpers on (n, 3) arrays, shared by every module."""
from __future__ import annotations

import numpy as np

# NumPy broadcasts an (n, 3) array against an (n, 1) or (3,) one with inner loops of
# length 3, 2-6x slower than the same work done one component (column) at a time.
# scale, unscale and select are the per-column forms of the common cases.


def _per_column(op, a, s) -> np.ndarray:
    a = np.asarray(a)
    s = np.asarray(s)
    k = a.shape[-1]
    out = np.empty((len(s), k), np.result_type(a, s))
    for c in range(k):
        op(a[..., c], s, out=out[:, c])
    return out


def scale(a, s) -> np.ndarray:
    """``a * s[:, None]``: the rows of ``a`` (n, k), or its one row (k,), times ``s`` (n,)."""
    return _per_column(np.multiply, a, s)


def unscale(a, s) -> np.ndarray:
    """``a / s[:, None]``: the rows of ``a`` (n, k), or its one row (k,), divided by ``s`` (n,)."""
    return _per_column(np.divide, a, s)


def select(mask, a, fill: float = 0.0) -> np.ndarray:
    """``np.where(mask[:, None], a, fill)`` for (n, k) ``a``, or its one row (k,)."""
    a = np.asarray(a)
    mask = np.asarray(mask)
    out = np.empty((len(mask), a.shape[-1]), np.result_type(a, fill))
    for c in range(out.shape[1]):
        out[:, c] = np.where(mask, a[..., c], fill)
    return out


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot product of two (n, 3) arrays -> (n,).

    Written out per component: twice as fast as ``einsum`` or a sum along the
    axis of length 3.
    """
    out = a[:, 0] * b[:, 0]
    out += a[:, 1] * b[:, 1]
    out += a[:, 2] * b[:, 2]
    return out


def dot_einsum(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot product of two (n, 3) arrays -> (n,), summed as ``np.einsum`` sums it.

    The same value as :func:`dot` up to the last bit: einsum adds the three products in an
    order that depends on the memory layout (``(x + z) + y`` for C-contiguous rows, where
    :func:`dot` adds ``(x + y) + z``), so about a third of the rows differ from :func:`dot`
    by one rounding. The BSDFs use this one, so that their values, and the images, stay
    those they have always rendered.
    """
    return np.einsum("ij,ij->i", a, b)


def norm(a: np.ndarray) -> np.ndarray:
    """Row-wise Euclidean length -> (n,)."""
    return np.sqrt(dot(a, a))


def normalize(a: np.ndarray) -> np.ndarray:
    """Rows scaled to unit length (zero rows stay zero)."""
    length = norm(a)
    return unscale(a, np.where(length > 0, length, 1.0))


def unit(v: np.ndarray) -> np.ndarray:
    """Vectors along the last axis divided by their length (zero vectors stay zero).

    The same directions as :func:`normalize`, computed as a division by
    ``np.linalg.norm`` rather than a product with the reciprocal: the meshes' normals and
    the curves' frames are made this way, and keep their bits.
    """
    length = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(length > 0, length, 1.0)


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of two (n, 3) arrays."""
    return np.stack(
        (a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
         a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
         a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]), axis=1)


def _frame_columns(n: np.ndarray):
    """Columns of the tangents (s, t) of Duff et al.'s frame around unit normals ``n``.

    Returns ``(nx, ny, nz), (s0, s1, s2), (t0, t1, t2)`` as (n,) arrays.
    """
    nx, ny, nz = n[:, 0], n[:, 1], n[:, 2]
    sign = np.where(nz >= 0, 1.0, -1.0)
    a = -1.0 / (sign + nz)
    b = nx * ny * a
    sb = sign * b
    s0 = 1.0 + sign * (nx * nx) * a
    s2 = -sign * nx
    t1 = sign + (ny * ny) * a
    return (nx, ny, nz), (s0, sb, s2), (b, t1, -ny)


def coordinate_system(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two tangents completing the unit normals ``n`` to orthonormal frames.

    Uses the branchless construction of Duff et al. (2017), "Building an
    orthonormal basis, revisited", the same construction Mitsuba uses.
    """
    _, s, t = _frame_columns(n)
    return np.stack(s, axis=1), np.stack(t, axis=1)


def frame(n: np.ndarray):
    """The frame (s, t, n) around unit normals ``n`` as component columns, for
    :func:`to_local` / :func:`to_world` of several vectors at the same points."""
    return _frame_columns(n)


def to_local(v: np.ndarray, n: np.ndarray, columns=None) -> np.ndarray:
    """Express world vectors ``v`` in the frame (s, t, n) built around ``n``.

    Written out per component (no (n, 3) tangent arrays are built).
    ``columns``: :func:`frame` of ``n``, when already computed.
    """
    (nx, ny, nz), (s0, s1, s2), (t0, t1, t2) = _frame_columns(n) if columns is None else columns
    vx, vy, vz = v[:, 0], v[:, 1], v[:, 2]
    out = np.empty((len(v), 3))
    out[:, 0] = vx * s0 + vy * s1 + vz * s2
    out[:, 1] = vx * t0 + vy * t1 + vz * t2
    out[:, 2] = vx * nx + vy * ny + vz * nz
    return out


def to_world(v: np.ndarray, n: np.ndarray, columns=None) -> np.ndarray:
    """Inverse of :func:`to_local` (``columns``: :func:`frame` of ``n``, when already computed)."""
    (nx, ny, nz), (s0, s1, s2), (t0, t1, t2) = _frame_columns(n) if columns is None else columns
    x, y, z = v[:, 0], v[:, 1], v[:, 2]
    out = np.empty((len(v), 3))
    out[:, 0] = x * s0 + y * t0 + z * nx
    out[:, 1] = x * s1 + y * t1 + z * ny
    out[:, 2] = x * s2 + y * t2 + z * nz
    return out


def max_component(a: np.ndarray) -> np.ndarray:
    """Largest component of each row of an (n, 3) array -> (n,) (e.g. of a throughput).

    Two elementwise maxima: ``a.max(axis=1)`` is ~5x slower.
    """
    return np.maximum(np.maximum(a[:, 0], a[:, 1]), a[:, 2])


def any_row(mask: np.ndarray) -> np.ndarray:
    """Rows of an (n, 3) boolean array with some True -> (n,) (``np.any(mask, axis=1)``).

    Two elementwise ors: the reduction along the axis of length 3 is ~10x slower.
    """
    return np.logical_or(np.logical_or(mask[:, 0], mask[:, 1]), mask[:, 2])


def max_abs(p: np.ndarray) -> np.ndarray:
    """Largest absolute coordinate of each row -> (n,).

    Two elementwise maxima: a reduction along an axis of length 3 is ~5x slower.
    """
    return max_component(np.abs(p))


def put_rows(a: np.ndarray, rows, values) -> None:
    """``a[rows] = values`` for the rows of an (n, k) array (``values``: (len(rows), k)).

    Each row is moved as one k-element record (a void view of the array): twice as
    fast as NumPy's fancy assignment, which copies element by element. Other shapes
    (broadcast values, non-contiguous arrays) take the plain assignment.
    """
    values = np.asarray(values)
    if (a.ndim == 2 and values.ndim == 2 and values.shape[1] == a.shape[1] and a.size
            and a.flags.c_contiguous):
        record = _RECORDS.get((a.dtype, a.shape[1]))
        if record is None:
            record = _RECORDS[a.dtype, a.shape[1]] = np.dtype((np.void, a.shape[1] * a.itemsize))
        if values.dtype != a.dtype or not values.flags.c_contiguous:
            values = np.ascontiguousarray(values, dtype=a.dtype)
        a.view(record)[rows, 0] = values.view(record)[:, 0]
    else:
        a[rows] = values


def rows_by_value(ids: np.ndarray) -> list:
    """``(k, rows)`` for each distinct value ``k`` of ``ids`` (n,): ``rows`` its indices, or
    ``slice(None)`` when every row has it (the common case of one medium, BSDF or emitter:
    views instead of gathers with :func:`take_rows`, and no ``np.unique``, which sorts)."""
    if len(ids) and (ids == ids[0]).all():
        return [(ids[0], slice(None))]
    return [(k, np.flatnonzero(ids == k)) for k in np.unique(ids)]


def take_rows(a: np.ndarray, rows) -> np.ndarray:
    """``a[rows]`` for integer indices ``rows`` or a slice: ``np.take`` along axis 0 is
    several times faster than fancy indexing of (n, 3) arrays, a slice is a view."""
    return a[rows] if isinstance(rows, slice) else np.take(a, rows, axis=0)


def multiply_rows(a: np.ndarray, rows: np.ndarray, factor: np.ndarray) -> None:
    """``a[rows] *= factor`` for the (distinct) rows of an (n, k) array: one ``np.take`` and
    one :func:`put_rows`, where the fancy ``*=`` reads and writes element by element
    (several times slower)."""
    put_rows(a, rows, np.take(a, rows, axis=0) * factor)


_RECORDS: dict = {}   # (dtype, k) -> the void dtype of one row of k elements
