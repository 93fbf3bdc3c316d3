r"""Mitsuba's ``sdfgrid`` shape: the zero set of a signed distance field sampled on a grid.

The ``.vol`` file (one channel, :mod:`pathtracer.io.vol`) holds :math:`N_x \times N_y
\times N_z` values; value :math:`(i, j, k)` sits at the object-space point
:math:`(i / (N_x - 1), j / (N_y - 1), k / (N_z - 1))`, so the grid's nodes span the unit
cube :math:`[0, 1]^3` (the box stored in the file is ignored) and ``to_world`` places it.
Below, points are in *grid coordinates* :math:`g = p_{object} (N - 1)`, where node
:math:`(i, j, k)` is the integer point and voxel :math:`v` the cube :math:`[v, v + 1]`.

Field. :math:`F(g)` is the trilinear interpolation of the nodes, with :math:`g` clamped
to the grid (Dr.Jit's linear, clamped texture, which Mitsuba evaluates). In a voxel,
with local coordinates :math:`(x, y, z) \in [0, 1]^3` and corner values
:math:`s_{abc}`,

.. math::

    f = a_0 + a_1 x + a_2 y + a_3 z + a_4 x y + a_5 y z + a_6 x z + a_7 x y z,

    a_0 = s_{000},\ a_1 = s_{100} - s_{000},\ a_2 = s_{010} - s_{000},\
    a_3 = s_{001} - s_{000},\ a_4 = s_{110} - s_{100} - s_{010} + s_{000},

    a_5 = s_{011} - s_{010} - s_{001} + s_{000},\ a_6 = s_{101} - s_{100} - s_{001} + s_{000},

    a_7 = s_{111} - s_{110} - s_{101} - s_{011} + s_{100} + s_{010} + s_{001} - s_{000}.

Voxels. Only *occupied* voxels are primitives: those whose eight corners are neither all
> 0 nor all < 0 (elsewhere the convex combination cannot vanish). Their bounds in the
tree are the tight boxes of Hansson-Söderlund and Akenine-Möller (2023), as Mitsuba's: the
box of the zero corners and of the points where the field changes sign along the twelve
edges. The range of the zero set along an axis ends where one of the edge lines
crosses zero, so the box holds the voxel's whole surface.

Intersection (Mitsuba's, after Hansson-Söderlund, Evans and Akenine-Möller 2022, Marmitt
et al. 2004), per (ray, occupied voxel): clip the ray to the *whole* voxel,
:math:`[t_0, t_1]` with :math:`t_0 \ge 0` (a ray with :math:`t_0 = t_1` misses); with the
local origin :math:`q = o + t_0 d - v` the field along the ray is the cubic
:math:`f(s) = c_3 s^3 + c_2 s^2 + c_1 s + c_0`, :math:`s \in [0, t_1 - t_0]`:

.. math::

    c_0 = f(q),\quad
    c_1 = a_1 d_x + a_2 d_y + a_3 d_z + a_4 (q_x d_y + q_y d_x) + a_5 (q_y d_z + q_z d_y)
          + a_6 (q_x d_z + q_z d_x) + a_7 (q_x q_y d_z + q_x d_y q_z + d_x q_y q_z),

    c_2 = a_4 d_x d_y + a_5 d_y d_z + a_6 d_x d_z + a_7 (q_x d_y d_z + d_x q_y d_z + d_x d_y q_z),
    \quad c_3 = a_7 d_x d_y d_z.

The roots of :math:`f'` cut the interval into monotone pieces; the first piece whose ends
have :math:`f_{near} f_{far} \le 0` holds the hit (no sign change, e.g. a ray that only
touches the surface, is a miss). The root is refined by regula falsi, stopped as Mitsuba
stops it (bracket narrower than :data:`SOLVE_EPSILON` in ray parameter, or
:data:`SOLVE_ITERATIONS` steps), so that the hit is Mitsuba's iterate, not the exact root.
The hit counts when :math:`0 \le t_0 + s < t_{max}`; the closest over voxels wins.

Normals. ``p = o + t d`` is the hit. The geometric normal is the gradient of the field
in voxel :math:`\lfloor g \rfloor` (truncated, as Mitsuba), whose components are the
differences across the voxel, e.g. :math:`(F(v_x + 1, g_y, g_z) - F(v_x, g_y, g_z))
(N_x - 1)`: the exact gradient of the trilinear piece (discontinuous across voxel faces).
``normals="analytic"`` shades with it; ``"smooth"`` (the default) with the normal of
Hansson-Söderlund et al. (2022): the unit gradients of the eight voxels around the node
:math:`r = \mathrm{round}(g)`, i.e. voxels :math:`r - 1 + \{0, 1\}^3` (a voxel with a
negative index counts as zero), blended trilinearly with weights
:math:`u = g - r + \tfrac12` (1 along an axis whose lower four voxels are all outside,
0 where the upper four are). A voxel's gradient component along an axis depends only on
its index along that axis, so nine field lookups give all eight gradients. Both normals
go to world space by the inverse transpose of ``to_world`` and are normalised; neither is
flipped towards the ray (the field is positive outside, so the normal points outwards).

As in Mitsuba: no texture coordinates (uv is (0, 0)), ``dp/du = dp/dv = 0``, surface area
0, so no area emitter. ``to_world`` of the shape itself may only scale and translate (Mitsuba
warns on a rotation and its voxel bounds are then wrong: use ``shapegroup`` + ``instance``).
The loader refuses grids whose x and z resolutions differ: Mitsuba 3.9.1 swaps them in its
voxel size and voxel numbering (such a grid's hits are lost there), so nothing could be
compared; this module itself handles any resolution.
"""
from __future__ import annotations

