"""Small meshes, every ray against every triangle (:class:`SmallMesh`), and scenes of
one big mesh in a room of small shapes (:class:`SplitMesh`, :func:`small_shapes`)."""
from __future__ import annotations

import threading

import numpy as np

from ..core.machine import format_size, this_machine
from ..core.vec import dot_einsum
from .blas import single_threaded_blas
from .bvh import BVH, _plane_coordinates, _rays

# ----------------------------------------------------------------------
# Small meshes: every ray against every triangle, float32 filter + float64 refit

SMALL_MAX = 64  # triangles up to which :class:`SmallMesh` beats the BVH
#: Rays per chunk: the chunk's float32 scratch fills at most the core's L2, within these bounds
#: (1024-16384 rays ran equally fast on the AMD EPYC and Intel Xeon of docs/performance.md).
SMALL_CHUNK_RANGE = (2048, 8192)
#: Rays per chunk where the machine does not report its L2.
SMALL_CHUNK_DEFAULT = 4096
SMALL_BARY_EPS = 1e-5  # barycentric slack of the float32 filter (covers its rounding)


class SmallMesh:
    """All-pairs intersection for scenes with few triangles (e.g. box rooms).

    Two triangles that form a parallelogram (the two halves of a rectangle, a
    cube's face) are tested as one primitive, so a box room costs half the
    tests. A primitive, with origin ``p0`` and edges ``e1``, ``e2``, is written
    as affine functions of a point x: the signed distance to its plane, and
    functions of x's coordinates ``b1``, ``b2`` along the edges that say whether
    it lies inside: ``|b1 - 1/2|, |b2 - 1/2| <= 1/2`` for a parallelogram,
    ``b1, b2, 1 - b1 - b2 >= 0`` for a lone triangle. For a ray, two small
    float32 matrix products give those functions at the origin and their rates
    along the direction for every primitive at once; then ``t = distance /
    rate`` and ``g = g(o) + t g'(d)`` with a handful of in-place ufuncs on
    (P, chunk) arrays. The closest accepted primitive per ray is one integer ``min``: the
    float32 ``t`` with its low mantissa bits replaced by the primitive index
    (negative ``t``, NaN and rejected pairs compare above ``inf`` as unsigned
    integers).

    The winner is then intersected again in float64 (Möller–Trumbore on its
    ``p0``, ``e1``, ``e2``, as :class:`BVH` does), so the returned ``t`` and
    barycentrics have full precision; float32 only decides which primitive. On
    a parallelogram, ``b1 + b2 <= 1`` picks the triangle, and an affine map turns
    the coordinates into that triangle's own barycentrics. The filter's slack of
    ``SMALL_BARY_EPS`` keeps shared edges watertight. The results match
    :class:`BVH` except at near-ties within float32 rounding (adjacent
    triangles, coplanar overlaps) and in the last bits of ``t``.
    """

    def __init__(self, tri_p: np.ndarray):
        tri_p = np.asarray(tri_p, np.float64).reshape(-1, 3, 3)
        self.num_triangles = T = len(tri_p)
        if T > 1 << 8:
            raise ValueError(f"SmallMesh holds at most 256 triangles, got {T}")
        self.brute_force = True
        # Primitive k: origin p0, edges e1, e2; its halves 2k (b1 + b2 <= 1) and 2k + 1 are
        # triangles[2k + h], and to_bary[:, 2k + h] maps (1, b1, b2) to that triangle's
        # barycentrics of its p1 (rows 0-2) and p2 (rows 3-5).
        p0, e1, e2, triangles, to_bary, quad = _parallelograms(tri_p)
        self._triangles = triangles.ravel()  # row 2k + half
        self._to_bary = np.ascontiguousarray(to_bary.reshape(-1, 6).T)  # (6, 2P)
        self.num_primitives = P = len(p0)
        self._quads = Q = int(quad.sum())   # parallelograms first, then lone triangles
        self._bits = max(1, int(np.ceil(np.log2(max(P, 2)))))
        n = np.cross(e1, e2)
        nn = dot_einsum(n, n)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = np.where(nn > 0, 1.0 / nn, np.nan)  # degenerate triangles: NaN, never hit
            a1 = np.cross(e2, n) * inv[:, None]
            a2 = np.cross(n, e1) * inv[:, None]
            unit = n * np.sqrt(inv)[:, None]
        # Affine functions c + a . x, as rows (linear part, constant): the signed distance
        # to the plane of every primitive; then b1 - 1/2, b2 - 1/2 of the parallelograms
        # (inside: both within +-1/2); then b1, b2, 1 - b1 - b2 of the lone triangles
        # (inside: all >= 0).
        para, lone = slice(0, Q), slice(Q, P)
        blocks = [(-unit, 0.0, slice(0, P)), (a1, -0.5, para), (a2, -0.5, para),
                  (a1, 0.0, lone), (a2, 0.0, lone), (-a1 - a2, 1.0, lone)]
        mo, md = [], []
        for a, c, rows in blocks:
            a, origin = a[rows], p0[rows]
            mo.append(np.column_stack((a, c - dot_einsum(a, origin))))
            md.append(a)
        md[0] = -md[0]  # the plane's rate along d: n . d
        self._mo = np.concatenate(mo).astype(np.float32)
        self._md = np.concatenate(md).astype(np.float32)
        self._index = np.arange(P, dtype=np.uint32)[:, None]
        self.chunk, self.chunk_reason = chunk_rays(self.scratch_bytes_per_ray(), this_machine().L2)
        self._prim = np.concatenate((p0, e1, e2), axis=1).T.copy()  # (9, P) float64 for the refit
        # Scratch buffers per thread: renders running in threads share one scene.
        self._scratch = threading.local()
        single_threaded_blas()

    def __getstate__(self):
        state = self.__dict__.copy()
        del state["_scratch"]
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._scratch = threading.local()
        single_threaded_blas()

    def scratch_bytes_per_ray(self) -> int:
        """Bytes of :meth:`_buffers` per ray: origin and direction, both matrix products, the
        per-primitive test values and their flags."""
        return 4 * (4 + 3) + 4 * 2 * len(self._mo) + 5 * self.num_primitives

    def _buffers(self, m):
        work = getattr(self._scratch, "work", None)
        if work is None or work[0].shape[1] != m:
            P = self.num_primitives
            rows = len(self._mo)
            work = (np.empty((4, m), np.float32), np.empty((3, m), np.float32),
                    np.empty((rows, m), np.float32), np.empty((rows, m), np.float32),
                    np.empty((P, m), np.float32), np.empty((P, m), bool))
            if m == self.chunk:  # the full chunks' buffers are kept for the next call
                self._scratch.work = work
        return work

    def _closest_keys(self, o, d):
        """Packed (t, primitive) key of the nearest accepted primitive per ray (o, d: (3, m))."""
        P = self.num_primitives
        o4, d3, ao, ad, low, ok = self._buffers(o.shape[1])
        o4[:3] = o
        o4[3] = 1.0
        d3[...] = d
        np.matmul(self._mo, o4, out=ao)
        np.matmul(self._md, d3, out=ad)
        Q = self._quads
        t = ao[:P]
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            t /= ad[:P]
            # g = g(o) + t g'(d): two functions per parallelogram, three per triangle.
            g = ad[P:]
            m = g.shape[1]
            g[:2 * Q].reshape(2, Q, m).__imul__(t[:Q])
            g[2 * Q:].reshape(3, P - Q, m).__imul__(t[Q:])
            g += ao[P:]
            quad, tri = g[:2 * Q], g[2 * Q:]
            np.abs(quad, out=quad)
            np.maximum(quad[:Q], quad[Q:], out=low[:Q])
            np.less_equal(low[:Q], 0.5 + SMALL_BARY_EPS, out=ok[:Q])
            L = P - Q
            np.minimum(tri[:L], tri[L:2 * L], out=low[Q:])
            np.minimum(low[Q:], tri[2 * L:], out=low[Q:])
            np.greater_equal(low[Q:], -SMALL_BARY_EPS, out=ok[Q:])
        # Rejected pairs get t / 0 = +-inf or NaN (a masked copy is ~8x slower than this
        # division by a bool, and dividing by 1 leaves t exact).
        with np.errstate(divide="ignore", invalid="ignore"):
            np.divide(t, ok, out=t)
        key = t.view(np.uint32)
        key &= np.uint32(~((1 << self._bits) - 1) & 0xFFFFFFFF)
        key |= self._index
        return key.min(axis=0)

    def _refit(self, o, d, prim):
        """Float64 hits of rays (3, m) on their primitives ``prim``: (t, triangle, b1, b2)."""
        t, b1, b2 = _plane_coordinates(o, d, self._primitive_rows(prim))
        half = 2 * prim + (b1 + b2 > 1.0)  # the triangle: row of the (2P,) tables
        m = np.take(self._to_bary, half, axis=1, mode="wrap")
        u = m[0] + m[1] * b1 + m[2] * b2
        v = m[3] + m[4] * b1 + m[5] * b2
        return t, np.take(self._triangles, half), u, v

    def intersect(self, o, d, tmax=None):
        """Closest hit of each ray (same contract as :meth:`BVH.intersect`)."""
        o, d, tmax = _rays(o, d, tmax)
        n = o.shape[1]
        if not self.num_triangles or not n:
            return _no_hits(n)
        key, found, rows = self._candidates(o, d)
        if 2 * len(rows) >= n:
            # Most rays have a candidate (a room, open on a side or not): refit every ray,
            # the candidate-less ones on some primitive, and mask them out after. Each
            # ray's arithmetic is its own, so the hits are those a gathered refit gives,
            # without gathering the rays and scattering the hits back.
            tt, tri, u, v = self._refit(o, d, self._primitive(key))
            ok = (tt > 0.0) & (tt < tmax)
            if len(rows) < n:
                ok &= found
            if ok.all():
                return tt, tri, u, v
            return (np.where(ok, tt, np.inf), np.where(ok, tri, -1), np.where(ok, u, 0.0),
                    np.where(ok, v, 0.0))
        t, prim, b1, b2 = _no_hits(n)
        if len(rows):
            tt, tri, u, v = self._refit(np.take(o, rows, axis=1), np.take(d, rows, axis=1),
                                        self._primitive(np.take(key, rows)))
            ok = (tt > 0.0) & (tt < tmax[rows])
            rows = rows[ok]
            t[rows], prim[rows], b1[rows], b2[rows] = tt[ok], tri[ok], u[ok], v[ok]
        return t, prim, b1, b2

    def occluded(self, o, d, tmax=None):
        """(n,) bool: some triangle lies on the ray with ``0 < t < tmax`` (the rays whose
        :meth:`intersect` finds a hit; only ``t`` is refitted)."""
        o, d, tmax = _rays(o, d, tmax)
        n = o.shape[1]
        if not self.num_triangles or not n:
            return np.zeros(n, bool)
        key, found, rows = self._candidates(o, d)
        if 2 * len(rows) >= n:
            t = _plane_coordinates(o, d, self._primitive_rows(self._primitive(key)))[0]
            return (t > 0.0) & (t < tmax) & found
        occluded = np.zeros(n, bool)
        if len(rows):
            tri = self._primitive_rows(self._primitive(np.take(key, rows)))
            t = _plane_coordinates(np.take(o, rows, axis=1), np.take(d, rows, axis=1), tri)[0]
            occluded[rows] = (t > 0.0) & (t < np.take(tmax, rows))
        return occluded

    def _candidates(self, o, d):
        """Per ray (o, d: (3, n)) the packed key of its nearest float32 candidate, whether it
        has one, and the rays that do (indices)."""
        n = o.shape[1]
        key = np.empty(n, np.uint32)
        for s in range(0, n, self.chunk):
            sl = slice(s, s + self.chunk)
            key[sl] = self._closest_keys(o[:, sl], d[:, sl])
        found = key < np.uint32(0x7F800000)  # a finite, positive t
        return key, found, np.flatnonzero(found)

    def _primitive(self, key):
        """The primitive index packed in the low bits of ``key`` (any value where the key has
        no candidate: refits index with ``mode="wrap"``)."""
        return (key & np.uint32((1 << self._bits) - 1)).astype(np.int64)

    def _primitive_rows(self, prim):
        """(9, m) float64 ``p0``, ``e1``, ``e2`` of primitives ``prim``."""
        return np.take(self._prim, prim, axis=1, mode="wrap")   # "wrap": see BVH._step


