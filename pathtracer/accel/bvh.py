"""Bounding volume hierarchy over a triangle soup, traversed by wavefronts.

Build: binned SAH, one tree level at a time (every open node of a level is
split by the same handful of NumPy calls), then the binary tree is collapsed
into a 4-wide tree so that each traversal step tests four boxes at once.

Traversal: a ray never owns a Python loop iteration. A chunk of rays is
traversed breadth first: a work list of (ray, node) pairs, the root for every
ray at first, advances one tree level per iteration; it tests the triangles of
the listed leaves (float64), then replaces each inner node by the children
whose boxes (float32 slabs, conservatively dilated) the ray segment up to its
best hit so far overlaps. ~5 inner nodes and ~0.8 leaves per ray on the
benchmark mesh scene (82k triangles, 9 levels), 9 iterations at most. Rays
whose segment misses the tree's bounds never enter it; a work list longer
than ``MAX_PAIRS`` is halved, its halves traversed one after the other.

Triangles: Möller–Trumbore in float64 with a tiny barycentric tolerance, so
that a ray through an edge shared by two triangles hits at least one of them.
Hits with ``t <= 0`` are ignored (Mitsuba offsets ray origins instead of
using a ``tmin``).
"""
from __future__ import annotations

import numpy as np

WIDTH = 4  # children per node of the traversed tree
LEAF_SIZE = 4  # max triangles per leaf
NUM_BINS = 12  # SAH bins per axis
BRUTE_FORCE_MAX = 32  # up to this many triangles, test every triangle
CHUNK = 32768  # rays per traversal chunk
MAX_PAIRS = 1 << 18  # (ray, node) pairs traversed at once (bounds the work lists' memory)
BARY_EPS = 1e-10  # barycentric slack: closes cracks along shared edges
SLAB_EPS = 16 * 2.0 ** -24  # box dilation for float32 slabs, relative to |o| + scene size


def _build_binary(lo, hi, leaf_size):
    """Binned-SAH binary tree, built breadth first.

    Parameters
    ----------
    lo, hi : (T, 3) ndarray
        Triangle bounds.

    Returns
    -------
    dict of arrays: ``lo``, ``hi`` (N, 3) node boxes; ``left``, ``right``
    (N,) child ids (-1 for leaves); ``leaf`` (N,) leaf id (-1 for inner
    nodes); ``leaf_tris`` (L, leaf_size) triangle ids (-1 padding).
    """
    cen = 0.5 * (lo + hi)
    tris = np.arange(len(lo))  # triangle ids of the open nodes, grouped by node
    counts = np.array([len(lo)])
    ids = np.array([0])  # node id of each open node
    out = {k: [] for k in ("id", "lo", "hi", "left", "right", "leaf")}
    leaf_rows = []
    n_nodes, n_leaves = 1, 0
    while len(counts):
        starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
        seg = np.repeat(np.arange(len(counts)), counts)
        nlo = np.minimum.reduceat(lo[tris], starts)
        nhi = np.maximum.reduceat(hi[tris], starts)
        is_leaf = counts <= leaf_size
        side = np.zeros(len(tris), bool)
        split = ~is_leaf
        if split.any():
            side = _sah_side(tris, seg, starts, counts, split, lo, hi, cen)
        # Leaves: their triangle ids, padded to leaf_size per row.
        lf = np.flatnonzero(is_leaf)
        leaf_id = np.full(len(counts), -1)
        leaf_id[lf] = n_leaves + np.arange(len(lf))
        if len(lf):
            rows = np.full((len(lf), leaf_size), -1)
            in_leaf = is_leaf[seg]
            lseg = np.searchsorted(lf, seg[in_leaf])
            rows[lseg, np.arange(len(tris))[in_leaf] - starts[seg[in_leaf]]] = tris[in_leaf]
            leaf_rows.append(rows)
            n_leaves += len(lf)
        # Inner nodes: children numbered in order of their parent.
        sp = np.flatnonzero(split)
        left = np.full(len(counts), -1)
        right = np.full(len(counts), -1)
        left[sp] = n_nodes + 2 * np.arange(len(sp))
        right[sp] = left[sp] + 1
        n_nodes += 2 * len(sp)
        for k, v in (("id", ids), ("lo", nlo), ("hi", nhi), ("left", left),
                     ("right", right), ("leaf", leaf_id)):
            out[k].append(v)
        # Next level: the split nodes' triangles, regrouped by (node, side).
        keep = split[seg]
        rank = np.cumsum(split) - 1  # index among split nodes
        key = 2 * rank[seg[keep]] + side[keep]
        order = np.argsort(key, kind="stable")
        tris = tris[keep][order]
        counts = np.bincount(key, minlength=2 * len(sp))
        ids = np.stack((left[sp], right[sp]), axis=1).ravel()
    order = np.argsort(np.concatenate(out["id"]))
    tree = {k: np.concatenate(v)[order] for k, v in out.items() if k != "id"}
    tree["leaf_tris"] = np.concatenate(leaf_rows)
    return tree


