"""Mitsuba's ``area`` emitter: a one-sided light attached to a shape."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.sampling import (
    square_to_uniform_cone,
    square_to_uniform_cone_pdf,
    square_to_uniform_disk_concentric,
    square_to_uniform_sphere,
    square_to_uniform_triangle,
)
from ..core.vec import dot, norm, normalize, scale, select, to_world, unscale
from ..scene.properties import Props, children
from ..scene.types import Scene
from ..scene.xml import Plugin
from ..shapes import intersect as geometry


@dataclass
class AreaEmitter:
    """One-sided area light attached to a shape (front = along the shading normal)."""

    shape: int
    radiance: np.ndarray  # (3,)
    kind: str = "area"


def build_area(plugin: Plugin, shape_id: int) -> AreaEmitter:
    """The ``<emitter type="area">`` nested in a shape."""
    if plugin.type != "area":
        raise plugin.error("only an area emitter can be nested in a shape")
    props = Props(plugin)
    children(plugin, {})
    radiance = props.color("radiance", 1.0)
    props.finish()
    return AreaEmitter(shape=shape_id, radiance=radiance)


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


def _sample_area(scene, emitter, ref_p, u, sample, rows):
    shape = emitter.shape
    kind = scene.shape_kind[shape]
    if kind == "sphere":
        point, normal, pdf = _sample_sphere(scene, shape, ref_p, u)
    else:
        point, normal = (_sample_disk if kind == "disk" else _sample_mesh)(scene, shape, u)
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
    sample.wo[rows] = wo
    sample.dist[rows] = dist
    sample.pdf[rows] = pdf
    sample.weight[rows] = select(facing, unscale(emitter.radiance, np.where(facing, pdf, 1.0)))


def _sample_mesh(scene, shape, u):
    """Triangle chosen proportionally to area (u_x reused), then a uniform point on it."""
    cdf = scene.shape_tri_cdf[shape]
    begin = scene.shape_prim[shape, 0]
    local = np.minimum(np.searchsorted(cdf, u[:, 0], side="right"), len(cdf) - 1)
    low = np.where(local > 0, cdf[np.maximum(local - 1, 0)], 0.0)
    u_x = np.clip((u[:, 0] - low) / np.maximum(cdf[local] - low, 1e-300), 0.0, 1.0 - 1e-16)
    tri = begin + local
    b = square_to_uniform_triangle(np.stack((u_x, u[:, 1]), axis=1))
    tables = geometry.triangle_tables(scene)
    b1, b2 = b[:, 0], b[:, 1]
    point = np.take(tables.p0, tri, axis=0)   # p0 + b1 e1 + b2 e2, gathered with np.take
    point += scale(np.take(tables.e1, tri, axis=0), b1)
    point += scale(np.take(tables.e2, tri, axis=0), b2)
    if not tables.smooth[begin:begin + len(cdf)].any():   # flat lights: one normal each
        return point, np.take(tables.flat_n, tri, axis=0)
    return point, geometry.smooth_normals(scene, tri, b1, b2)


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