def _no_hits(n: int):
    """``t``, triangle, ``b1``, ``b2`` of ``n`` rays that hit nothing."""
    return np.full(n, np.inf), np.full(n, -1, np.int64), np.zeros(n), np.zeros(n)


def chunk_rays(bytes_per_ray: int, l2: int | None) -> tuple[int, str]:
    """Rays per all-pairs chunk for ``bytes_per_ray`` of scratch and an L2 of ``l2`` bytes
    (None: unknown), and why: the largest power of two whose scratch fits in the L2, within
    :data:`SMALL_CHUNK_RANGE`.

    Examples
    --------
    >>> chunk_rays(550, 2 << 20)[0], chunk_rays(202, 2 << 20)[0], chunk_rays(550, None)[0]
    (2048, 8192, 4096)
    """
    low, high = SMALL_CHUNK_RANGE
    if not l2:
        return SMALL_CHUNK_DEFAULT, f"{SMALL_CHUNK_DEFAULT} rays (L2 unknown)"
    rays = high
    while rays > low and rays * bytes_per_ray > l2:
        rays //= 2
    scratch = f"{rays} rays x {bytes_per_ray} B of scratch = {format_size(rays * bytes_per_ray)}"
    fits = "within" if rays * bytes_per_ray <= l2 else "the floor, beyond"
    return rays, f"{scratch} ({fits} the {format_size(l2)} L2)"


