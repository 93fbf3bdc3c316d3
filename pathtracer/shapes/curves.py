"""Mitsuba's curve shapes: ``bsplinecurve`` and ``linearcurve``.

Both read a text file of control points, one ``x y z radius`` per line, a blank line
starting a new curve; ``to_world`` moves the points but not the radii. Like Mitsuba
(Embree), only the outside of a curve can be hit: a ray that would meet its surface from
inside (back face) passes through.

* ``linearcurve``: consecutive points joined by cones whose radius varies linearly, with a
  sphere at every point (round joints and end caps): the surface swept by a sphere of
  radius r(v) moving along the polyline. Segment k of a curve of n points is points
  k, k+1 (n - 1 segments); normal ``p - c`` with c the centre of the sweeping sphere
  that touches the hit point.
* ``bsplinecurve``: uniform cubic B-splines (4 consecutive points per segment, n - 3
  segments), a tube whose cross-section is the circle of radius r(v) orthogonal to the
  centre line c(v), open at both ends (no caps). Normal as Mitsuba's:
  ``(|c'|^2 - (p - c).c'') (p - c) - r r' c'``.

Texture coordinates as Mitsuba's: ``u`` the angle around the centre line (measured from
the frame Mitsuba builds from the tangent and the world z axis) as a fraction of a turn,
``v = (segment + local v) / number of segments`` over the whole file.

Intersection of a B-spline: each segment is cut into ``K`` pieces (chosen per segment);
piece j is the cone from ``(c(v_j), r(v_j))`` to ``(c(v_j+1), r(v_j+1))``, cut at the
joints by the planes that bisect consecutive pieces (so that the pieces meet without
gaps) and at the curve's ends by planes orthogonal to the end pieces. The pieces lie
within :func:`chord_error` of the true tube: ``h^2 (max|c''| + max|r''|) / 8`` for a
piece spanning ``h`` of the segment's parameter (c'' and r'' are linear in v, so their
maxima are at the segment's ends), and ``K`` is the smallest that keeps this below
``TOLERANCE`` times the curve's bounding-box diagonal (capped at ``MAX_PIECES``). The
hit's normal and uv are then Mitsuba's formulas at the parameter ``v`` whose orthogonal
circle holds the hit point (found by Newton's method from the piece's estimate). With
a radius that varies along the curve, the cone pieces approximate the sweep of spheres
rather than of orthogonal circles; the two differ by ``r r'^2 / (2 |c'|^2)`` in radius.

A linear curve is intersected exactly (each segment is one piece with its two spheres).
The pieces' bounds go into a :class:`pathtracer.accel.bvh.BVH`-style wide tree; its leaves
test pieces instead of triangles.
"""
from __future__ import annotations

import math
import os

import numpy as np

from ..accel.bvh import BVH
from ..core.vec import unit
from ..scene import transform
from ..scene.properties import Props, find_file
from ..scene.registry import register

#: Largest allowed distance between the pieces and the true B-spline tube, relative to
#: the diagonal of the curve's bounding box.
TOLERANCE = 1e-5
#: Most pieces per B-spline segment.
MAX_PIECES = 256
#: Newton steps that find the hit's curve parameter.
NEWTON_STEPS = 4


class CurveFileError(ValueError):
    """A malformed control-point file; the message names the line."""


def read_control_points(path: str, min_points: int) -> list[np.ndarray]:
    """The curves of a control-point file, each a (k, 4) array of ``x y z radius``.

    Raises
    ------
    CurveFileError
        A line that is not four finite numbers, a curve with fewer than
        ``min_points`` points, or no point at all.
    """
    curves, current, first_line = [], [], 0
    with open(path, encoding="utf-8", errors="replace") as f:
        lines = f.read().split("\n")
    for number, line in enumerate(lines + [""], start=1):
        fields = line.split()
        if not fields:
            if current:
                if len(current) < min_points:
                    raise CurveFileError(f"line {first_line}: a curve needs at least {min_points} "
                                         f"control points, this one has {len(current)}")
                curves.append(np.array(current))
            current = []
            continue
        try:
            values = [float(v) for v in fields[:4]]
        except ValueError:
            values = []
        if len(values) != 4 or not all(math.isfinite(v) for v in values):
            raise CurveFileError(f"line {number}: expected four numbers \"x y z radius\", "
                                 f"got \"{line.strip()[:60]}\"")
        if not current:
            first_line = number
        current.append(values)
    if not curves:
        raise CurveFileError("no control points")
    return curves