def _sah_side(tris, seg, starts, counts, split, lo, hi, cen):
    """For every triangle of the open nodes: False = left child, True = right.

    Only nodes with ``split`` set matter. Each is cut at the bin boundary of
    lowest SAH cost (area(L) * n(L) + area(R) * n(R)) over three axes; when
    every centroid falls in one bin, the node is halved in list order.
    """
    S, B = len(counts), NUM_BINS
    c = cen[tris]
    cmin = np.minimum.reduceat(c, starts)
    ext = np.maximum.reduceat(c, starts) - cmin
    scale = B * (1 - 1e-9) / np.where(ext > 0, ext, 1.0)
    bins = ((c - cmin[seg]) * scale[seg]).astype(np.int64)  # (m, 3)
    np.clip(bins, 0, B - 1, out=bins)
    tlo, thi = lo[tris], hi[tris]
    best_cost = np.full(S, np.inf)
    best_axis = np.zeros(S, np.int64)
    best_k = np.zeros(S, np.int64)
    with np.errstate(invalid="ignore"):
        for a in range(3):
            key = seg * B + bins[:, a]
            cnt = np.bincount(key, minlength=S * B).reshape(S, B)
            blo = np.full((S * B, 3), np.inf)
            bhi = np.full((S * B, 3), -np.inf)
            np.minimum.at(blo, key, tlo)
            np.maximum.at(bhi, key, thi)
            blo, bhi = blo.reshape(S, B, 3), bhi.reshape(S, B, 3)
            # Boxes and counts left of boundary k (k = 1..B-1) and right of it.
            llo = np.minimum.accumulate(blo, axis=1)[:, :-1]
            lhi = np.maximum.accumulate(bhi, axis=1)[:, :-1]
            rlo = np.minimum.accumulate(blo[:, ::-1], axis=1)[:, ::-1][:, 1:]
            rhi = np.maximum.accumulate(bhi[:, ::-1], axis=1)[:, ::-1][:, 1:]
            nl = np.cumsum(cnt, axis=1)[:, :-1]
            nr = counts[:, None] - nl
            cost = _half_area(llo, lhi) * nl + _half_area(rlo, rhi) * nr
            cost = np.where((nl > 0) & (nr > 0), cost, np.inf)
            k = np.argmin(cost, axis=1)
            ck = cost[np.arange(S), k]
            better = ck < best_cost
            best_cost[better] = ck[better]
            best_axis[better] = a
            best_k[better] = k[better] + 1
    side = bins[np.arange(len(tris)), best_axis[seg]] >= best_k[seg]
    # Fallback for nodes SAH could not cut: halve the list.
    stuck = np.isinf(best_cost) & split
    if stuck.any():
        m = stuck[seg]
        pos = np.arange(len(tris)) - starts[seg]
        side[m] = pos[m] >= (counts[seg[m]] // 2)
    return side


def _half_area(lo, hi):
    e = hi - lo
    return e[..., 0] * e[..., 1] + e[..., 1] * e[..., 2] + e[..., 2] * e[..., 0]


def _collapse(tree):
    """Turn the binary tree into a WIDTH-wide one (grandchildren become children).

    Returns
    -------
    box : (N, 6, 4) float64
        Rows lo x, y, z, hi x, y, z of each child slot; NaN for empty slots
        (NaN makes the slab test fail).
    child : (N, 4) int64
        >= 0: wide node id; < 0: leaf ``~child``.
    """
    left, right = tree["left"], tree["right"]
    front = np.array([0])  # binary ids of wide nodes being created
    if left[0] < 0:  # root is a leaf: one wide node holding it
        slots = np.array([[0, -1, -1, -1]])
        front = None
    boxes, children = [], []
    n_wide = 1
    while front is not None and len(front):
        l, r = left[front], right[front]
        ll = np.where(left[l] >= 0, left[l], l)
        lr = np.where(left[l] >= 0, right[l], -1)
        rl = np.where(left[r] >= 0, left[r], r)
        rr = np.where(left[r] >= 0, right[r], -1)
        slots = np.stack((ll, lr, rl, rr), axis=1)
        box, child, inner = _slots(tree, slots, n_wide)
        boxes.append(box)
        children.append(child)
        front = slots[inner]  # row-major: the order their wide ids were given
        n_wide += len(front)
    if not boxes:
        box, child, _ = _slots(tree, slots, 1)
        boxes, children = [box], [child]
    return np.concatenate(boxes), np.concatenate(children)


def _slots(tree, slots, next_id):
    """Boxes, child codes and inner-child mask of a batch of wide nodes.

    ``slots`` holds binary node ids of the children (-1: empty slot).
    """
    valid = slots >= 0
    s = np.maximum(slots, 0)
    lo = np.where(valid[..., None], tree["lo"][s], np.nan)
    hi = np.where(valid[..., None], tree["hi"][s], np.nan)
    box = np.concatenate((lo, hi), axis=2).transpose(0, 2, 1)
    inner = valid & (tree["left"][s] >= 0)
    child = np.zeros(slots.shape, np.int64)
    # Inner children get wide ids in row-major order (matches the next front).
    child[inner] = next_id + np.arange(int(inner.sum()))
    is_leaf = valid & ~inner
    child[is_leaf] = ~tree["leaf"][s[is_leaf]]
    return box, child, inner


def _moller_trumbore(o, d, tri, tmax):
    """Intersect rays with groups of triangles (pairs along the last axis).

    Parameters
    ----------
    o, d : (3, m) ndarray
        Ray origins and directions, one column per ray.
    tri : (9, k, m) or (9, k, 1) ndarray
        For each ray, ``k`` triangles as rows p0, e1 = p1 - p0, e2 = p2 - p0
        (NaN entries are padding and never hit).
    tmax : (m,) ndarray
        Only hits with ``0 < t < tmax`` count.

    Returns
    -------
    t, b1, b2 : (k, m) ndarray
        Ray parameter (inf where missed) and barycentrics of p1 and p2.
    """
    t, b1, b2 = _plane_coordinates(o, d, tri)
    with np.errstate(invalid="ignore"):
        # Comparisons with NaN are False: degenerate and padding triangles miss.
        ok = (b1 >= -BARY_EPS) & (b2 >= -BARY_EPS) & (b1 + b2 <= 1.0 + BARY_EPS)
        ok &= (t > 0.0) & (t < tmax)
    return np.where(ok, t, np.inf), b1, b2


def _plane_coordinates(o, d, tri):
    """Möller–Trumbore's ray parameter ``t`` and edge coordinates ``b1``, ``b2`` of the
    point where rays (o, d: (3, m)) meet the planes of ``tri`` (rows p0, e1, e2; any
    shape that broadcasts against (m,)), with no test of whether it lies inside.
    """
    ox, oy, oz = o
    dx, dy, dz = d
    e1x, e1y, e1z, e2x, e2y, e2z = tri[3:]
    with np.errstate(divide="ignore", invalid="ignore"):
        px = dy * e2z - dz * e2y
        py = dz * e2x - dx * e2z
        pz = dx * e2y - dy * e2x
        inv = 1.0 / (e1x * px + e1y * py + e1z * pz)
        sx = ox - tri[0]
        sy = oy - tri[1]
        sz = oz - tri[2]
        b1 = (sx * px + sy * py + sz * pz) * inv
        qx = sy * e1z - sz * e1y
        qy = sz * e1x - sx * e1z
        qz = sx * e1y - sy * e1x
        b2 = (dx * qx + dy * qy + dz * qz) * inv
        t = (e2x * qx + e2y * qy + e2z * qz) * inv
    return t, b1, b2


class BVH:
    """Triangle acceleration structure queried by whole arrays of rays.

    Arrays used by traversal keep the (ray, node) pairs on their *last* axis
    (e.g. boxes as (24, m)): NumPy then runs long contiguous loops instead of
    many loops of length 4.

    Parameters
    ----------
    tri_p : (T, 3, 3) ndarray
        World-space triangle vertices.
    brute_force_max : int
        With at most this many triangles every ray tests every triangle
        (one leaf holding all of them), which beats traversal for tiny scenes.
    """

    def __init__(self, tri_p: np.ndarray, brute_force_max: int = BRUTE_FORCE_MAX):
        tri_p = np.asarray(tri_p, np.float64).reshape(-1, 3, 3)
        self.num_triangles = T = len(tri_p)
        self.brute_force = T <= brute_force_max
        # Brute force makes (T, rays) temporaries: keep them near CHUNK * 4.
        self._chunk = max(64, CHUNK * 4 // max(T, 4)) if self.brute_force else CHUNK
        if self.brute_force:
            rows = np.arange(T)[None, :]
        else:
            rows = self._build_tree(tri_p.min(axis=1), tri_p.max(axis=1))
        # Leaf triangles as (9, leaves, k): component c of slot j of leaf l at [c, l, j], so
        # that a leaf's k values of a component share a cache line.
        data = _tri_data(tri_p)
        tri = np.where(rows[..., None] >= 0, data[np.maximum(rows, 0)], np.nan)
        self._leaf_tri = np.ascontiguousarray(tri.transpose(2, 0, 1))
        self._leaf_prim = np.ascontiguousarray(rows.T)
        self._leaf_k = rows.shape[1]

    def _init_over_boxes(self, lo, hi, chunk: int) -> None:
        """The tree's attributes over primitives known only by their boxes ``lo``, ``hi``
        (P, 3): a subclass that tests its own primitives in ``_leaf_test`` (curve pieces,
        SDF voxels); ``chunk`` rays per leaf test bounds its temporaries."""
        n = len(lo)
        self.num_triangles = n            # the traversal's name for "primitives"
        self.brute_force = n <= 8
        self._chunk = chunk
        rows = np.arange(n)[None, :] if self.brute_force else self._build_tree(lo, hi)
        self._leaf_prim = np.ascontiguousarray(rows.T)       # (slots, leaves), -1 padding
        self._leaf_k = rows.shape[1]

    def _build_tree(self, lo, hi) -> np.ndarray:
        """Build the wide tree over primitive bounds ``lo``, ``hi`` (P, 3); returns the
        (leaves, LEAF_SIZE) primitive ids of the leaves (-1 padding)."""
        tree = _build_binary(lo, hi, LEAF_SIZE)
        box, child = _collapse(tree)
        self.num_nodes = len(child)
        # float32 boxes rounded outwards; the slab rounding is covered by
        # the per-ray dilation of _ray9. Row 4 * c + j: coordinate c
        # (lo x, y, z, hi x, y, z) of child slot j.
        b32 = box.astype(np.float32)
        lo32, hi32 = b32[:, :3], b32[:, 3:]  # views
        lo32[...] = np.where(lo32 > box[:, :3], np.nextafter(lo32, -np.inf), lo32)
        hi32[...] = np.where(hi32 < box[:, 3:], np.nextafter(hi32, np.inf), hi32)
        self._box = np.ascontiguousarray(b32.reshape(len(child), -1).T)
        self._child = np.ascontiguousarray(child.T)
        self._scene_max = float(max(np.abs(lo).max(), np.abs(hi).max()))
        margin = 1e-9 * (self._scene_max + 1.0)
        self._bounds = np.stack((lo.min(axis=0) - margin, hi.max(axis=0) + margin))
        return tree["leaf_tris"]

    # ------------------------------------------------------------------
    def intersect(self, o, d, tmax=None):
        """Closest hit of each ray.

        Parameters
        ----------
        o, d : (n, 3) float64
            Origins and directions (need not be unit length; ``t`` is the ray
            parameter, the distance when ``d`` is unit).
        tmax : (n,) float64 or float or None
            Only hits with ``0 < t < tmax`` count; None means infinity.

        Returns
        -------
        t : (n,) float64, inf on a miss
        prim : (n,) int64, triangle index, -1 on a miss
        b1, b2 : (n,) float64, barycentrics of vertices p1 and p2
        """
        o, d, tmax = _rays(o, d, tmax)
        n = o.shape[1]
        t, prim, b1, b2 = tmax.copy(), np.full(n, -1, np.int64), np.zeros(n), np.zeros(n)
        self._in_chunks(self._closest, o, d, t, prim, b1, b2)
        t[prim < 0] = np.inf
        return t, prim, b1, b2

    def occluded(self, o, d, tmax=None):
        """(n,) bool: the ray hits some triangle with ``0 < t < tmax`` (None: inf)."""
        o, d, tmax = _rays(o, d, tmax)
        occ = np.zeros(o.shape[1], bool)
        self._in_chunks(self._any, o, d, tmax, occ)
        return occ

    def _in_chunks(self, query, o, d, tmax, *out):
        """``query(o, d, tmax, *out)`` on the rays that may meet the tree, ``CHUNK`` at a time.

        ``tmax`` and ``out`` are per-ray arrays that ``query`` updates in place; the rays
        that :meth:`_candidates` culls keep their values.
        """
        rows = self._candidates(o, d, tmax)
        every = len(rows) == o.shape[1]
        arrays = (tmax,) + out
        if not every:   # only the rays that may meet the mesh, as a batch of their own
            o, d = np.take(o, rows, axis=1), np.take(d, rows, axis=1)
            arrays = tuple(np.take(a, rows) for a in arrays)
        for s in range(0, len(rows), self._chunk):
            sl = slice(s, s + self._chunk)
            query(o[:, sl], d[:, sl], *(a[sl] for a in arrays))
        if not every:
            for full, part in zip((tmax,) + out, arrays):
                full[rows] = part

    def _candidates(self, o, d, tmax) -> np.ndarray:
        """Indices of the rays (o, d: (3, n)) whose segment ``[0, tmax]`` meets the tree's
        bounds, dilated by a relative 1e-9 (float64: a conservative test).

        In a mesh-in-a-room scene ~70 % of the rays miss the mesh's bounds: culled here
        by one slab test, they cost no float32 ray set-up and no first tree level.
        """
        n = o.shape[1]
        if self.brute_force or not self.num_triangles or not n:
            return np.arange(n) if self.num_triangles else np.zeros(0, np.int64)
        near, far = np.zeros(n), tmax.copy()
        with np.errstate(over="ignore"):
            for a in range(3):
                inv = 1.0 / np.where(np.abs(d[a]) < 1e-30, 1e-30, d[a])   # no 0 * inf
                t0 = (self._bounds[0, a] - o[a]) * inv
                t1 = (self._bounds[1, a] - o[a]) * inv
                np.maximum(near, np.minimum(t0, t1), out=near)
                np.minimum(far, np.maximum(t0, t1), out=far)
        return np.flatnonzero(near <= far)

    # ------------------------------------------------------------------
    def _leaf_test(self, o, d, r, leaf, tbest):
        """Best hit of each (ray r, leaf) pair -> (t, prim, b1, b2), t inf if none.

        ``r = None`` tests every ray against leaf 0 by broadcasting (brute force).
        """
        k = self._leaf_k
        if r is None:
            tri = self._leaf_tri[:, 0, :, None]
            leaf = np.zeros(o.shape[1], np.int64)
            tt, u, v = _moller_trumbore(o, d, tri, tbest)
        else:
            # Gathered as (9, m, k) (few cache lines per pair), used as (9, k, m).
            tri = np.take(self._leaf_tri, leaf, axis=1).transpose(0, 2, 1).copy()
            tt, u, v = _moller_trumbore(np.take(o, r, axis=1, mode="wrap"),
                                        np.take(d, r, axis=1, mode="wrap"), tri, tbest[r])
        if k > 8:
            j = np.argmin(tt, axis=0)
        else:  # a few row-wise comparisons beat argmin along a short axis
            j = np.zeros(tt.shape[1], np.int64)
            best = tt[0].copy()
            for i in range(1, k):
                c = tt[i] < best
                best[c] = tt[i][c]
                j[c] = i
        col = np.arange(tt.shape[1])
        return tt[j, col], self._leaf_prim[j, leaf], u[j, col], v[j, col]

    def _step(self, ray9, tbest, pr, pn):
        """Slab test (float32) of all child boxes of the pairs (ray pr, node pn).

        Returns
        -------
        hit : (WIDTH, m) bool
            The ray segment ``[0, best t]`` overlaps the (dilated) box.
        """
        # mode="wrap" (the indices are valid either way): NumPy's float32 gather along
        # axis 1 then runs 1.6x faster than with its default bounds check.
        box = np.take(self._box, pn, axis=1, mode="wrap").reshape(6, WIDTH, -1)
        rd = np.take(ray9, pr, axis=1, mode="wrap")
        t0 = np.empty(box.shape[1:], np.float32)
        t1, tmp, tn, tf = (np.empty_like(t0) for _ in range(4))
        for a in range(3):
            np.multiply(box[a], rd[a], out=t0)
            t0 += rd[a + 3]
            np.multiply(box[a + 3], rd[a], out=t1)
            t1 += rd[a + 6]
            if a == 0:
                np.minimum(t0, t1, out=tn)
                np.maximum(t0, t1, out=tf)
            else:
                np.minimum(t0, t1, out=tmp)
                np.maximum(t0, t1, out=t0)
                np.maximum(tn, tmp, out=tn)
                np.minimum(tf, t0, out=tf)
        np.maximum(tn, 0.0, out=tn)
        # Rounding tbest to float32 must not shorten the ray.
        tb = np.take(tbest, pr).astype(np.float32)
        tb *= np.float32(1 + 2.0 ** -20)
        np.minimum(tf, tb, out=tf)
        return tn <= tf

    def _closest(self, o, d, tbest, prim, b1, b2):
        """Closest-hit traversal of one chunk; updates the outputs in place."""
        if self.brute_force:
            t, p, u, v = self._leaf_test(o, d, None, None, tbest)
            hit = t < np.inf
            tbest[hit], prim[hit], b1[hit], b2[hit] = t[hit], p[hit], u[hit], v[hit]
            return

        def on_hit(r, t, p, u, v):
            tbest[r], prim[r], b1[r], b2[r] = t, p, u, v

        self._traverse(o, d, tbest, on_hit)

    def _any(self, o, d, tmax, occ):
        """Any-hit traversal of one chunk; sets ``occ`` in place."""
        if self.brute_force:
            occ |= self._leaf_test(o, d, None, None, tmax)[0] < np.inf
            return
        tmax = tmax.copy()

        def on_hit(r, t, p, u, v):
            occ[r] = True
            tmax[r] = -1.0  # no box overlaps [0, -1]: the ray's other pairs end

        self._traverse(o, d, tmax, on_hit)

    def _traverse(self, o, d, tbest, on_hit):
        """Breadth-first traversal of one chunk of rays, all rays at once.

        Leaf hits closer than ``tbest`` are reported as ``on_hit(rays, t, prim, b1,
        b2)`` (each ray's nearest of an iteration, the first on ties), which may
        shorten ``tbest``. A work list holds (ray, node) pairs, at first the root for
        every ray; an iteration tests its leaves, then replaces every inner node by
        the children whose boxes the ray segment ``[0, tbest]`` overlaps (``tbest``
        already shortened by this iteration's leaves). A list longer than
        :data:`MAX_PAIRS` is halved and its halves traversed one after the other, so
        memory stays bounded when many boxes overlap; a pair made stale by a shorter
        ``tbest`` costs a test, never a wrong hit (leaves and boxes are tested
        against the current ``tbest``).

        Depth first, with a stack per ray popped one entry per iteration, rays visit
        nodes near to far and test fewer of them, but every iteration costs ~40 NumPy
        calls however few rays are still active, and the slowest ray of a chunk needs
        ~60 iterations against the tree's ~9 levels: on the benchmark mesh scene
        breadth first is 2.4x faster (docs/performance.md).
        """
        ray9 = _ray9(o, d, self._scene_max)
        n = o.shape[1]
        work = [(np.arange(n), np.zeros(n, np.int64))]   # every ray at the root
        while work:
            ray, node = work.pop()
            if len(ray) > MAX_PAIRS:
                half = len(ray) // 2
                work += [(ray[half:], node[half:]), (ray[:half], node[:half])]
                continue
            is_leaf = node < 0
            if is_leaf.any():
                leaf = np.flatnonzero(is_leaf)
                lr = np.take(ray, leaf)
                t, p, u, v = self._leaf_test(o, d, lr, ~np.take(node, leaf), tbest)
                h = np.flatnonzero(t < np.inf)
                if len(h):
                    order = h[np.lexsort((t[h], lr[h]))]
                    ro = lr[order]
                    nearest = order[np.r_[True, ro[1:] != ro[:-1]]]
                    on_hit(lr[nearest], t[nearest], p[nearest], u[nearest], v[nearest])
                inner = np.flatnonzero(~is_leaf)
                ray, node = np.take(ray, inner), np.take(node, inner)
                if not len(ray):
                    continue
            hit = self._step(ray9, tbest, ray, node)
            pick = np.flatnonzero(hit)  # (slot, pair) flattened: slot-major
            if len(pick):
                work.append((np.take(ray, pick % len(ray)),
                             np.take(np.take(self._child, node, axis=1), pick)))


def _tri_data(tri_p: np.ndarray) -> np.ndarray:
    """Rows (p0, e1, e2) of each triangle as (T, 9) float64."""
    p0 = tri_p[:, 0]
    return np.concatenate((p0, tri_p[:, 1] - p0, tri_p[:, 2] - p0), axis=1)


def _rays(o, d, tmax):
    """Rays as (3, n) float64 component rows, and tmax as (n,)."""
    o = np.ascontiguousarray(np.asarray(o, np.float64).reshape(-1, 3).T)
    d = np.ascontiguousarray(np.asarray(d, np.float64).reshape(-1, 3).T)
    n = o.shape[1]
    if tmax is None:
        tmax = np.full(n, np.inf)
    else:
        tmax = np.array(np.broadcast_to(np.asarray(tmax, np.float64), (n,)))
    return o, d, tmax


def _ray9(o, d, scene_max):
    """Per ray, float32 slab coefficients ``(1/d, -(o + e)/d, -(o - e)/d)`` as (9, n).

    The slab test computes ``lo * inv + off_lo`` and ``hi * inv + off_hi``:
    with ``e`` > 0 that is the exact slab test of the box dilated by ``e`` on
    every side, whatever the sign of ``d``. ``e`` exceeds the float32 rounding
    of the whole computation (a few ulps of ``|o| + |box|``), so a ray that
    meets a box in exact arithmetic is never culled. Zero direction
    components become tiny ones so that ``0 * inf`` cannot make NaNs.
    """
    d = np.where(np.abs(d) < 1e-30, 1e-30, d)
    inv = 1.0 / d
    e = SLAB_EPS * (np.abs(o).max(axis=0) + scene_max + 1e-30)
    return np.concatenate((inv, -(o + e) * inv, -(o - e) * inv)).astype(np.float32)