def _parallelograms(tri_p: np.ndarray, rtol: float = 1e-9):
    """Pair the triangles that form parallelograms; every other triangle stays alone.

    Triangles (x, s, t) and (y, s, t), in any vertex order, sharing the edge s-t
    with ``x + y = s + t`` form the parallelogram x + b1 (s - x) + b2 (t - x),
    b1, b2 in [0, 1]; (x, s, t) is its half with ``b1 + b2 <= 1``.

    Returns
    -------
    p0, e1, e2 : (P, 3) arrays
        Origin and edges of each primitive (a lone triangle: its own p0, e1, e2), the
        parallelograms first.
    triangles : (P, 2) int64
        The triangle for ``b1 + b2 <= 1`` and for ``> 1`` (a lone triangle twice).
    to_bary : (P, 2, 2, 3) array
        Per triangle, the rows mapping (1, b1, b2) to its barycentrics of p1 and p2.
    quad : (P,) bool
        Which primitives are parallelograms.
    """
    T = len(tri_p)
    scale = max(float(np.abs(tri_p).max()), 1e-30) if T else 1.0
    pairs, used = [], np.zeros(T, bool)
    for i in range(T):
        for j in range(i + 1, T):
            if used[i] or used[j]:
                continue
            roles = _shared_edge(tri_p[i], tri_p[j], rtol * scale)
            if roles is not None:
                pairs.append((i, j) + roles)
                used[i] = used[j] = True
    p0, e1, e2, triangles, to_bary, quad = [], [], [], [], [], []
    # Weights of x, s, t (in the first half) and of s, t, y = s + t - x (in the second)
    # at the point x + b1 (s - x) + b2 (t - x), as rows over (1, b1, b2).
    first_weights = {"x": (1.0, -1.0, -1.0), "s": (0.0, 1.0, 0.0), "t": (0.0, 0.0, 1.0)}
    second_weights = {"y": (-1.0, 1.0, 1.0), "s": (1.0, 0.0, -1.0), "t": (1.0, -1.0, 0.0)}
    for i, j, roles_i, roles_j in pairs:
        x, s, t = (tri_p[i][roles_i.index(r)] for r in "xst")
        first = np.array([first_weights[r] for r in roles_i[1:]])
        second = np.array([second_weights[r] for r in roles_j[1:]])
        p0.append(x), e1.append(s - x), e2.append(t - x)
        triangles.append((i, j)), to_bary.append((first, second)), quad.append(True)
    # A lone triangle's own coordinates: barycentrics of p1, p2 are (b1, b2).
    own = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    for i in np.flatnonzero(~used):
        a, b, c = tri_p[i]
        p0.append(a), e1.append(b - a), e2.append(c - a)
        triangles.append((i, i)), to_bary.append((own, own)), quad.append(False)
    if not p0:
        return (np.zeros((0, 3)),) * 3 + (np.zeros((0, 2), np.int64), np.zeros((0, 2, 2, 3)),
                                          np.zeros(0, bool))
    return (np.array(p0), np.array(e1), np.array(e2), np.array(triangles, np.int64),
            np.array(to_bary), np.array(quad))