# ----------------------------------------------------------------------
# Centre lines


def bspline(points: np.ndarray, v: np.ndarray):
    """Uniform cubic B-spline of the 4 control points ``points`` (m, 4, 4) at ``v`` (m,).

    Returns ``c, dc, ddc`` (m, 3) and ``r, dr, ddr`` (m,): centre, radius and their first
    and second derivatives with respect to the segment's own parameter v in [0, 1].
    """
    v = np.asarray(v, dtype=np.float64)[:, None]
    v2, v3 = v * v, v * v * v
    basis = np.stack([(1 - v) ** 3, 3 * v3 - 6 * v2 + 4, -3 * v3 + 3 * v2 + 3 * v + 1, v3],
                     axis=1) / 6.0
    d1 = np.stack([-(1 - v) ** 2, 3 * v2 - 4 * v, -3 * v2 + 2 * v + 1, v2], axis=1) / 2.0
    d2 = np.stack([1 - v, 3 * v - 2, 1 - 3 * v, v], axis=1)
    value, first, second = (np.einsum("mkx,mkj->mj", b, points) for b in (basis, d1, d2))
    return (value[:, :3], first[:, :3], second[:, :3],
            value[:, 3], first[:, 3], second[:, 3])


def local_frame(tangent: np.ndarray):
    """Mitsuba's frame around a unit tangent: ``(v_rot, v_rad)``, v_rot towards world +z."""
    guide = np.array([0.0, 0.0, 1.0])
    v_rot = guide - tangent * tangent[:, 2:3]
    length = np.linalg.norm(v_rot, axis=1, keepdims=True)
    singular = length[:, 0] < 1e-12
    v_rot = np.where(singular[:, None], np.array([0.0, 1.0, 0.0]), v_rot / np.where(
        singular[:, None], 1.0, length))
    return v_rot, np.cross(v_rot, tangent)


def chord_error(points: np.ndarray, pieces: int) -> np.ndarray:
    """Bound on the distance between a B-spline segment's tube and its ``pieces`` cones.

    ``points`` (S, 4, 4): control points and radii of S segments.
    """
    second_0 = points[:, 0] - 2 * points[:, 1] + points[:, 2]       # c'', r'' at v = 0
    second_1 = points[:, 1] - 2 * points[:, 2] + points[:, 3]       # at v = 1
    bound = np.maximum(np.linalg.norm(second_0[:, :3], axis=1), np.linalg.norm(second_1[:, :3], axis=1))
    bound += np.maximum(np.abs(second_0[:, 3]), np.abs(second_1[:, 3]))
    return bound / (8.0 * np.asarray(pieces, dtype=np.float64) ** 2)


# ----------------------------------------------------------------------
# Ray against cone pieces


