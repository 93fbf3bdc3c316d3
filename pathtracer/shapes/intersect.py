"""Ray-scene intersection for wavefronts of rays, and ray spawning.

Triangles go through the accelerators of :mod:`pathtracer.accel` (built once per
scene, cached in ``scene._accel``); spheres, disks and cylinders are few, so they are
intersected analytically one shape at a time, each over all rays; each curve
shape has its own tree of pieces, each SDF grid its tree of voxels. Each analytic
kind's intersection and the surface data of its hits live in the kind's module
(:mod:`.sphere`, :mod:`.disk`, :mod:`.cylinder`, :mod:`.curves`, :mod:`.sdfgrid`);
this module dispatches over the kinds, keeps the triangles' tables and spawns rays.

Ray spawning follows Mitsuba 3 (``Interaction::offset_p``, ``spawn_ray``,
``spawn_ray_to`` in include/mitsuba/render/interaction.h): there is no
``tmin``; instead the origin is pushed off the surface along the geometric
normal by ``(1 + max|p|) * RAY_EPSILON``, to the side the ray leaves to.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..accel.bvh import BVH
from ..accel.small_mesh import SMALL_MAX, SmallMesh, SplitMesh, small_shapes
from ..core.surface_uv import SurfaceUV
from ..core.vec import dot, max_abs, normalize, put_rows, scale, unscale
from .curves import fill_curve
from .cylinder import cylinder_t, fill_cylinders
from .disk import disk_t, fill_disks
from .sdfgrid import fill_sdfgrid
from .sphere import fill_spheres, sphere_t

RAY_EPSILON = 1500 * 2.0 ** -24  # Mitsuba's math::RayEpsilon for float32 (8.94e-5)
SHADOW_EPSILON = 10 * RAY_EPSILON  # math::ShadowEpsilon


@dataclass
class Hit:
    """Closest intersections of a batch of ``n`` rays.

    Attributes
    ----------
    valid : (n,) bool
        The ray hit something.
    t : (n,) float64
        Ray parameter of the hit (the distance for unit directions), inf on a miss.
    p : (n, 3) float64
        Hit point (0 on a miss). Triangles: interpolated from the vertices by
        barycentrics; spheres: reprojected onto the sphere; disks: onto the
        plane (as Mitsuba does).
    n : (n, 3) float64
        Unit geometric normal (0 on a miss). Triangles:
        ``normalize(cross(p1 - p0, p2 - p0))``; spheres: outward, or inward
        with ``flip_normals``; disks: the world image of local +z (inverse
        transpose), negated with ``flip_normals``.
    sh_n : (n, 3) float64
        Unit shading normal: interpolated vertex normals for triangles, an SDF
        grid's ``smooth`` normal, the geometric normal otherwise.
    shape : (n,) int32
        Shape id, -1 on a miss.
    prim : (n,) int64
        Triangle index into ``tri_*``, or sphere / disk / curve index into
        ``sphere_*`` / ``disk_*`` / ``curves`` / ``sdfgrids``; -1 on a miss.
    uv : (n, 2) float64
        Primitive coordinates. Triangles: barycentrics (b1, b2) of p1 and p2.
        Spheres: ``(phi / 2pi, theta / pi)`` around the world z axis. Disks:
        local (x, y) on the unit disk. Curves: Mitsuba's surface uv. Cylinders: ``(phi / 2pi, z)``
        in the unit tube's frame. Textures use :func:`texture_uv`
        (Mitsuba's surface uv), computed from these.
    """

    valid: np.ndarray
    t: np.ndarray
    p: np.ndarray
    n: np.ndarray
    sh_n: np.ndarray
    shape: np.ndarray
    prim: np.ndarray
    uv: np.ndarray


def prepare(scene) -> BVH | SmallMesh | SplitMesh:
    """Build (once) and return the scene's triangle accelerator, cached in ``scene._accel``.

    Up to :data:`pathtracer.accel.small_mesh.SMALL_MAX` triangles (rooms built of
    rectangles and cubes) every ray is tested against every triangle by
    :class:`pathtracer.accel.small_mesh.SmallMesh`. Larger scenes whose small shapes
    hold some of the triangles (a mesh in a room) get a
    :class:`pathtracer.accel.small_mesh.SplitMesh`; the others a :class:`BVH`.
    """
    if scene._accel is None:
        tri = scene.tri_p
        if len(tri) <= SMALL_MAX:
            scene._accel = SmallMesh(tri) if len(tri) else BVH(tri)
        else:
            small = small_shapes(scene.tri_shape)
            scene._accel = SplitMesh(tri, small) if small.any() else BVH(tri)
    return scene._accel


def intersect(scene, o: np.ndarray, d: np.ndarray, tmax=None) -> Hit:
    """Closest hit of each ray ``o + t d`` with ``0 < t < tmax``.

    Parameters
    ----------
    scene : Scene
    o, d : (n, 3) float64
        Origins and directions (unit directions make ``t`` a distance).
    tmax : (n,) array, float or None
        Far end of each ray; None means infinity.
    """
    o = np.asarray(o, np.float64)
    d = np.asarray(d, np.float64)
    n = len(o)
    tmax = np.broadcast_to(np.inf if tmax is None else np.asarray(tmax, np.float64), (n,))
    t, prim, b1, b2 = prepare(scene).intersect(o, d, tmax)
    # Most rays hit a triangle (a room, closed or open on a side): the triangle records are
    # built whole, no scatters, and the rays that missed get empty records after; the rows
    # that analytic shapes take are written over below.
    missed = np.flatnonzero(prim < 0)
    room = 2 * len(missed) <= n and n > 0
    records = _triangle_records(scene, np.maximum(prim, 0) if len(missed) else prim, b1, b2) \
        if room else None
    kind = np.where(prim >= 0, 0, -1)  # 0 triangle, 1 sphere, 2 disk, 3 curve, 4 cylinder, 5 sdfgrid
    t = np.where(kind >= 0, t, tmax)  # the far end for the analytic shapes
    for i in range(len(scene.sphere_radius)):
        ts = sphere_t(scene.sphere_center[i], scene.sphere_radius[i], o, d, t)
        closer = ts < t
        np.minimum(t, ts, out=t)
        kind[closer], prim[closer] = 1, i
    for i in range(len(scene.disk_shape)):
        td = disk_t(scene.disk_to_local[i], o, d, t)
        closer = td < t
        np.minimum(t, td, out=t)
        kind[closer], prim[closer] = 2, i
    curve_hits = []
    for i, curve in enumerate(scene.curves):
        tc, piece, s, _ = curve.intersect(o, d, t)
        closer = tc < t
        t[closer], kind[closer], prim[closer] = tc[closer], 3, i
        curve_hits.append((piece, s))
    for i in range(len(scene.cylinder_shape)):
        tc = cylinder_t(scene.cylinder_to_local[i], o, d, tmax)
        closer = tc < t
        t[closer], kind[closer], prim[closer] = tc[closer], 4, i
    for i, grid in enumerate(scene.sdfgrids):
        tg = grid.intersect(o, d, t)[0]
        closer = tg < t
        t[closer], kind[closer], prim[closer] = tg[closer], 5, i

    t[kind < 0] = np.inf
    if records is not None:
        p, nrm, sh_n, shape, uv = records
        if len(missed):   # empty records where no triangle was hit (analytic hits come below)
            for field in (p, nrm, sh_n, uv):
                field[missed] = 0.0
            shape[missed] = -1
        hit = Hit(valid=kind >= 0, t=t, p=p, n=nrm, sh_n=sh_n, shape=shape, prim=prim, uv=uv)
    else:
        hit = Hit(valid=kind >= 0, t=t, p=np.zeros((n, 3)), n=np.zeros((n, 3)),
                  sh_n=np.zeros((n, 3)), shape=np.full(n, -1, np.int32), prim=prim,
                  uv=np.zeros((n, 2)))
        sel = np.flatnonzero(kind == 0)
        if len(sel):
            _fill_triangles(scene, hit, sel, b1[sel], b2[sel])
    sel = np.flatnonzero(kind == 1)
    if len(sel):
        fill_spheres(scene, hit, sel, np.take(o, sel, axis=0), np.take(d, sel, axis=0))
    sel = np.flatnonzero(kind == 2)
    if len(sel):
        fill_disks(scene, hit, sel, np.take(o, sel, axis=0), np.take(d, sel, axis=0))
    for i, (piece, s) in enumerate(curve_hits):
        sel = np.flatnonzero((kind == 3) & (prim == i))
        if len(sel):
            fill_curve(scene.curves[i], hit, sel, o[sel], d[sel], piece[sel], s[sel])
    sel = np.flatnonzero(kind == 4)
    if len(sel):
        fill_cylinders(scene, hit, sel, o[sel], d[sel])
    for i, grid in enumerate(scene.sdfgrids):
        sel = np.flatnonzero((kind == 5) & (prim == i))
        if len(sel):
            fill_sdfgrid(grid, hit, sel, o[sel], d[sel])
    return hit


def occluded(scene, o: np.ndarray, d: np.ndarray, tmax) -> np.ndarray:
    """(n,) bool: something lies on ``o + t d`` for some ``0 < t < tmax``."""
    o = np.asarray(o, np.float64)
    d = np.asarray(d, np.float64)
    tmax = np.array(np.broadcast_to(np.asarray(tmax, np.float64), (len(o),)))
    occ = prepare(scene).occluded(o, d, tmax)
    for i in range(len(scene.sphere_radius)):
        occ |= sphere_t(scene.sphere_center[i], scene.sphere_radius[i], o, d, tmax) < tmax
    for i in range(len(scene.disk_shape)):
        occ |= disk_t(scene.disk_to_local[i], o, d, tmax) < tmax
    for curve in scene.curves:
        occ |= curve.occluded(o, d, tmax)
    for i in range(len(scene.cylinder_shape)):
        occ |= cylinder_t(scene.cylinder_to_local[i], o, d, tmax) < tmax
    for grid in scene.sdfgrids:
        occ |= grid.occluded(o, d, tmax)
    return occ


# ----------------------------------------------------------------------
# Ray spawning


def offset_p(p: np.ndarray, n: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Mitsuba's ``offset_p``: ``p`` pushed along ``+-n`` to the side of ``d``.

    The push is ``(1 + max|p|) * RAY_EPSILON`` long; its sign is the sign of
    ``dot(n, d)`` (positive for zero, as ``mulsign`` treats +0).
    """
    mag = (1.0 + max_abs(p)) * RAY_EPSILON
    mag = np.where(dot(n, d) >= 0.0, mag, -mag)
    return p + scale(n, mag)


def spawn_ray(p: np.ndarray, n: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Origin of rays leaving surface points ``p`` (geometric normals ``n``) along ``d``.

    The rays are ``(origin, d)`` with ``tmax = inf``: :func:`spawn_ray_inf`
    returns all three.
    """
    return offset_p(p, n, d)


def spawn_ray_inf(p: np.ndarray, n: np.ndarray, d: np.ndarray):
    """Rays towards infinity (e.g. shadow rays to an environment).

    Returns
    -------
    o : (n, 3) offset origin; d : (n, 3) the given directions;
    tmax : (n,) all inf.
    """
    return offset_p(p, n, d), d, np.full(len(p), np.inf)


def spawn_ray_to(p: np.ndarray, n: np.ndarray, target: np.ndarray):
    """Shadow rays from surface points ``p`` to points ``target``, as Mitsuba's ``spawn_ray_to``.

    Returns
    -------
    o : (n, 3)
        Origin offset off the surface towards ``target`` (``offset_p(p, n, target - p)``).
    d : (n, 3)
        Unit direction from ``o`` to ``target``.
    tmax : (n,)
        ``|target - o| * (1 - SHADOW_EPSILON)``: the ray stops just short of
        the target, so the surface that holds the target does not block it.
    """
    o = offset_p(p, n, target - p)
    d = target - o
    dist = np.sqrt(dot(d, d))
    d = unscale(d, np.where(dist > 0, dist, 1.0))
    return o, d, dist * (1.0 - SHADOW_EPSILON)


# ----------------------------------------------------------------------
# Surface data of the hits


class TriangleTables:
    """Per-triangle data that hit shading reads, computed once per scene.

    Attributes
    ----------
    p0, e1, e2 : (T, 3) first vertex and edges ``p1 - p0``, ``p2 - p0``.
    n : (T, 3) unit geometric normal ``normalize(cross(e1, e2))``.
    flat_n : (T, 3) unit shading normal of triangles whose three vertex
        normals are equal (rectangles, cubes, flat meshes); NaN elsewhere.
    smooth : (T,) bool, the vertex normals differ (interpolate them).
    """

    def __init__(self, tri_p, tri_n):
        self.p0 = np.ascontiguousarray(tri_p[:, 0])
        self.e1 = tri_p[:, 1] - tri_p[:, 0]
        self.e2 = tri_p[:, 2] - tri_p[:, 0]
        self.n = normalize(np.cross(self.e1, self.e2))
        self.smooth = ~(np.all(tri_n[:, 0] == tri_n[:, 1], axis=1)
                        & np.all(tri_n[:, 0] == tri_n[:, 2], axis=1))
        self.flat_n = normalize(tri_n[:, 0])
        self.any_smooth = bool(self.smooth.any())


def triangle_tables(scene) -> TriangleTables:
    """The scene's :class:`TriangleTables` (built once, kept with its accelerator)."""
    accel = prepare(scene)
    tables = getattr(accel, "_tables", None)
    if tables is None:
        tables = accel._tables = TriangleTables(scene.tri_p, scene.tri_n)
    return tables


def _triangle_records(scene, k, b1, b2):
    """Hit point, geometric and shading normal, shape and uv of hits on triangles ``k``.

    Gathers are ``np.take`` along axis 0 (several times faster than fancy
    indexing of (T, 3) tables); the point is ``p0 + b1 e1 + b2 e2`` in that order.
    """
    tab = triangle_tables(scene)
    p = np.take(tab.p0, k, axis=0)
    p += scale(np.take(tab.e1, k, axis=0), b1)
    p += scale(np.take(tab.e2, k, axis=0), b2)
    nrm = np.take(tab.n, k, axis=0)
    sh_n = np.take(tab.flat_n, k, axis=0)
    if tab.any_smooth:
        rows = np.flatnonzero(np.take(tab.smooth, k))
        if len(rows):
            put_rows(sh_n, rows, smooth_normals(scene, np.take(k, rows), np.take(b1, rows),
                                                np.take(b2, rows)))
    uv = np.empty((len(k), 2))
    uv[:, 0], uv[:, 1] = b1, b2
    return p, nrm, sh_n, np.take(scene.tri_shape, k).astype(np.int32, copy=False), uv


def smooth_normals(scene, tri: np.ndarray, b1: np.ndarray, b2: np.ndarray) -> np.ndarray:
    """Unit normals interpolated from the vertex normals of triangles ``tri`` at
    barycentrics ``b1``, ``b2`` (of their vertices p1 and p2) -> (n, 3)."""
    nv = np.take(scene.tri_n, tri, axis=0)
    return normalize(scale(nv[:, 0], 1.0 - b1 - b2) + scale(nv[:, 1], b1) + scale(nv[:, 2], b2))


def _fill_triangles(scene, hit, sel, b1, b2):
    p, nrm, sh_n, shape, uv = _triangle_records(scene, hit.prim[sel], b1, b2)
    put_rows(hit.p, sel, p)
    put_rows(hit.n, sel, nrm)
    put_rows(hit.sh_n, sel, sh_n)
    put_rows(hit.uv, sel, uv)
    hit.shape[sel] = shape


# ----------------------------------------------------------------------
# Texture coordinates


def texture_uv(scene, hit, rows: np.ndarray) -> np.ndarray:
    """Mitsuba's surface ``uv`` at the hits ``rows`` (valid hits), as (m, 2).

    * Meshes (rectangle, cube, obj, ply): the vertices' ``scene.tri_uv``
      interpolated with the hit's barycentrics (the barycentrics themselves
      when ``tri_uv`` is None).
    * Spheres: ``(phi / 2pi, theta / pi)`` of the direction from the center
      in the sphere's object frame (``scene.sphere_to_local``; the world axes
      when that is None), phi in [0, 2pi).
    * Disks: ``(r, phi / 2pi)`` of the local point, phi in [0, 2pi).
    * Curves: Mitsuba's ``(angle around the centre line / 2pi, v along the file's
      segments)``, computed at the hit (:mod:`pathtracer.shapes.curves`).
    * Cylinders: ``(phi / 2pi, z)`` in the unit tube's frame (:mod:`pathtracer.shapes.cylinder`).
    * SDF grids: (0, 0), as Mitsuba (:mod:`pathtracer.shapes.sdfgrid`).

    Computed only where a texture needs it, so untextured scenes never pay. Returned as
    a :class:`~pathtracer.core.surface_uv.SurfaceUV` that also carries the hits' shapes,
    triangles and barycentrics (for ``mesh_attribute``).
    """
    rows = np.asarray(rows)
    out = np.empty((len(rows), 2))
    prim = hit.prim[rows]
    shape = hit.shape[rows]
    kind = np.asarray(scene.shape_kind)[shape] if len(rows) else np.zeros(0, str)
    tri = np.flatnonzero(kind == "mesh")
    if len(tri):
        b = hit.uv[rows[tri]]
        if scene.tri_uv is None:
            out[tri] = b
        else:
            corner = scene.tri_uv[prim[tri]]
            out[tri] = ((1.0 - b[:, 0] - b[:, 1])[:, None] * corner[:, 0]
                        + b[:, 0, None] * corner[:, 1] + b[:, 1, None] * corner[:, 2])
    sph = np.flatnonzero(kind == "sphere")
    if len(sph):
        i = prim[sph]
        local = normalize(hit.p[rows[sph]] - scene.sphere_center[i])
        if scene.sphere_to_local is not None:
            local = np.einsum("kij,kj->ki", scene.sphere_to_local[i], local)
        out[sph, 0] = _unit_angle(np.arctan2(local[:, 1], local[:, 0]))
        out[sph, 1] = np.arccos(np.clip(local[:, 2], -1.0, 1.0)) / np.pi
    crv = np.flatnonzero(kind == "curve")
    if len(crv):
        out[crv] = hit.uv[rows[crv]]
    cyl = np.flatnonzero(kind == "cylinder")
    if len(cyl):
        out[cyl] = hit.uv[rows[cyl]]   # (phi / 2pi, z), as filled in at the hit
    out[kind == "sdfgrid"] = 0.0
    dsk = np.flatnonzero(kind == "disk")
    if len(dsk):
        local = hit.uv[rows[dsk]]
        out[dsk, 0] = np.hypot(local[:, 0], local[:, 1])
        out[dsk, 1] = _unit_angle(np.arctan2(local[:, 1], local[:, 0]))
    on_mesh = kind == "mesh"
    bary = np.where(on_mesh[:, None], hit.uv[rows], 0.0)
    return SurfaceUV(out, shape, np.where(on_mesh, prim, -1), bary)


def _unit_angle(phi: np.ndarray) -> np.ndarray:
    """An angle in (-pi, pi] as a fraction of a turn in [0, 1)."""
    turn = phi / (2.0 * np.pi)
    return np.where(turn < 0.0, turn + 1.0, turn)