def _shared_edge(a: np.ndarray, b: np.ndarray, tol: float):
    """The roles of the vertices of triangles ``a`` and ``b`` (3, 3) if they form a parallelogram.

    They do when they share two vertices s and t (exactly equal) and their third
    vertices x (of ``a``) and y (of ``b``) satisfy ``x + y = s + t`` within ``tol``.
    Returns (roles of ``a``'s vertices, roles of ``b``'s) as strings over "xst" and
    "yst" in vertex order, or None.
    """
    match = [[k for k in range(3) if np.array_equal(a[i], b[k])] for i in range(3)]
    if sum(map(len, match)) != 2 or any(len(m) > 1 for m in match):
        return None
    shared = [i for i in range(3) if match[i]]
    roles_a = ["x"] * 3
    roles_b = ["y"] * 3
    for name, i in zip("st", shared):
        roles_a[i] = name
        roles_b[match[i][0]] = name
    x, s, t = (a[roles_a.index(r)] for r in "xst")
    y = b[roles_b.index("y")]
    if np.abs(x + y - s - t).max() > tol:
        return None
    return "".join(roles_a), "".join(roles_b)


# ----------------------------------------------------------------------
# Scenes with one big mesh in a room: the room's few triangles first


class SplitMesh:
    """The triangles of small shapes in a :class:`SmallMesh`, the rest in a :class:`BVH`.

    A large mesh standing in a room of rectangles is the common case: in one
    BVH the room's huge triangles overlap every ray, and their boxes are
    visited by all of them. Here the small part is intersected first, all
    pairs at once; its hit distance then bounds the BVH traversal, so a ray
    that meets a wall before the mesh's boxes is culled at the root, and a
    shadow ray already blocked by the room never enters the tree. Triangle
    indices in and out are those of the whole scene.

    Parameters
    ----------
    tri_p : (T, 3, 3) ndarray
        World-space triangle vertices.
    small : (T,) bool
        The triangles that go to the :class:`SmallMesh` (at most ``SMALL_MAX``).
    """

    def __init__(self, tri_p: np.ndarray, small: np.ndarray):
        tri_p = np.asarray(tri_p, np.float64).reshape(-1, 3, 3)
        self.num_triangles = len(tri_p)
        self.brute_force = False
        self._small_prim = np.flatnonzero(small)
        self._big_prim = np.flatnonzero(~small)
        self.small = SmallMesh(tri_p[self._small_prim])
        self.big = BVH(tri_p[self._big_prim])

    def intersect(self, o, d, tmax=None):
        """Closest hit of each ray (same contract as :meth:`BVH.intersect`)."""
        o, d, tmax = _row_rays(o, d, tmax)
        t, prim, b1, b2 = self.small.intersect(o, d, tmax)
        hit = prim >= 0
        prim[hit] = self._small_prim[prim[hit]]
        t_big, prim_big, b1_big, b2_big = self.big.intersect(o, d, np.where(hit, t, tmax))
        closer = np.flatnonzero(prim_big >= 0)   # only hits before the small part's
        t[closer], prim[closer] = t_big[closer], self._big_prim[prim_big[closer]]
        b1[closer], b2[closer] = b1_big[closer], b2_big[closer]
        return t, prim, b1, b2

    def occluded(self, o, d, tmax=None):
        """(n,) bool: some triangle lies on the ray with ``0 < t < tmax``."""
        o, d, tmax = _row_rays(o, d, tmax)
        occ = self.small.occluded(o, d, tmax)
        rows = np.flatnonzero(~occ)
        if len(rows):
            occ[rows] = self.big.occluded(np.take(o, rows, axis=0), np.take(d, rows, axis=0),
                                          np.take(tmax, rows))
        return occ


def _row_rays(o, d, tmax):
    """Rays as (n, 3) float64 rows and tmax as (n,) (inf for None), for row-wise subsets."""
    o = np.asarray(o, np.float64).reshape(-1, 3)
    d = np.asarray(d, np.float64).reshape(-1, 3)
    return o, d, np.broadcast_to(np.inf if tmax is None else np.asarray(tmax, np.float64), (len(o),))


def small_shapes(tri_shape: np.ndarray, max_triangles: int = SMALL_MAX) -> np.ndarray:
    """(T,) bool: the triangles of the fewest-triangle shapes, at most ``max_triangles`` in all."""
    shapes, counts = np.unique(tri_shape, return_counts=True)
    order = np.argsort(counts, kind="stable")
    taken = shapes[order][np.cumsum(counts[order]) <= max_triangles]
    return np.isin(tri_shape, taken)