def piece_hits(o, d, tmax, piece):
    """Nearest front-facing hit of rays ``o + t d`` (3, m) on pieces (dict of (m,...) arrays).

    A piece is the cone tangent to the spheres ``(a, ra)`` and ``(b, rb)``, kept between the
    clip planes ``(pa, ma)`` (keep ``(p - pa).ma >= 0``) and ``(pb, mb)`` (keep ``<= 0``),
    plus the spheres themselves where ``cap_a`` / ``cap_b``. Returns ``t`` (inf: no hit)
    and ``s``, the parameter along a -> b of the sphere centre that touches the hit point.
    """
    a, b, ra, rb = piece["a"], piece["b"], piece["ra"], piece["rb"]
    axis = b - a
    length = np.sqrt(np.einsum("im,im->m", axis, axis))
    w = axis / np.where(length > 0, length, 1.0)
    sin_a = (ra - rb) / np.where(length > 0, length, 1.0)
    cos2 = 1.0 - sin_a * sin_a
    has_cone = (cos2 > 1e-12) & (length > 0)
    cos2 = np.where(has_cone, cos2, 1.0)
    cos_a = np.sqrt(cos2)
    q = o - a
    dd = np.einsum("im,im->m", d, d)
    qd = np.einsum("im,im->m", q, d)
    qq = np.einsum("im,im->m", q, q)
    dx = np.einsum("im,im->m", d, w)
    qx = np.einsum("im,im->m", q, w)
    e, f = ra - qx * sin_a, dx * sin_a
    A = cos2 * (dd - dx * dx) - f * f
    h = cos2 * (qd - qx * dx) + e * f
    C = cos2 * (qq - qx * qx) - e * e
    disc = h * h - A * C
    best_t = np.full(len(A), np.inf)
    best_s = np.zeros(len(A))
    with np.errstate(divide="ignore", invalid="ignore"):
        root = np.sqrt(np.maximum(disc, 0.0))
        qr = -(h + np.where(h >= 0, root, -root))
        for t in (qr / A, C / qr):
            x = qx + t * dx
            rho = (e - t * f) / cos_a                 # radial distance on this nappe
            p = o + t * d
            radial = p - a - x * w
            # Front face: d . (cos_a e_rho + sin_a w) < 0, e_rho = radial / rho.
            facing = cos_a * np.einsum("im,im->m", radial, d) + sin_a * dx * rho
            ok = (has_cone & (disc >= 0) & (t > 0) & (t < tmax) & (t < best_t) & (rho >= 0)
                  & (facing < 0)
                  & (np.einsum("im,im->m", p - piece["pa"], piece["ma"]) >= 0)
                  & (np.einsum("im,im->m", p - piece["pb"], piece["mb"]) <= 0))
            s = (x - ra * sin_a) / (np.where(length > 0, length, 1.0) * cos2)
            best_t = np.where(ok, t, best_t)
            best_s = np.where(ok, np.clip(s, 0.0, 1.0), best_s)
    for centre, radius, cap, s_value in ((a, ra, piece["cap_a"], 0.0), (b, rb, piece["cap_b"], 1.0)):
        if not np.any(cap):
            continue
        l = o - centre
        t_mid = -np.einsum("im,im->m", l, d) / dd
        closest = l + t_mid * d
        c = np.einsum("im,im->m", closest, closest) - radius * radius
        with np.errstate(invalid="ignore"):
            t = t_mid - np.sqrt(-dd * c) / dd        # the entering root only: no back faces
        ok = cap & (c <= 0) & (t > 0) & (t < tmax) & (t < best_t)
        best_t = np.where(ok, t, best_t)
        best_s = np.where(ok, s_value, best_s)
    return best_t, best_s


