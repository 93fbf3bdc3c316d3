r"""An area light whose ``radiance`` is a texture (Mitsuba's ``area`` with a textured radiance).

Radiance at a point is the texture at the point's surface ``uv`` (on its emitting side).
How next-event estimation samples the light follows Mitsuba 3.9.1's ``AreaLight``:

* a texture that is not spatially varying (``mesh_attribute``, which Mitsuba calls
  constant) keeps the shape's own sampling by area, :math:`L(x) / p(\omega)`;
* a spatially varying one (``bitmap``, ``checkerboard``) draws the surface coordinates
  from the texture, :math:`(u, v) \sim p_{uv}` (``sample_position``: by texel luminance
  for a bitmap, uniform for a checkerboard), finds the surface point with those
  coordinates (``eval_parameterization``: the mesh triangle whose uv triangle holds
  them) and converts the density to solid angle,

  .. math:: p(\omega) = \frac{p_{uv}(u, v)}{\lVert \partial_u p \times \partial_v p \rVert}
            \frac{d^2}{|\cos\theta_l|}, \qquad
            \lVert \partial_u p \times \partial_v p \rVert = \frac{A_{world}}{A_{uv}}

  of the triangle (its world area over its uv area). Coordinates that no triangle covers
  give weight 0, as in Mitsuba. Only mesh shapes (rectangle, cube, obj, ply, serialized)
  are supported; the normal there is the triangle's geometric normal.
"""
from __future__ import annotations

import numpy as np

from ..core.surface_uv import SurfaceUV
from ..core.vec import dot, norm, unscale
from ..shapes import intersect
from .base import EmitterSample


class MeshParameterization:
    """A mesh shape's triangles in uv space, to find the point of given coordinates.

    A uniform grid over the uv bounding box lists, per cell, the triangles whose uv boxes
    overlap it; a query tests the candidates of its cell (padded to the longest list).
    """

    def __init__(self, scene, shape: int):
        begin, end = (int(v) for v in scene.shape_prim[shape])
        self.begin = begin
        p = scene.tri_p[begin:end]
        if scene.tri_uv is None:
            raise ValueError("a textured area light needs texture coordinates on its mesh")
        uv = scene.tri_uv[begin:end]
        self.uv0 = uv[:, 0]
        self.e1, self.e2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
        det = self.e1[:, 0] * self.e2[:, 1] - self.e1[:, 1] * self.e2[:, 0]
        self.det = det
        cross = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        area_world = 0.5 * np.linalg.norm(cross, axis=1)
        area_uv = 0.5 * np.abs(det)
        with np.errstate(divide="ignore", invalid="ignore"):
            self.jacobian = np.where(area_uv > 0, area_world / area_uv, np.inf)
            self.normal = cross / np.linalg.norm(cross, axis=1, keepdims=True)
        self.p0, self.pe1, self.pe2 = p[:, 0], p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
        lo, hi = uv.min(axis=1), uv.max(axis=1)
        self.lo, self.hi = lo.min(axis=0), hi.max(axis=0)
        count = len(p)
        self.cells = max(1, int(np.ceil(np.sqrt(count))))
        span = np.maximum(self.hi - self.lo, 1e-300)
        c_lo = np.clip(((lo - self.lo) / span * self.cells).astype(np.int64), 0, self.cells - 1)
        c_hi = np.clip(((hi - self.lo) / span * self.cells).astype(np.int64), 0, self.cells - 1)
        lists = [[] for _ in range(self.cells * self.cells)]
        for t in np.flatnonzero(area_uv > 0):
            for cy in range(c_lo[t, 1], c_hi[t, 1] + 1):
                for cx in range(c_lo[t, 0], c_hi[t, 0] + 1):
                    lists[cy * self.cells + cx].append(t)
        width = max(1, max(len(c) for c in lists))
        self.table = np.full((len(lists), width), -1, np.int64)
        for i, c in enumerate(lists):
            self.table[i, :len(c)] = c
        self.span = span

    def locate(self, uv: np.ndarray):
        """``(found, local triangle, b1, b2)`` of the coordinates ``uv`` (n, 2): the first
        triangle (in file order) whose uv triangle contains each point."""
        n = len(uv)
        cell = np.clip(((uv - self.lo) / self.span * self.cells).astype(np.int64), 0, self.cells - 1)
        inside_box = np.all((uv >= self.lo) & (uv <= self.hi), axis=1)
        cand = self.table[cell[:, 1] * self.cells + cell[:, 0]]             # (n, w)
        safe = np.maximum(cand, 0)
        d = uv[:, None, :] - self.uv0[safe]
        e1, e2, det = self.e1[safe], self.e2[safe], self.det[safe]
        with np.errstate(divide="ignore", invalid="ignore"):
            b1 = (d[..., 0] * e2[..., 1] - d[..., 1] * e2[..., 0]) / det
            b2 = (e1[..., 0] * d[..., 1] - e1[..., 1] * d[..., 0]) / det
        eps = 1e-9
        ok = (cand >= 0) & (b1 >= -eps) & (b2 >= -eps) & (b1 + b2 <= 1 + eps) & inside_box[:, None]
        ok &= np.isfinite(b1) & np.isfinite(b2)
        # First candidate in file order: the smallest triangle index among those that hold it.
        key = np.where(ok, cand, np.iinfo(np.int64).max)
        pick = np.argmin(key, axis=1)
        rows = np.arange(n)
        found = ok[rows, pick]
        tri = np.where(found, cand[rows, pick], 0)
        return found, tri, np.where(found, b1[rows, pick], 0.0), np.where(found, b2[rows, pick], 0.0)

    def point(self, tri: np.ndarray, b1: np.ndarray, b2: np.ndarray) -> np.ndarray:
        """World points (n, 3) of local triangles at barycentrics ``b1, b2``."""
        return self.p0[tri] + b1[:, None] * self.pe1[tri] + b2[:, None] * self.pe2[tri]


