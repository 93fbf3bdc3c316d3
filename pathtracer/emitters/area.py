"""Mitsuba's ``area`` emitter: a one-sided light attached to a shape.

Area lights are one-sided: a point emits towards ``w`` only if ``dot(n_shading, w) > 0``.
Next-event estimation samples a point on the shape as Mitsuba does: meshes pick a triangle
proportionally to area, then a uniform point; disks a uniform point; a sphere seen from
outside samples the cone it subtends, from inside a uniform point on its surface. The
solid-angle pdf of an area sample is ``pdf_area * dist^2 / |cos theta_light|``. Light paths
start at a uniform point of the shape, in a cosine-weighted direction on its emitting side.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.sampling import (
    square_to_cosine_hemisphere,
    square_to_cosine_hemisphere_pdf,
    square_to_uniform_cone,
    square_to_uniform_cone_pdf,
    square_to_uniform_disk_concentric,
    square_to_uniform_sphere,
    square_to_uniform_triangle,
)
from ..core.vec import dot, norm, normalize, scale, select, to_local, to_world, unscale
from ..scene.properties import Props, children
from ..scene.registry import register
from ..scene.types import Scene
from ..shapes import intersect
from ..textures.base import ConstantTexture, Texture
from . import area_texture
from .base import Emitter, EmitterSample


@dataclass
class AreaEmitter(Emitter):
    """One-sided area light attached to a shape (front = along the shading normal).

    Attributes
    ----------
    shape : int
        Index of the shape it is attached to.
    radiance : (3,) emitted radiance.
    """

    shape: int
    radiance: np.ndarray  # (3,), or a Texture (pathtracer.emitters.area_texture)

    kind = "area"
    on_surface = True
    starts_light_paths = True

    def __post_init__(self):
        self.textured = isinstance(self.radiance, Texture)
        self.by_texture = self.textured and self.radiance.spatially_varying

    def radiance_at(self, surface) -> np.ndarray:
        """Radiance (n, 3) at surface points (:class:`~pathtracer.core.surface_uv.SurfaceUV`)."""
        if self.textured:
            return self.radiance.eval(surface)
        return np.broadcast_to(self.radiance, (len(surface), 3)).copy()

    def pdf_hit(self, scene, ref_p, p, n, d, surface=None):
        """Cone pdf from outside a sphere, else the area pdf converted to solid angle; for a
        spatially varying radiance, the texture's density (``surface``: the hits' coordinates)."""
        if self.by_texture:
            return area_texture.pdf_by_texture(self, scene, ref_p, p, d, surface)
        dist2 = np.sum((p - ref_p) ** 2, axis=1)
        cos_light = np.abs(dot(d, n))
        if scene.shape_kind[self.shape] == "sphere":
            return _sphere_pdf(scene, self.shape, ref_p, dist2, cos_light)
        return dist2 / (cos_light * scene.shape_area[self.shape])

    def sample_direction(self, scene, ref_p, u):
        """A point on the shape (see the module's docstring); samples that see its back, or graze
        it, get pdf and weight 0."""
        if self.by_texture:
            return area_texture.sample_by_texture(self, scene, ref_p, u)
        shape = self.shape
        kind = scene.shape_kind[shape]
        surface = None
        if kind == "sphere":
            point, normal, pdf = _sample_sphere(scene, shape, ref_p, u)
        elif kind == "disk":
            point, normal = _sample_disk(scene, shape, u)
            pdf = None
        else:
            point, normal, *rest = _sample_mesh(scene, shape, u, with_surface=self.textured)
            surface = rest[0] if rest else None
            pdf = None
        to_light = point - ref_p
        dist = norm(to_light)
        wo = unscale(to_light, np.where(dist > 0, dist, 1.0))
        cos_light = dot(wo, normal)
        if pdf is None:
            # A grazing sample (cos_light = 0) has an infinite solid-angle pdf: dropped below.
            with np.errstate(divide="ignore"):
                pdf = dist ** 2 / (np.abs(cos_light) * scene.shape_area[shape])
        # One-sided: the light emits only on the side its normal faces.
        facing = (cos_light < 0) & (dist > 0) & np.isfinite(pdf) & (pdf > 0)
        pdf = np.where(facing, pdf, 0.0)
        radiance = self.radiance_at(surface) if self.textured else self.radiance
        weight = select(facing, unscale(radiance, np.where(facing, pdf, 1.0)))
        return EmitterSample(wo, dist, pdf, weight, np.zeros(len(u), dtype=bool))

    def sample_position(self, scene, u):
        """A point where a light path starts, drawn as :meth:`sample_direction` draws it
        (Mitsuba's ``AreaLight::sample_position``): uniform in area (meshes by area, disks
        concentric-mapped, spheres over the whole sphere; density ``1 / area``), or from the
        texture of a spatially varying radiance (:func:`area_texture.sample_position`).
        The emission is the radiance at the point."""
        if self.by_texture:
            return area_texture.sample_position(self, scene, u)
        if self.textured:
            p, n, surface = _sample_mesh(scene, self.shape, u, with_surface=True)
            emission = self.radiance_at(surface)
        else:
            p, n = _uniform_area_point(scene, self.shape, u)
            emission = np.broadcast_to(self.radiance, (len(u), 3)).copy()
        return p, n, np.full(len(u), 1.0 / scene.shape_area[self.shape]), emission

    def sample_ray_direction(self, n, u):
        """Cosine-weighted on the emitting side: ``pdf_dir = cos / pi``, weight ``pi`` (times
        the point's radiance: ``Le cos / pdf_dir = Le pi``)."""
        d = to_world(square_to_cosine_hemisphere(u), n)
        pdf_dir = square_to_cosine_hemisphere_pdf(to_local(d, n))
        return d, pdf_dir, np.full((len(u), 3), np.pi)

    def pdf_ray_direction(self, n, d):
        return np.maximum(dot(d, n), 0.0) / np.pi

    def eval_towards(self, n, d):
        """1 on the emitting side, 0 behind (the point's radiance multiplies it)."""
        front = dot(d, n) > 0
        return np.repeat(front[:, None].astype(np.float64), 3, axis=1)

    def position_pdf(self, scene, surface, lights: int = 1) -> np.ndarray:
        """Area density (n,) with which :meth:`sample_position` picks the surface points of
        coordinates ``surface`` (a :class:`~pathtracer.core.surface_uv.SurfaceUV` of hits on
        this light), times the probability ``1 / lights`` of choosing this light."""
        if self.by_texture:
            return area_texture.position_pdf(self, scene, surface) / lights
        return np.full(len(surface), 1.0 / (scene.shape_area[self.shape] * lights))


@register("emitter", "area")
def create(props: Props):
    """An ``<emitter type="area">`` nested in (or referenced by) the shape of index
    ``props.shape_id``."""
    plugin = props.plugin
    if props.shape_id is None:
        raise plugin.error("an area emitter emits from a shape: nest it in a <shape> or "
                           "reference it there with <ref id=\"...\"/>")
    children(plugin, {"texture": 1})
    radiance = props.emission_or_texture("radiance", 1.0)
    if isinstance(radiance, ConstantTexture):   # the same everywhere: a plain colour
        radiance = radiance.value.copy()
    return AreaEmitter(shape=props.shape_id, radiance=radiance)


def _sphere_pdf(scene, shape, ref_p, dist2, cos_light):
    """Cone pdf from outside a sphere, area pdf converted to solid angle from inside."""
    k = scene.shape_prim[shape, 0]
    center, radius = scene.sphere_center[k], scene.sphere_radius[k]
    sin_alpha = radius / norm(center - ref_p)
    cos_alpha = np.sqrt(np.maximum(1 - sin_alpha ** 2, 0))
    outside = sin_alpha < 1 - 2.0 ** -24
    cone = _cone_pdf(np.where(outside, cos_alpha, 0.0))
    area = dist2 / (cos_light * scene.shape_area[shape])
    return np.where(outside, cone, area)


def _cone_pdf(cos_max: np.ndarray) -> np.ndarray:
    """Solid-angle pdf of a uniform direction in cones of half-angle acos(cos_max)."""
    axis = np.tile([0.0, 0.0, 1.0], (len(cos_max), 1))
    return square_to_uniform_cone_pdf(axis, cos_max)


def _sample_mesh(scene, shape, u, with_surface=False):
    """Triangle chosen proportionally to area (u_x reused), then a uniform point on it;
    with ``with_surface``, also the points' surface coordinates (for a textured radiance)."""
    cdf = scene.shape_tri_cdf[shape]
    begin = scene.shape_prim[shape, 0]
    local = np.minimum(np.searchsorted(cdf, u[:, 0], side="right"), len(cdf) - 1)
    low = np.where(local > 0, cdf[np.maximum(local - 1, 0)], 0.0)
    u_x = np.clip((u[:, 0] - low) / np.maximum(cdf[local] - low, 1e-300), 0.0, 1.0 - 1e-16)
    tri = begin + local
    b = square_to_uniform_triangle(np.stack((u_x, u[:, 1]), axis=1))
    tables = intersect.triangle_tables(scene)
    b1, b2 = b[:, 0], b[:, 1]
    point = np.take(tables.p0, tri, axis=0)   # p0 + b1 e1 + b2 e2, gathered with np.take
    point += scale(np.take(tables.e1, tri, axis=0), b1)
    point += scale(np.take(tables.e2, tri, axis=0), b2)
    if not tables.smooth[begin:begin + len(cdf)].any():   # flat lights: one normal each
        normal = np.take(tables.flat_n, tri, axis=0)
    else:
        normal = intersect.smooth_normals(scene, tri, b1, b2)
    if with_surface:
        return point, normal, area_texture.surface_at(scene, shape, tri, b1, b2)
    return point, normal


def _sample_disk(scene, shape, u):
    k = scene.shape_prim[shape, 0]
    to_world = scene.disk_to_world[k]
    local = square_to_uniform_disk_concentric(u)
    point = local[:, 0:1] * to_world[:3, 0] + local[:, 1:2] * to_world[:3, 1] + to_world[:3, 3]
    normal = np.linalg.inv(to_world[:3, :3]).T @ np.array([0.0, 0.0, 1.0])   # normals: inverse transpose
    normal *= (-1.0 if scene.disk_flip[k] else 1.0) / np.linalg.norm(normal)
    normal = np.tile(normal, (len(u), 1))
    return point, normal


def _sample_sphere(scene, shape, ref_p, u):
    """Cone sampling from outside, uniform area sampling from inside (Mitsuba's rule)."""
    k = scene.shape_prim[shape, 0]
    center, radius = scene.sphere_center[k], scene.sphere_radius[k]
    flip = scene.sphere_flip[k]
    to_center = center - ref_p
    dist_c = norm(to_center)
    radius_adj = radius * ((1 + 8.94e-5) if flip else (1 - 8.94e-5))
    outside = dist_c > radius_adj
    # Outside: uniform direction in the subtended cone, point = nearest intersection.
    sin_max = np.minimum(radius / np.maximum(dist_c, 1e-300), 1.0)
    cos_max = np.sqrt(np.maximum(1 - sin_max ** 2, 0))
    axis = to_center / np.maximum(dist_c, 1e-300)[:, None]
    d = to_world(square_to_uniform_cone(u, np.where(outside, cos_max, 0.0)), axis)
    b = dot(d, to_center)
    disc = np.maximum(b ** 2 - (dist_c ** 2 - radius ** 2), 0)
    t = b - np.sqrt(disc)
    cone_point = ref_p + d * t[:, None]
    # Inside: uniform point on the whole sphere.
    area_point = center + radius * square_to_uniform_sphere(u)
    point = np.where(outside[:, None], cone_point, area_point)
    outward = normalize(point - center)
    to_point = point - ref_p
    dist2 = dot(to_point, to_point)
    cos_light = np.abs(dot(normalize(to_point), outward))
    pdf = np.where(outside, _cone_pdf(cos_max),
                   dist2 / (np.maximum(cos_light, 1e-300) * scene.shape_area[shape]))
    return point, (-outward if flip else outward), pdf


def _uniform_area_point(scene: Scene, shape: int, u: np.ndarray):
    """A uniform point on a shape and its normal (the emitting side)."""
    kind = scene.shape_kind[shape]
    if kind == "disk":
        return _sample_disk(scene, shape, u)
    if kind != "sphere":
        return _sample_mesh(scene, shape, u)
    k = scene.shape_prim[shape, 0]
    outward = square_to_uniform_sphere(u)
    point = scene.sphere_center[k] + scene.sphere_radius[k] * outward
    return point, (-outward if scene.sphere_flip[k] else outward)