class CurveShape(BVH):
    """One ``bsplinecurve`` or ``linearcurve`` shape: its pieces in a wide BVH.

    The tree and its traversal are :class:`pathtracer.accel.bvh.BVH`'s (``intersect`` and
    ``occluded`` return ``t, piece, s, 0`` in place of ``t, triangle, b1, b2``); only the
    leaf test differs.

    Parameters
    ----------
    curves : list of (k, 4) arrays
        World-space control points and radii of each curve.
    kind : {'bspline', 'linear'}
    shape : int
        Scene shape id.

    Attributes
    ----------
    segments : (S, P, 4) control points of every segment (P = 4 or 2).
    piece_segment, piece_v0, piece_v1 : (M,) segment and parameter span of each piece.
    """

    def __init__(self, curves, kind: str, shape: int):
        self.kind, self.shape = kind, shape
        per = 4 if kind == "bspline" else 2
        segments, first, last = [], [], []
        for pts in curves:
            for k in range(len(pts) - per + 1):
                first.append(k == 0)
                last.append(k == len(pts) - per)
                segments.append(pts[k:k + per])
        self.segments = np.array(segments, dtype=np.float64)
        first, last = np.array(first), np.array(last)
        pieces = self._bspline_pieces(first, last) if kind == "bspline" else \
            self._linear_pieces()
        self._piece = pieces
        lo = np.minimum(pieces["a"] - pieces["ra"][:, None], pieces["b"] - pieces["rb"][:, None])
        hi = np.maximum(pieces["a"] + pieces["ra"][:, None], pieces["b"] + pieces["rb"][:, None])
        # A piece test makes ~30 temporaries per (ray, piece) pair.
        self._init_over_boxes(lo, hi, chunk=8192)

    # -- pieces ----------------------------------------------------------------
    def _linear_pieces(self) -> dict:
        seg = self.segments
        a, b, ra, rb = seg[:, 0, :3], seg[:, 1, :3], seg[:, 0, 3], seg[:, 1, 3]
        length = np.linalg.norm(b - a, axis=1)
        w = (b - a) / np.where(length > 0, length, 1.0)[:, None]
        sin_a = (ra - rb) / np.where(length > 0, length, 1.0)
        # The cone part runs between the circles where it touches the two spheres.
        pa = a + (ra * sin_a)[:, None] * w
        pb = b + (rb * sin_a)[:, None] * w
        n = len(seg)
        self.piece_segment = np.arange(n)
        self.piece_v0, self.piece_v1 = np.zeros(n), np.ones(n)
        return dict(a=a, b=b, ra=ra, rb=rb, pa=pa, ma=w, pb=pb, mb=w,
                    cap_a=np.ones(n, bool), cap_b=np.ones(n, bool))

    def _bspline_pieces(self, first, last) -> dict:
        seg = self.segments
        diag = np.linalg.norm(seg[..., :3].reshape(-1, 3).max(0) - seg[..., :3].reshape(-1, 3).min(0))
        tol = TOLERANCE * max(diag, 1e-12)
        bound = chord_error(seg, 1)
        counts = np.clip(np.ceil(np.sqrt(bound / tol)), 1, MAX_PIECES).astype(np.int64)
        self.max_chord_error = float(np.max(chord_error(seg, counts)))
        sid = np.repeat(np.arange(len(seg)), counts)
        j = np.arange(len(sid)) - np.repeat(np.cumsum(counts) - counts, counts)
        v0, v1 = j / counts[sid], (j + 1) / counts[sid]
        c0, dc0, _, r0, _, _ = bspline(seg[sid], v0)
        c1, dc1, _, r1, _, _ = bspline(seg[sid], v1)
        w = unit(c1 - c0)
        # Joint planes bisect consecutive pieces (pieces of one curve are consecutive);
        # at a curve's two ends the plane is orthogonal to the end piece.
        starts = (j == 0) & first[sid]
        ends = (j == counts[sid] - 1) & last[sid]
        prev_w = np.roll(w, 1, axis=0)
        next_w = np.roll(w, -1, axis=0)
        ma = np.where(starts[:, None], w, unit(w + prev_w))
        mb = np.where(ends[:, None], w, unit(w + next_w))
        self.piece_segment, self.piece_v0, self.piece_v1 = sid, v0, v1
        n = len(sid)
        return dict(a=c0, b=c1, ra=r0, rb=r1, pa=c0, ma=ma, pb=c1, mb=mb,
                    cap_a=np.zeros(n, bool), cap_b=np.zeros(n, bool))

    # -- BVH over the pieces (the triangle BVH's traversal, a piece leaf test) ----
    def _leaf_test(self, o, d, r, leaf, tbest):
        """Nearest piece hit of each (ray r, leaf) pair: (t, piece, s, 0)."""
        k = self._leaf_k
        if r is None:
            r = np.arange(o.shape[1])
            leaf = np.zeros(len(r), np.int64)
        best_t = np.full(len(r), np.inf)
        best_p = np.full(len(r), -1, np.int64)
        best_s = np.zeros(len(r))
        ro, rd, rt = np.take(o, r, axis=1), np.take(d, r, axis=1), tbest[r]
        for slot in range(k):
            prim = self._leaf_prim[slot, leaf]
            use = np.flatnonzero(prim >= 0)
            if not len(use):
                continue
            pr = prim[use]
            piece = {key: (val[pr].T if val.ndim == 2 else val[pr])
                     for key, val in self._piece.items()}
            t, s = piece_hits(ro[:, use], rd[:, use], np.minimum(rt[use], best_t[use]), piece)
            closer = t < best_t[use]
            rows = use[closer]
            best_t[rows], best_p[rows], best_s[rows] = t[closer], pr[closer], s[closer]
        return best_t, best_p, best_s, np.zeros(len(r))

    # -- surface at the hits ------------------------------------------------------
    def surface(self, p: np.ndarray, piece: np.ndarray, s: np.ndarray):
        """Mitsuba's normal (unit, outwards) and uv at hit points ``p`` (m, 3) on ``piece``.

        ``s`` is the piece parameter of the touching sphere's centre (from the intersection).
        """
        seg_id = self.piece_segment[piece]
        v = self.piece_v0[piece] + s * (self.piece_v1[piece] - self.piece_v0[piece])
        seg = self.segments[seg_id]
        if self.kind == "linear":
            centre = seg[:, 0, :3] + v[:, None] * (seg[:, 1, :3] - seg[:, 0, :3])
            normal = unit(p - centre)
            tangent = unit(seg[:, 1, :3] - seg[:, 0, :3])
        else:
            for _ in range(NEWTON_STEPS):   # v whose orthogonal circle holds p
                c, dc, ddc, *_ = bspline(seg, v)
                rad = p - c
                g = np.einsum("mi,mi->m", rad, dc)
                dg = np.einsum("mi,mi->m", rad, ddc) - np.einsum("mi,mi->m", dc, dc)
                v = np.clip(v - g / np.where(dg != 0, dg, -1.0), 0.0, 1.0)
            c, dc, ddc, r, dr, _ = bspline(seg, v)
            rad = p - c
            normal = unit((np.einsum("mi,mi->m", dc, dc) - np.einsum("mi,mi->m", rad, ddc))[:, None]
                           * rad - (dr * r)[:, None] * dc)
            centre, tangent = c, unit(dc)
        v_rot, v_rad = local_frame(tangent)
        radial = unit(p - centre)
        u = np.arctan2(np.einsum("mi,mi->m", v_rot, radial), np.einsum("mi,mi->m", v_rad, radial))
        u = np.where(u < 0, u + 2 * np.pi, u) / (2 * np.pi)
        return normal, np.stack([u, (v + seg_id) / len(self.segments)], axis=1)

    def area(self) -> float:
        """Lateral area of the pieces (the cones' ``pi (ra + rb) L``)."""
        pc = self._piece
        return float(np.sum(np.pi * (pc["ra"] + pc["rb"]) * np.linalg.norm(pc["b"] - pc["a"], axis=1)))

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """World bounding box (lo, hi) of the pieces."""
        pc = self._piece
        lo = np.minimum(pc["a"] - pc["ra"][:, None], pc["b"] - pc["rb"][:, None]).min(0)
        hi = np.maximum(pc["a"] + pc["ra"][:, None], pc["b"] + pc["rb"][:, None]).max(0)
        return lo, hi