def parameterization(emitter, scene) -> MeshParameterization:
    """The emitter's shape in uv space, built once per process."""
    cached = getattr(emitter, "_parameterization", None)
    if cached is None:
        cached = emitter._parameterization = MeshParameterization(scene, emitter.shape)
    return cached


def surface_at(scene, shape: int, tri: np.ndarray, b1: np.ndarray, b2: np.ndarray) -> SurfaceUV:
    """Surface coordinates of points on global triangles ``tri`` (as at a hit there)."""
    b = np.stack((b1, b2), axis=1)
    if scene.tri_uv is None:
        uv = b.copy()
    else:
        corner = scene.tri_uv[tri]
        uv = ((1.0 - b1 - b2)[:, None] * corner[:, 0] + b1[:, None] * corner[:, 1]
              + b2[:, None] * corner[:, 2])
    return SurfaceUV(uv, np.full(len(tri), shape), tri, b)


def _draw_point(emitter, scene, u: np.ndarray):
    """Surface points drawn by the texture: ``(found, local triangle, b1, b2, point, area
    density)``, the density ``p_uv / |dp_du x dp_dv|`` (0 where no triangle holds the
    coordinates)."""
    mesh = parameterization(emitter, scene)
    uv, pdf_uv = emitter.radiance.sample_position(u)
    found, local, b1, b2 = mesh.locate(uv)
    with np.errstate(divide="ignore", invalid="ignore"):
        pdf_area = np.where(found, pdf_uv / mesh.jacobian[local], 0.0)
    found &= np.isfinite(pdf_area) & (pdf_area > 0)
    return found, local, b1, b2, mesh.point(local, b1, b2), np.where(found, pdf_area, 0.0)


def sample_by_texture(emitter, scene, ref_p: np.ndarray, u: np.ndarray) -> EmitterSample:
    """Next-event sample of a spatially varying radiance (see the module docstring)."""
    count = len(u)
    mesh = parameterization(emitter, scene)
    found, local, b1, b2, point, pdf_area = _draw_point(emitter, scene, u)
    normal = mesh.normal[local]
    to_light = point - ref_p
    dist = norm(to_light)
    wo = unscale(to_light, np.where(dist > 0, dist, 1.0))
    cos_light = dot(wo, normal)
    ok = found & (cos_light < 0) & (dist > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        pdf = np.where(ok, pdf_area * dist ** 2 / np.abs(cos_light), 0.0)
    ok &= np.isfinite(pdf) & (pdf > 0)
    pdf = np.where(ok, pdf, 0.0)
    weight = np.zeros((count, 3))
    rows = np.flatnonzero(ok)
    if len(rows):
        surface = surface_at(scene, emitter.shape, mesh.begin + local[rows], b1[rows], b2[rows])
        weight[rows] = emitter.radiance.eval(surface) / pdf[rows, None]
    return EmitterSample(wo, dist, pdf, weight, np.zeros(count, dtype=bool))


def sample_position(emitter, scene, u: np.ndarray):
    """Where light paths start on a spatially varying radiance (Mitsuba's
    ``AreaLight::sample_position``): the points next-event estimation draws, with their area
    density and radiance, as ``(p, n, pdf, emission)``. The normal is the shading normal
    there, the one hits on the light test their side against. Coordinates no triangle holds give pdf and
    emission 0."""
    count = len(u)
    mesh = parameterization(emitter, scene)
    found, local, b1, b2, point, pdf_area = _draw_point(emitter, scene, u)
    tri = mesh.begin + local
    tables = intersect.triangle_tables(scene)
    normal = np.take(tables.flat_n, tri, axis=0)      # the shading normal, as at a hit there
    smooth = tables.smooth[tri] & found
    if smooth.any():
        normal[smooth] = intersect.smooth_normals(scene, tri[smooth], b1[smooth], b2[smooth])
    emission = np.zeros((count, 3))
    rows = np.flatnonzero(found)
    if len(rows):
        emission[rows] = emitter.radiance.eval(surface_at(scene, emitter.shape, tri[rows],
                                                          b1[rows], b2[rows]))
    return point, normal, pdf_area, emission


def position_pdf(emitter, scene, surface: SurfaceUV) -> np.ndarray:
    """Area density (n,) with which :func:`sample_position` picks the points of surface
    coordinates ``surface`` (their uv and triangles): ``p_uv(uv) / |dp_du x dp_dv|``."""
    mesh = parameterization(emitter, scene)
    pdf_uv = emitter.radiance.pdf_position(np.asarray(surface))
    with np.errstate(divide="ignore", invalid="ignore"):
        pdf = pdf_uv / mesh.jacobian[surface.prim - mesh.begin]
    return np.where(np.isfinite(pdf), pdf, 0.0)


def pdf_by_texture(emitter, scene, ref_p, p, d, surface: SurfaceUV) -> np.ndarray:
    """Solid-angle density with which :func:`sample_by_texture` picks the hit points ``p``
    (reached along ``d``; ``surface`` their coordinates and triangles)."""
    mesh = parameterization(emitter, scene)
    cos_light = np.abs(dot(d, mesh.normal[surface.prim - mesh.begin]))
    dist2 = np.sum((p - ref_p) ** 2, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        pdf = position_pdf(emitter, scene, surface) * dist2 / cos_light
    return np.where(np.isfinite(pdf), pdf, 0.0)