import os

import numpy as np

from ..accel.bvh import BVH
from ..core.vec import normalize
from ..io.vol import VolFormatError, read_vol
from ..scene import transform
from ..scene.properties import Props, find_file
from ..scene.registry import register

#: Regula falsi stops when its bracket is narrower than this (ray parameter), as Mitsuba's.
SOLVE_EPSILON = 1e-5
#: ... or after this many steps (Mitsuba's loop runs while its counter, incremented first,
#: is at most 50).
SOLVE_ITERATIONS = 51
#: Normal modes, as Mitsuba spells them.
NORMAL_MODES = ("smooth", "analytic")
#: (ray, voxel) pairs tested at once.
PIECE = 1 << 16
#: Padding of the tight voxel boxes (grid units): rounding of the edge crossings must not
#: cull a hit.
BOX_PAD = 1e-7

# Corner c of a voxel has offset (c & 1, (c >> 1) & 1, (c >> 2) & 1).
_CORNERS = np.array([[c & 1, (c >> 1) & 1, (c >> 2) & 1] for c in range(8)])
_EDGES = [(c, c | (1 << axis)) for c in range(8) for axis in range(3) if not c & (1 << axis)]


class SDFGridError(ValueError):
    """A grid that cannot be a shape; the loader adds the scene location."""


def field(data: np.ndarray, g: np.ndarray) -> np.ndarray:
    """The clamped trilinear interpolation ``F`` of ``data`` (z, y, x) at grid points ``g`` (m, 3)."""
    res = np.array([data.shape[2], data.shape[1], data.shape[0]])
    g = np.clip(g, 0.0, res - 1)
    # The lower node is at most N - 2 (a point on the last node weighs it by 1).
    i0 = np.minimum(np.floor(g).astype(np.int64), res - 2)
    w = g - i0
    out = np.zeros(len(g))
    for c in range(8):
        a, b, e = _CORNERS[c]
        weight = ((w[:, 0] if a else 1.0 - w[:, 0]) * (w[:, 1] if b else 1.0 - w[:, 1])
                  * (w[:, 2] if e else 1.0 - w[:, 2]))
        out += weight * data[i0[:, 2] + e, i0[:, 1] + b, i0[:, 0] + a]
    return out


def face_gradients(data: np.ndarray, g: np.ndarray, index: np.ndarray, axis: int) -> np.ndarray:
    """Component ``axis`` of the gradient (object space) of voxels whose index along
    ``axis`` is ``index`` (m,), the other coordinates those of ``g`` (m, 3)."""
    res = data.shape[2 - axis]
    hi, lo = g.copy(), g.copy()
    hi[:, axis], lo[:, axis] = index + 1, index
    return (field(data, hi) - field(data, lo)) * (res - 1)


def polynomial(corners: np.ndarray) -> np.ndarray:
    """Coefficients ``a_0 .. a_7`` (P, 8) of the trilinear polynomial of voxels whose
    corner values are ``corners`` (P, 8), corner order as :data:`_CORNERS`."""
    s = [corners[:, c] for c in range(8)]
    return np.stack([s[0], s[1] - s[0], s[2] - s[0], s[4] - s[0],
                     s[3] - s[1] - s[2] + s[0], s[6] - s[2] - s[4] + s[0],
                     s[5] - s[1] - s[4] + s[0],
                     s[7] - s[3] - s[5] - s[6] + s[1] + s[2] + s[4] - s[0]], axis=1)