def fill_curve(curve, hit, sel, o, d, piece, s):
    """Surface data of the hits ``sel`` on ``curve`` (rays ``o``, ``d``, pieces and piece
    parameters of those rows)."""
    # The hit point stays on the ray: it lies within the pieces' tolerance of the tube.
    p = o + hit.t[sel, None] * d
    nrm, uv = curve.surface(p, piece, s)
    hit.p[sel] = p
    hit.n[sel] = nrm
    hit.sh_n[sel] = nrm
    hit.shape[sel] = curve.shape
    hit.uv[sel] = uv


@register("shape", "bsplinecurve", "linearcurve")
def create(props: Props) -> None:
    """A ``bsplinecurve`` or ``linearcurve``: control points read from ``filename`` and
    moved to world space."""
    plugin, shape = props.plugin, props.shape
    m = shape.to_world
    if shape.flip:
        raise plugin.error("flip_normals is not supported on curves (Mitsuba only ever "
                           "hits their outside)", props.line("flip_normals"))
    if shape.emitter is not None:
        raise shape.emitter.error("an area emitter on a curve is not supported (this "
                                  "tracer cannot sample points on curves)")
    transform.check_affine(m)
    path = find_file(plugin, props, "filename", props.folders)
    bspline = plugin.type == "bsplinecurve"
    try:
        curves = read_control_points(path, 4 if bspline else 2)
    except CurveFileError as e:
        raise plugin.error(f"{os.path.basename(path)}: {e}", props.line("filename")) from None
    except OSError as e:
        raise plugin.error(f"cannot read curve file \"{os.path.basename(path)}\": "
                           f"{e.strerror or e}", props.line("filename")) from None
    world = [np.column_stack([transform.apply_points(m, c[:, :3]), c[:, 3]]) for c in curves]
    if any(np.any(c[:, 3] < 0) for c in world):
        raise plugin.error(f"{os.path.basename(path)}: a control point has a negative radius",
                           props.line("filename"))
    curve = CurveShape(world, "bspline" if bspline else "linear", props.shape_id)
    shape.geometry.add_analytic("curve", shape.geometry.curves, curve, curve.area())