def tight_boxes(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Local bounds (lo, hi) in [0, 1]^3, each (P, 3), of the zero sets of voxels with
    corner values ``corners`` (P, 8): the box of the zero corners and the edges' sign
    changes (see the module docstring)."""
    lo = np.full((len(corners), 3), np.inf)
    hi = np.full((len(corners), 3), -np.inf)
    for c in range(8):
        zero = corners[:, c] == 0
        lo = np.where(zero[:, None], np.minimum(lo, _CORNERS[c]), lo)
        hi = np.where(zero[:, None], np.maximum(hi, _CORNERS[c]), hi)
    with np.errstate(divide="ignore", invalid="ignore"):
        for c1, c2 in _EDGES:
            f1, f2 = corners[:, c1], corners[:, c2]
            cross = (f1 * f2 <= 0) & (f1 != f2)
            point = _CORNERS[c1] + (f1 / (f1 - f2))[:, None] * (_CORNERS[c2] - _CORNERS[c1])
            lo = np.where(cross[:, None], np.minimum(lo, point), lo)
            hi = np.where(cross[:, None], np.maximum(hi, point), hi)
    return np.clip(lo - BOX_PAD, 0.0, 1.0), np.clip(hi + BOX_PAD, 0.0, 1.0)


def _cubic(c, s):
    """``c[3] s^3 + c[2] s^2 + c[1] s + c[0]`` (Horner)."""
    return ((c[3] * s + c[2]) * s + c[1]) * s + c[0]


def voxel_hits(o, d, tmax, coeff, voxel):
    """Ray parameter of each (ray, voxel) pair's hit, inf where none (see the module docstring).

    Parameters
    ----------
    o, d : (3, m) rays in grid coordinates.
    tmax : (m,) only hits below it count.
    coeff : (8, m) the voxels' trilinear coefficients (:func:`polynomial`).
    voxel : (3, m) the voxels' lower corners.
    """
    m = o.shape[1]
    out = np.full(m, np.inf)
    safe = np.where(np.abs(d) < 1e-30, np.where(d < 0, -1e-30, 1e-30), d)   # no 0 * inf
    inv = 1.0 / safe
    ta, tb = (voxel - o) * inv, (voxel + 1.0 - o) * inv
    t0 = np.maximum(np.minimum(ta, tb).max(axis=0), 0.0)
    t1 = np.maximum(ta, tb).min(axis=0)
    rows = np.flatnonzero((t0 < t1) & (t0 < tmax))
    if not len(rows):
        return out
    o, d, a, t0, t1 = o[:, rows], d[:, rows], coeff[:, rows], t0[rows], t1[rows]
    qx, qy, qz = o + t0 * d - voxel[:, rows]
    dx, dy, dz = d
    c0 = (a[0] + a[1] * qx + a[2] * qy + a[3] * qz + a[4] * qx * qy + a[5] * qy * qz
          + a[6] * qx * qz + a[7] * qx * qy * qz)
    c1 = (a[1] * dx + a[2] * dy + a[3] * dz + a[4] * (qx * dy + qy * dx) + a[5] * (qy * dz + qz * dy)
          + a[6] * (qx * dz + qz * dx) + a[7] * (qx * qy * dz + qx * dy * qz + dx * qy * qz))
    c2 = (a[4] * dx * dy + a[5] * dy * dz + a[6] * dx * dz
          + a[7] * (qx * dy * dz + dx * qy * dz + dx * dy * qz))
    c3 = a[7] * dx * dy * dz
    c = (c0, c1, c2, c3)
    near, far = np.zeros(len(rows)), t1 - t0
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        # Roots of f' = 3 c3 s^2 + 2 c2 s + c1 (one root when c3 = 0), in increasing order.
        qa, qb = 3.0 * c3, 2.0 * c2
        linear = qa == 0
        disc = qb * qb - 4.0 * qa * c1
        q = -0.5 * (qb + np.copysign(np.sqrt(disc), qb))
        r0 = np.where(linear, -c1 / qb, np.minimum(q / qa, c1 / q))
        r1 = np.where(linear, r0, np.maximum(q / qa, c1 / q))
        has = np.where(linear, qb != 0, disc >= 0)
        # Keep the first monotone piece that changes sign: [near, r0], else [r0, ...].
        for root in (r0, r1):
            inside = has & (near <= root) & (root <= far)
            f_root = _cubic(c, root)
            before = inside & (_cubic(c, near) * f_root <= 0)
            far = np.where(before, root, far)
            near = np.where(inside & ~before, root, near)
        f_near, f_far = _cubic(c, near), _cubic(c, far)
        ok = np.flatnonzero((f_near * f_far <= 0) & (t0 + near < tmax[rows]))
        s = _regula_falsi(c, near, far, f_near, f_far, ok)
        t = t0[ok] + s
    good = (t >= 0) & (t < tmax[rows[ok]])
    out[rows[ok[good]]] = t[good]
    return out


def _regula_falsi(c, near, far, f_near, f_far, rows):
    """Mitsuba's refinement of the bracketed roots ``rows``: the last false-position
    iterate when the bracket is narrower than :data:`SOLVE_EPSILON` or after
    :data:`SOLVE_ITERATIONS` steps (NaN when both ends are zeros: a miss, as in Mitsuba)."""
    c = tuple(x[rows] for x in c)
    near, far, f_near, f_far = near[rows], far[rows], f_near[rows], f_far[rows]
    result = np.empty(len(rows))
    live = np.arange(len(rows))
    for _ in range(SOLVE_ITERATIONS):
        if not len(live):
            break
        s = near + (far - near) * (-f_near / (f_far - f_near))
        f_s = _cubic(c, s)
        left = f_s * f_near <= 0                 # the root lies in [near, s]
        far, f_far = np.where(left, s, far), np.where(left, f_s, f_far)
        right = ~left
        near, f_near = np.where(right, s, near), np.where(right, f_s, f_near)
        result[live] = s
        keep = ~(np.abs(near - far) < SOLVE_EPSILON)
        if not keep.all():
            live, s = live[keep], s[keep]
            near, far, f_near, f_far = near[keep], far[keep], f_near[keep], f_far[keep]
            c = tuple(x[keep] for x in c)
    return result


class SDFGridShape(BVH):
    """One ``sdfgrid`` shape: its occupied voxels in a wide BVH, in grid coordinates.

    The tree and its traversal are :class:`pathtracer.accel.bvh.BVH`'s (``intersect``
    returns ``t, voxel, 0, 0``); the leaf test is :func:`voxel_hits`. Rays are mapped to
    grid coordinates first (an affine map keeps the ray parameter).

    Parameters
    ----------
    data : (z, y, x) float64 array, at least 2 nodes along each axis.
    to_world : (4, 4) object (unit cube) to world map.
    normals : {'smooth', 'analytic'}
    shape : int
        Scene shape id.

    Raises
    ------
    SDFGridError
        No voxel holds a sign change (Mitsuba refuses such a grid too).
    """

    def __init__(self, data: np.ndarray, to_world: np.ndarray, normals: str, shape: int):
        self.data, self.normals, self.shape = np.asarray(data, np.float64), normals, shape
        nz, ny, nx = self.data.shape
        self.resolution = np.array([nx, ny, nz])
        self.to_world = np.asarray(to_world, np.float64)
        to_grid = np.diag(np.append(self.resolution - 1.0, 1.0)) @ np.linalg.inv(self.to_world)
        self.to_grid = to_grid
        # Normals go object -> world by the inverse transpose of to_world; gradients are
        # taken per object-space unit, so that is the whole map.
        self.normal_map = np.linalg.inv(self.to_world[:3, :3]).T
        corners = np.stack([self.data[e:nz - 1 + e, b:ny - 1 + b, a:nx - 1 + a].reshape(-1)
                            for a, b, e in _CORNERS], axis=1)
        occupied = ~(np.all(corners > 0, axis=1) | np.all(corners < 0, axis=1))
        index = np.flatnonzero(occupied)
        if not len(index):
            raise SDFGridError("no voxel holds a sign change (Mitsuba: an SDF grid needs at "
                               "least one non-empty voxel)")
        z, rem = np.divmod(index, (ny - 1) * (nx - 1))
        y, x = np.divmod(rem, nx - 1)
        self.voxel = np.stack([x, y, z], axis=1).astype(np.float64)      # (P, 3) lower corners
        self._coeff = np.ascontiguousarray(polynomial(corners[index]).T)  # (8, P)
        self._voxel_t = np.ascontiguousarray(self.voxel.T)               # (3, P)
        lo, hi = tight_boxes(corners[index])
        # A voxel test makes ~40 temporaries per (ray, voxel) pair.
        self._init_over_boxes(self.voxel + lo, self.voxel + hi, chunk=8192)

    def _leaf_test(self, o, d, r, leaf, tbest):
        """Nearest voxel hit of each (ray r, leaf) pair: (t, voxel, 0, 0)."""
        if r is None:
            r = np.arange(o.shape[1])
            leaf = np.zeros(len(r), np.int64)
        k, m = self._leaf_k, len(r)
        # Every (slot, pair) at once, the slots' empty padding left out.
        prim = self._leaf_prim[:, leaf].reshape(-1)
        use = np.flatnonzero(prim >= 0)
        pair = use % m
        pr = prim[use]
        rr = np.take(r, pair)
        best = np.full(k * m, np.inf)
        # In pieces: a voxel test holds ~40 temporaries per (ray, voxel) pair.
        for s in range(0, len(use), PIECE):
            sl = slice(s, s + PIECE)
            best[use[sl]] = voxel_hits(
                np.take(o, rr[sl], axis=1), np.take(d, rr[sl], axis=1), np.take(tbest, rr[sl]),
                np.take(self._coeff, pr[sl], axis=1), np.take(self._voxel_t, pr[sl], axis=1))
        best = best.reshape(k, m)
        j = np.argmin(best, axis=0)
        col = np.arange(m)
        t_best = best[j, col]
        voxel = np.where(np.isfinite(t_best), self._leaf_prim[j, leaf], -1)
        return t_best, voxel, np.zeros(m), np.zeros(m)

    # -- world-space queries ------------------------------------------------------
    def _grid_rays(self, o, d):
        m = self.to_grid
        return o @ m[:3, :3].T + m[:3, 3], d @ m[:3, :3].T

    def intersect(self, o, d, tmax=None):
        """Closest hit ``(t, voxel, 0, 0)`` of world rays ``o + t d`` (n, 3), t in [0, tmax)."""
        go, gd = self._grid_rays(np.asarray(o, np.float64), np.asarray(d, np.float64))
        return BVH.intersect(self, go, gd, tmax)

    def occluded(self, o, d, tmax=None):
        """(n,) bool: a hit with t in [0, tmax) (world rays)."""
        go, gd = self._grid_rays(np.asarray(o, np.float64), np.asarray(d, np.float64))
        return BVH.occluded(self, go, gd, tmax)

    def surface(self, p: np.ndarray):
        """Unit geometric and shading normals (world, (m, 3) each) at world hit points ``p``."""
        g = p @ self.to_grid[:3, :3].T + self.to_grid[:3, 3]
        cell = np.trunc(g).astype(np.int64)       # Mitsuba casts to int: towards zero
        grad = np.stack([face_gradients(self.data, g, cell[:, a], a) for a in range(3)], axis=1)
        n = normalize(grad @ self.normal_map.T)
        if self.normals == "analytic":
            return n, n
        smooth = self.smooth_normals(g)
        length = np.linalg.norm(smooth, axis=1)
        # A zero blend (Mitsuba: NaN) cannot shade: the geometric normal stands in.
        sh_n = np.where((length > 0)[:, None], normalize(np.where((length > 0)[:, None], smooth, 1.0)), n)
        return n, sh_n

    def smooth_normals(self, g: np.ndarray) -> np.ndarray:
        """The blended voxel normals (world, not normalised) at grid points ``g`` (m, 3)."""
        base = np.rint(g).astype(np.int64) - 1
        # comp[a][j]: gradient component a of the voxels whose index along a is base + j.
        comp = [[face_gradients(self.data, g, base[:, a] + j, a) for j in (0, 1)] for a in range(3)]
        valid = [[base[:, a] + j >= 0 for j in (0, 1)] for a in range(3)]
        weight = g - base - 0.5                 # u, v, w: weight of the upper voxels
        normals = {}
        ok = {}
        for a, b, e in _CORNERS:
            vec = np.stack([comp[0][a], comp[1][b], comp[2][e]], axis=1)
            ok[a, b, e] = valid[0][a] & valid[1][b] & valid[2][e]
            length = np.linalg.norm(vec, axis=1)
            # A zero gradient has no direction (Mitsuba: NaN); it adds nothing here.
            keep = ok[a, b, e] & (length > 0)
            normals[a, b, e] = np.where(keep[:, None], vec / np.where(keep, length, 1.0)[:, None], 0.0)
        for axis in range(3):
            def layer(j):
                return [key for key in ok if key[axis] == j]
            low_out = ~np.any([ok[key] for key in layer(0)], axis=0)
            high_out = ~np.any([ok[key] for key in layer(1)], axis=0)
            weight[:, axis] = np.where(low_out, 1.0, weight[:, axis])
            weight[:, axis] = np.where(high_out, 0.0, weight[:, axis])
        blend = np.zeros_like(g)
        for (a, b, e), vec in normals.items():
            w = ((weight[:, 0] if a else 1.0 - weight[:, 0]) * (weight[:, 1] if b else 1.0 - weight[:, 1])
                 * (weight[:, 2] if e else 1.0 - weight[:, 2]))
            blend += w[:, None] * vec
        return blend @ self.normal_map.T

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """World bounding box (lo, hi) of the unit cube under ``to_world`` (Mitsuba's bbox)."""
        cube = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
        world = transform.apply_points(self.to_world, cube)
        return world.min(axis=0), world.max(axis=0)


def fill_sdfgrid(grid: SDFGridShape, hit, sel, o, d):
    """Surface data of the hits ``sel`` on ``grid`` (rays ``o``, ``d`` of those rows)."""
    p = o + hit.t[sel, None] * d                  # Mitsuba: the point on the ray
    n, sh_n = grid.surface(p)
    hit.p[sel], hit.n[sel], hit.sh_n[sel] = p, n, sh_n
    hit.uv[sel] = 0.0
    hit.shape[sel] = grid.shape


def check_scale_translate(m: np.ndarray) -> bool:
    """``m`` only scales (by positive factors along the axes) and translates."""
    linear = m[:3, :3]
    diagonal = np.diag(linear)
    off = linear - np.diag(diagonal)
    return bool(np.all(diagonal > 0) and np.abs(off).max() <= 1e-6 * np.abs(diagonal).max())


@register("shape", "sdfgrid")
def create(props: Props) -> None:
    """An ``sdfgrid``: ``filename`` (a one-channel ``.vol`` file), ``normals`` (``smooth``),
    ``to_world`` (scale and translate only; rotate through an instance)."""
    plugin, shape = props.plugin, props.shape
    if "flip_normals" in plugin.props:
        raise plugin.error("flip_normals is not a parameter of sdfgrid (Mitsuba refuses it as "
                           "an unreferenced property)", props.line("flip_normals"))
    if shape.emitter is not None:
        raise shape.emitter.error("an sdfgrid cannot be an area emitter (Mitsuba: it has no "
                                  "surface area and no position sampling)")
    normals = props.string("normals", "smooth")
    if normals not in NORMAL_MODES:
        raise plugin.error(f"normals must be one of {', '.join(NORMAL_MODES)}, got {normals!r}",
                           props.line("normals"))
    if not check_scale_translate(props.transform("to_world")):
        raise plugin.error("an sdfgrid's own to_world may only scale (by positive factors) and "
                           "translate: Mitsuba warns on anything else and its voxel bounds are "
                           "then wrong; put the grid in a shapegroup and transform the instance",
                           props.line("to_world"))
    try:
        transform.check_affine(shape.to_world)
    except ValueError as e:
        raise plugin.error(f"to_world: {e}") from None
    path = find_file(plugin, props, "filename", props.folders)
    name = os.path.basename(path)
    try:
        grid = read_vol(path)
    except VolFormatError as e:
        raise plugin.error(f"{name}: {e}", props.line("filename")) from None
    except OSError as e:
        raise plugin.error(f"cannot read \"{name}\": {e.strerror or e}", props.line("filename")) from None
    if grid.channels != 1:
        raise plugin.error(f"{name} has {grid.channels} channels; an SDF grid has 1 (as in Mitsuba)",
                           props.line("filename"))
    nx, _, nz = grid.resolution
    if nx != nz:
        raise plugin.error(f"{name}: resolution {' x '.join(map(str, grid.resolution))}; Mitsuba "
                           "3.9.1 mixes up an SDF grid's x and z sizes (voxel size and numbering), "
                           "so a grid whose x and z resolutions differ cannot be compared",
                           props.line("filename"))
    if min(grid.resolution) < 2:
        raise plugin.error(f"{name}: resolution {' x '.join(map(str, grid.resolution))}; an SDF "
                           "grid needs at least 2 values along each axis", props.line("filename"))
    try:
        sdf = SDFGridShape(grid.data[..., 0], shape.to_world, normals, props.shape_id)
    except SDFGridError as e:
        raise plugin.error(f"{name}: {e}", props.line("filename")) from None
    shape.geometry.add_analytic("sdfgrid", shape.geometry.sdfgrids, sdf, 0.0)
